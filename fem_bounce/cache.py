"""Finished runs, reused: a study asks for (scene, model) and gets the run directory.

A run is keyed by its resolved scene (as TOML), its model and the code that computes it: a hash of the
shared core (scene, theory, contact, sphere integrator, run driver) and of that model's own modules, and
the versions of the numerical libraries under them (another PETSc or gmsh moves the digits), so
redrawing a figure never re-runs a simulation, changing the physics or the stack never reuses a stale
answer, and adding or changing one model leaves the other models' runs valid.  (numerics.py is data: its values
enter through the resolved scene.)  An interrupted
study resumes where it stopped: finished runs are found, unfinished ones run again.

    run_dir = cached_run(scene, "fd", comm)                 # ~/.cache/fem_bounce/runs/<key>/ (cachedir)
"""
from __future__ import annotations

import contextlib
import fcntl
import functools
import hashlib
import json
import os
import re
import shutil
import time
from importlib import metadata
from pathlib import Path

from . import cachedir, models
from . import scene as scenes
from .errors import OutputError, RunDiverged, RunFailed, RunInterrupted
from .models.registry import CORE_SOURCES
from .output import MARKER, atomic_write_text, file_digest, read_summary
from .progress import on_root_watching, stop_requested
from .run import on_root, simulate

POLL_SECONDS = 0.1  # how often a wait for another process's run of the same entry looks for a signal

def default_root() -> Path:
    """The finished runs' folder in fem_bounce's cache ($FEM_BOUNCE_CACHE/runs, fem_bounce.cachedir)."""
    return cachedir.folder("runs")


@functools.cache
def code_version(model: str) -> str:
    """Hash of the source files that decide this model's numbers."""
    package = Path(__file__).parent
    digest = hashlib.sha256()
    for name in CORE_SOURCES + models.info(model).sources:
        path = package / name
        files = sorted(path.rglob("*.py")) if path.is_dir() else [path] if path.exists() else []
        for source in files:
            digest.update(str(source.relative_to(package)).encode())
            digest.update(source.read_bytes())
    return digest.hexdigest()[:12]


# the distributions whose versions move a run's digits: the PyPI stack's wheel, or conda-forge's packages
STACK_DISTRIBUTIONS = ("numpy", "scipy", "dolfinx-solver-real", "fenics-dolfinx", "petsc4py", "fenics-basix",
                       "fenics-ffcx", "fenics-ufl", "gmsh")


@functools.cache
def stack_version() -> str:
    """The installed versions of STACK_DISTRIBUTIONS (those present), read without importing them."""
    found = []
    for name in STACK_DISTRIBUTIONS:
        try:
            found.append(f"{name}=={metadata.version(name)}")
        except metadata.PackageNotFoundError:
            pass
    return ",".join(found)


def run_key(scene: scenes.Scene, model: str) -> str:
    """The key of a run: its model, code and libraries, its resolved scene and the content of every file the scene
    names (motion.series: the scene holds only its path, and an edited series must not hit the old run)."""
    text = f"{model}\n{code_version(model)}\n{stack_version()}\n{scenes.dumps(scene)}"
    if scene.motion.series:
        try:
            text += f"\nmotion.series: {file_digest(Path(scene.motion.series))}"
        except OSError as err:
            raise scenes.SceneError(f"motion.series = {scene.motion.series!r}: {err.strerror or err}") from None
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def run_directory(scene: scenes.Scene, model: str, root: Path | None = None) -> Path:
    """Where the run of `model` on `scene` is (or will be) cached (root: default_root())."""
    return Path(root or default_root()) / f"{scene.name}-{model}-{run_key(scene, model)}"


ENTRY = "cache-entry.json"  # written last into a finished entry: the hashes of the files the studies read
ENTRY_FILES = ("scene.toml", "summary.json", "trajectory.csv")


def finished(run_dir: Path) -> Path | None:
    """run_dir if it holds a finished run (completed or diverged) that is whole: its entry file lists the hashes of
    its files and they still match (a run killed before its summary, interrupted or failed is not finished, and a
    damaged entry or a directory the cache did not write is not trusted: both run again)."""
    run_dir = Path(run_dir)
    try:
        entry = json.loads((run_dir / ENTRY).read_text())
        if entry.get("key") != run_dir.name or any(file_digest(run_dir / name) != entry["files"].get(name)
                                                   for name in ENTRY_FILES):
            return None
        status = read_summary(run_dir).get("status", "")
    except (OSError, ValueError, AttributeError, KeyError, TypeError):  # missing, cut short, edited
        return None
    return None if status.startswith(("interrupted", "failed")) else run_dir


