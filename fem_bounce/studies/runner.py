"""How a study's runs are spread: the runs of a study are independent, so they can go to several
processes at once; the run cache (fem_bounce.cache) makes the result the same whichever way they go.

    fem-bounce restitution --model fd --jobs 2               # 2 processes on this machine
    mpiexec -n 9 python -m mpi4py.futures -m fem_bounce restitution --model fd --executor mpi
                                                              # 8 workers over an MPI allocation

- jobs = 1 (the default): one run after the other on the study's communicator; under plain `mpiexec`
  each run uses every rank (the fd and ale models solve in parallel, ode and ib run on rank 0).
- jobs = N > 1: N worker processes on this machine (multiprocessing, "spawn"), each run serial.
- executor "mpi": the workers of an `mpi4py.futures` pool; the study runs on rank 0 of
  `mpiexec -n K python -m mpi4py.futures -m fem_bounce ...` and the K - 1 other ranks run one serial
  run each at a time, so a study scales past one machine.

Finished runs are read from the cache in the study's own process and never submitted, identical runs
are submitted once, and a killed study loses only the runs in progress: run the same command again.
On SIGINT or SIGTERM the study cancels the runs not yet started, asks the running ones to stop
between two steps (they are recorded as interrupted, and redone next time) and raises RunInterrupted.
"""
from __future__ import annotations

import concurrent.futures as cf
import multiprocessing
import numbers
import os
import signal
from pathlib import Path
from typing import Iterator

from .. import scene as scenes
from ..cache import cached_run, default_root, finished, run_directory
from ..errors import RunFailed, RunInterrupted, RunnerError
from ..mpi_pool import run_one, start_worker, under_mpi_futures
from ..progress import Interrupts, signal_name

EXECUTORS = ("local", "mpi")
POLL_SECONDS = 0.2  # how often the study looks for a signal while its workers run


