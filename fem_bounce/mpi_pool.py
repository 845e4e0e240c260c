"""A study's runs on the workers of an `mpi4py.futures` pool, and on local worker processes.

    mpiexec -n K python -m mpi4py.futures -m fem_bounce study ... --executor mpi

Under `-m mpi4py.futures` only rank 0 runs the command; the other K - 1 ranks wait for tasks and never
join a collective call on COMM_WORLD.  PETSc initialises on COMM_WORLD by default, and that is
collective, so the study and every worker must give PETSc COMM_SELF before anything imports
petsc4py.PETSc: this module imports neither PETSc nor the rest of the package at import time.
"""
from __future__ import annotations

import ctypes
import os
import signal
import sys
import warnings

PR_SET_PDEATHSIG = 1  # linux/prctl.h


def under_mpi_futures() -> bool:
    """True on the master of `python -m mpi4py.futures` with at least one worker rank.  mpi4py has no
    public query for it; its shared pool is the attribute that the `-m mpi4py.futures` launcher sets
    (in `mpi4py.futures._core` since mpi4py 4, `_lib` before; 3.1 has both modules, the pool in `_lib`)."""
    import importlib

    from mpi4py import MPI

    for name in ("mpi4py.futures._core", "mpi4py.futures._lib"):
        try:
            if getattr(importlib.import_module(name), "SharedPool", None) is not None:
                return MPI.COMM_WORLD.size > 1
        except ImportError:
            continue
    return False


def petsc_on_self() -> None:
    """Initialise PETSc on COMM_SELF, unless it is initialised already (then nothing changes)."""
    if "petsc4py.PETSc" in sys.modules:
        return
    import petsc4py
    from mpi4py import MPI

    petsc4py.init(comm=MPI.COMM_SELF)


def start_worker() -> None:
    """In each worker process: PETSc on COMM_SELF; SIGTERM stops the current run between two steps (it is
    recorded as interrupted and redone next time); SIGINT, a terminal's Ctrl-C, is left to the study's
    process, which passes it on as SIGTERM; warnings are one line each; the libraries' INFO logging (the
    form compiler's gcc command lines on a cold cache) is dropped, their warnings kept.  A worker dies
    with the study's process (_die_with_parent)."""
    _die_with_parent()
    petsc_on_self()
    import logging

    quiet = logging.StreamHandler(sys.stderr)
    quiet.setLevel(logging.WARNING)
    logging.getLogger().handlers[:] = [quiet]  # ffcx's logging.basicConfig() then adds no handler of its own
    from .run import Interrupts  # PETSc: after petsc_on_self() above, before Interrupts installs its handlers

    Interrupts(announce=False).__enter__()
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    warnings.simplefilter("default")
    warnings.simplefilter("ignore", ResourceWarning)  # the form compiler's JIT leaves files to the collector
    warnings.showwarning = lambda message, *args, **kwargs: print(
        f"fem-bounce: worker {os.getpid()}: warning: {message}", file=sys.stderr, flush=True)


def _die_with_parent() -> None:
    """Linux: the kernel sends this process SIGKILL when its parent, the study, dies, however it dies
    (SIGKILL included), so no worker runs on for nobody (its unfinished run is redone next time, as
    after any interruption).  Elsewhere nothing happens."""
    if not sys.platform.startswith("linux"):
        return
    try:
        ctypes.CDLL(None, use_errno=True).prctl(PR_SET_PDEATHSIG, int(signal.SIGKILL))
    except (OSError, AttributeError):
        return
    if os.getppid() == 1:  # the parent died before the request was made
        os._exit(1)


def run_one(scene, model: str, root: str) -> str:
    """One run through the cache, serial, in a worker process; its run directory."""
    from pathlib import Path

    from mpi4py import MPI

    from .cache import cached_run  # PETSc, in a worker that start_worker gave COMM_SELF

    return str(cached_run(scene, model, MPI.COMM_SELF, root=Path(root)))