def cached_run(scene: scenes.Scene, model: str, comm, root: Path | None = None, progress: bool = False,
               command: str = "") -> Path:
    """The directory of a finished run of `model` on `scene` (completed or diverged), running it if needed.

    One process at a time makes an entry: the others wait for its lock (watching for signals) and then find it
    finished, so identical studies at once share their runs.  The run is made in a directory of its own beside the
    entry and renamed into place once finished, its entry file written last; a damaged entry is made again."""
    run_dir = run_directory(scene, model, root)
    # decided on rank 0 for every rank: a rank that arrives after rank 0 has finished the run would
    # otherwise skip the run's collectives that the others are in
    if comm.bcast(finished(run_dir) is not None if comm.rank == 0 else None, root=0):
        return run_dir
    lock = on_root_watching(comm, lambda: _lock(run_dir))
    try:
        if not comm.bcast(finished(run_dir) is not None if comm.rank == 0 else None, root=0):  # made meanwhile?
            # one name: only the lock's holder makes it, and a maker killed outright left its run here to replace
            partial = run_dir.with_name(f".{run_dir.name}.partial")
            try:
                simulate(scene, model, comm, partial, force=True, progress=progress, plots=False,
                         command=command or f"cached run of {scene.name} with {model}")
            except RunDiverged:
                pass  # recorded in summary.json; a study classifies it (an interrupted or failed run is redone)
            except (RunFailed, OutputError) as err:  # its folder goes (_settle): the message must not name it
                raise _unkept(err, f"the study cache's run of {scene.name} with the {model} model in "
                                   f"{run_dir.parent}") from None
            finally:
                on_root(comm, lambda: _settle(partial, run_dir))
    finally:
        if comm.rank == 0:  # rank 0 alone holds the lock (its number reached every rank)
            os.close(lock)
    return run_dir


def _unkept(err: RunFailed | OutputError, what: str) -> RunFailed | OutputError:
    """`err` (the same kind: the same exit status) for a run whose unfinished folder is removed (_settle), so
    naming `what` instead of that folder: interrupted at a time, or not made for a reason, the last "...: reason"
    of the message (the system's word, e.g. "File too large", before any "(...)" or "; ..." that follows)."""
    if isinstance(err, RunInterrupted):
        return RunInterrupted(f"{str(err).split(';')[0]}: {what} is not kept; it runs again next time", err.signum)
    reasons = re.findall(r": ([^:;()]+?)(?= \(|;|$)", str(err))
    return type(err)(f"cannot make {what}: {reasons[-1] if reasons else err}; nothing of it is kept")


def _lock(run_dir: Path) -> int:
    """Take the entry's lock (a file beside it, flock), waiting while another process makes the same run."""
    path = run_dir.with_name(f".{run_dir.name}.lock")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as err:
        raise OutputError(f"cannot use {path.parent} as fem_bounce's cache: {err.strerror or err}") from None
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return fd
        except BlockingIOError:
            pass
        try:
            stop_requested()
        except BaseException:
            os.close(fd)
            raise
        time.sleep(POLL_SECONDS)


def _settle(partial: Path, run_dir: Path) -> None:
    """A finished run in `partial` becomes the entry `run_dir` (its files fsynced, the entry file last); an
    unfinished one is removed (it runs again)."""
    status = ""
    with contextlib.suppress(OSError, ValueError):
        status = read_summary(partial).get("status", "")
    if not status or status.startswith(("interrupted", "failed")):
        shutil.rmtree(partial, ignore_errors=True)
        return
    try:
        if run_dir.exists():  # an earlier entry, damaged or unfinished
            shutil.rmtree(run_dir)
        (partial / MARKER).unlink(missing_ok=True)  # the cache's entry, not a run directory --force may replace
        files = {name: file_digest(partial / name) for name in ENTRY_FILES}
        partial.replace(run_dir)
        atomic_write_text(run_dir / ENTRY, json.dumps({"key": run_dir.name, "files": files}, indent=1) + "\n")
    except OSError as err:
        raise OutputError(f"cannot write the cache entry {run_dir}: {err.strerror or err}") from None