class Runner:
    """Runs (scene, model) pairs through the cache and yields (index, run directory) as each finishes."""

    def __init__(self, comm, jobs: int = 1, executor: str = "local", root: Path | None = None):
        if executor not in EXECUTORS:
            raise RunnerError(f"--executor {executor!r}: choose one of {', '.join(EXECUTORS)}")
        if isinstance(jobs, numbers.Integral) and not isinstance(jobs, bool):
            jobs = int(jobs)  # NumPy's integers too
        if not isinstance(jobs, int) or isinstance(jobs, bool) or jobs < 1:
            raise RunnerError(f"--jobs {jobs!r}: give a whole number of processes, 1 or more")
        if executor == "mpi":
            if jobs != 1:
                raise RunnerError("--jobs applies to --executor local; with --executor mpi the workers are the "
                                  "mpiexec ranks after the first")
            if not under_mpi_futures():
                raise RunnerError("--executor mpi runs the study's runs on the workers of an mpi4py.futures pool: "
                                  "start it as `mpiexec -n K python -m mpi4py.futures -m fem_bounce study ... "
                                  "--executor mpi` with K >= 2 (K - 1 workers)")
        elif jobs > 1 and comm.size > 1:
            raise RunnerError(f"--jobs {jobs} starts its own processes: run it without mpiexec, or spread the runs "
                              "over MPI ranks with `mpiexec -n K python -m mpi4py.futures -m fem_bounce ... "
                              "--executor mpi`")
        self.comm, self.jobs, self.executor = comm, jobs, executor
        if root is not None and not isinstance(root, (str, os.PathLike)):
            raise RunnerError(f"cache = {root!r} must be a folder's path (or None for fem_bounce's cache)")
        self.root = Path(root or default_root()).absolute()
        self._executor: cf.Executor | None = None  # the worker pool, started at first use, kept until close()

    def __enter__(self) -> "Runner":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        """Let the workers go (a Runner that was never asked to spread anything has none)."""
        if self._executor is not None:
            self._executor.shutdown(wait=True, cancel_futures=True)
            self._executor = None

    @property
    def parallel(self) -> bool:
        return self.executor == "mpi" or self.jobs > 1

    def map(self, function, *iterables) -> list:
        """[function(*items)], in order, spread over the workers like the runs; for short, independent
        pieces of a study (the restitution planning's ODE runs).  function must be a module-level function."""
        if not self.parallel:
            return list(map(function, *iterables))
        calls = list(zip(*iterables))
        found: list = [None] * len(calls)
        for k, result in self._watch({self._pool().submit(function, *args): k for k, args in enumerate(calls)}):
            found[k] = result
        return found

    @property
    def workers(self) -> int:
        if self.executor == "mpi":
            from mpi4py import MPI

            return MPI.COMM_WORLD.size - 1
        return self.jobs

    def describe(self) -> str:
        if self.executor == "mpi":
            return f"{self.workers} MPI worker(s) of mpi4py.futures"
        if self.jobs > 1:
            return f"{self.jobs} local processes"
        return f"one run at a time on {self.comm.size} rank(s)"

    def run(self, tasks: list[tuple[scenes.Scene, str]]) -> Iterator[tuple[int, Path]]:
        """(index into tasks, finished run directory), cached runs first, then in the order they finish."""
        directories = [run_directory(scene, model, self.root) for scene, model in tasks]
        # rank 0's view of the cache for every rank: a rank that comes later must not find the run rank 0
        # has just finished and skip the collective run the others are in
        done = self.comm.bcast([finished(d) is not None for d in directories] if self.comm.rank == 0 else None,
                               root=0)
        pending: dict[Path, list[int]] = {}
        for k, run_dir in enumerate(directories):
            if done[k]:
                yield k, run_dir
            else:
                pending.setdefault(run_dir, []).append(k)
        if not pending:
            return
        if not self.parallel:
            for run_dir, indices in pending.items():
                scene, model = tasks[indices[0]]
                cached_run(scene, model, self.comm, root=self.root)
                for k in indices:
                    yield k, run_dir
            return
        yield from self._in_pool({d: (tasks[ks[0]], ks) for d, ks in pending.items()})

    def _pool(self) -> cf.Executor:
        if self._executor is None:
            self._executor = self._start_pool()
        return self._executor

    def _start_pool(self) -> cf.Executor:
        if self.executor == "mpi":
            from mpi4py.futures import MPIPoolExecutor

            # main=False: a worker must not import __main__, which is the study itself under `-m fem_bounce`
            return MPIPoolExecutor(main=False, initializer=start_worker)
        # spawn, not fork: the study's process has initialised MPI, which a forked child must not inherit;
        # one thread per worker, so that N workers use N cores (a worker imports numpy after this).
        previous = {name: os.environ.get(name) for name in _ONE_THREAD}
        os.environ.update({name: "1" for name in _ONE_THREAD if previous[name] is None})
        try:
            return cf.ProcessPoolExecutor(self.jobs, mp_context=multiprocessing.get_context("spawn"),
                                          initializer=start_worker)
        finally:
            for name, value in previous.items():
                if value is None:
                    os.environ.pop(name, None)

    def _in_pool(self, pending: dict) -> Iterator[tuple[int, Path]]:
        pool = self._pool()
        futures = {pool.submit(run_one, scene, model, str(self.root)): (run_dir, indices)
                   for run_dir, ((scene, model), indices) in pending.items()}
        for (run_dir, indices), _ in self._watch(futures):
            for k in indices:
                yield k, run_dir

    def _watch(self, futures: dict) -> Iterator[tuple]:
        """(futures[f], f's result) as each of `futures` finishes, while watching for a signal (Interrupts) every
        POLL_SECONDS: on one the runs not started are cancelled, the running ones asked to stop, and
        RunInterrupted raised; a failed one stops the rest and is raised."""
        pool = self._pool()
        interrupts = Interrupts.active
        signum, failure = 0, None
        try:
            waiting = set(futures)
            while waiting:
                done, waiting = cf.wait(waiting, timeout=POLL_SECONDS, return_when=cf.FIRST_COMPLETED)
                for future in done:
                    if future.cancelled():
                        continue
                    error = future.exception()
                    if error is None:
                        yield futures[future], future.result()
                    elif failure is None:
                        failure = error
                if interrupts is not None and interrupts.signum and not signum:
                    signum = interrupts.signum
                    self._stop_workers(futures, signum)
                if failure is not None and not signum:
                    signum = -1  # stop the rest: the study cannot finish
                    self._stop_workers(futures, 0)
        except BaseException:
            self._stop_workers(futures, signal.SIGTERM)
            pool.shutdown(wait=False, cancel_futures=True)
            self._executor = None
            raise
        if signum > 0:
            raise RunInterrupted(f"interrupted by {signal_name(signum)}; the finished runs are cached: run the "
                                 "same command again to continue the study", signum)
        if isinstance(failure, (RunFailed, scenes.SceneError)):
            raise failure
        if failure is not None:
            raise RunFailed(f"a study worker failed: {type(failure).__name__}: {failure}") from failure

    def _stop_workers(self, futures: dict, signum: int) -> None:
        """Cancel the runs not yet started; with a signal, ask the local workers' runs to stop too (an
        MPI pool's workers receive mpiexec's SIGTERM themselves)."""
        for future in futures:
            future.cancel()
        if signum and self.executor == "local":
            for child in multiprocessing.active_children():
                if child.pid is not None:
                    os.kill(child.pid, signal.SIGTERM)


_ONE_THREAD = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def study_runner(jobs: int, executor: str, comm=None, cache: str | Path | None = None) -> tuple:
    """(the study's communicator, its Runner) from --jobs and --executor.  Under mpi4py.futures only rank 0
    runs the study, so it works on COMM_SELF and leaves COMM_WORLD to the pool."""
    from mpi4py import MPI

    if comm is None:
        comm = MPI.COMM_SELF if executor == "mpi" else MPI.COMM_WORLD
    return comm, Runner(comm, jobs, executor, root=cache)
