"""What a run shows while it runs, and how it is asked to stop between two steps.

    with Interrupts():   # SIGINT and SIGTERM set a flag (a second raises StopNow)
        bar = ProgressBar(end_time=0.2, diameters=[0.012], enabled=comm.rank == 0)
        monitor = Monitor(bar, comm, Interrupts.active, writers, time_unit)  # called: monitor(t, steps, gaps, V)

Work outside a run's steps that a person waits on (meshing, a study's planning) calls stop_requested() as
often.  The bar is one status line on stderr (rank 0); the monitor draws it after every step and ends the run
on every rank together when a signal has arrived (Interrupts), rank 0 could not write the
trajectory or a side file (output.TrajectoryWriter.failure), or the steps fell below their floor (STEP_FLOOR).
"""
from __future__ import annotations

import contextlib
import pickle
import signal
import sys
import time

import numpy as np

from .errors import RunDiverged, RunFailed, RunInterrupted


class StopNow(KeyboardInterrupt):
    """A second SIGINT or SIGTERM: stop at once, not after the step."""

    def __init__(self, signum: int):
        super().__init__()
        self.signum = signum


def signal_name(signum: int) -> str:
    return signal.Signals(signum).name


class Interrupts:
    """SIGINT (Ctrl-C) and SIGTERM (batch schedulers; MPICH's mpiexec passes Ctrl-C on as SIGINT, OpenMPI's
    as SIGTERM) as a request to stop.  The first sets a flag that the run checks after every step, on every
    rank together, so it ends between two steps with its summary written; a second raises StopNow at once.

        with Interrupts():
            simulate(...)        # any run inside, also through studies and the cache
    """

    active: "Interrupts | None" = None

    def __init__(self, announce: bool = True):
        self.signum = 0
        self.announce = announce
        self._previous: dict = {}

    def __enter__(self) -> "Interrupts":
        with contextlib.suppress(ValueError):  # not the main thread: signals stay as they were
            for signum in (signal.SIGINT, signal.SIGTERM):
                self._previous[signum] = signal.signal(signum, self._handle)
        Interrupts.active = self
        return self

    def __exit__(self, *exc) -> None:
        for signum, handler in self._previous.items():
            signal.signal(signum, handler)
        Interrupts.active = None

    def _handle(self, signum, frame) -> None:
        if self.signum:
            raise StopNow(signum)
        self.signum = signum
        if self.announce and sys.stderr.isatty():  # a person at a terminal; logs get the one final line
            print(f"\nfem-bounce: {signal_name(signum)} received: stopping after this step (again to stop at once)",
                  file=sys.stderr, flush=True)


def stop_requested() -> None:
    """Raise RunInterrupted when SIGINT or SIGTERM has asked this process to stop (Interrupts): for work outside a
    run's steps that a person waits on, such as a study's planning, checked as often as a run checks between steps."""
    interrupts = Interrupts.active
    if interrupts is not None and interrupts.signum:
        raise RunInterrupted(f"interrupted by {signal_name(interrupts.signum)}", interrupts.signum)


def wait_for_root(comm) -> None:
    """Every rank waits until rank 0 arrives here too, polling instead of blocking in a collective (a rank that
    waits uses no core, and a signal reaches it)."""
    arrived = comm.Ibarrier()
    while not arrived.Test():
        time.sleep(0.05)


def on_root_watching(comm, action):
    """action() on rank 0, the other ranks waiting for it without blocking in a collective, so that a signal
    that stops rank 0 (a wait that calls stop_requested: RunInterrupted) or its failure stops every rank alike;
    rank 0's result on every rank.  A second signal (StopNow) stops rank 0 at once and the others as
    interrupted; an exception that cannot travel goes to them as RunFailed with its message."""
    failure, result, own = None, None, None
    if comm.rank == 0:
        try:
            result = action()
        except Exception as err:  # noqa: BLE001 -- raised on every rank below
            failure = err
        except BaseException as err:  # noqa: BLE001 -- rank 0 raises its own; the others stop as interrupted
            own, signum = err, getattr(err, "signum", signal.SIGINT)
            failure = RunInterrupted(f"interrupted by {signal_name(signum)}", signum)
    if comm.size > 1:
        if comm.rank == 0:
            try:
                pickle.dumps(failure)
            except Exception:  # noqa: BLE001 -- an exception that cannot travel goes as its message
                failure = RunFailed(f"{type(failure).__name__}: {failure}")
        wait_for_root(comm)
        failure, result = comm.bcast((failure, result), root=0)
    if own is not None:
        raise own
    if failure is not None:
        raise failure
    return result


class ProgressBar:
    """One status line on stderr (rank 0): model time, steps, gaps, speeds and the remaining wall time."""

    def __init__(self, end_time: float, diameters, enabled: bool = True, every: float = 1.0):
        """end_time [s] scales the bar, the bodies' `diameters` [m] (sphere 1 first) the gaps; `every` [s of
        wall time] thins the lines written to a log (a terminal's line is redrawn every 0.2 s)."""
        self.end_time, self.enabled, self.every = end_time, enabled, every
        self.diameters = np.asarray(diameters, dtype=float)
        self.start = time.perf_counter()
        self._last = -float("inf")
        self._tty = sys.stderr.isatty()

    def __call__(self, t: float, steps: int, gaps: np.ndarray, velocities: np.ndarray, force: bool = False) -> None:
        """t [s]; the bodies' gaps above z = 0 [m] and velocities [m/s], arrays with sphere 1 first."""
        now = time.perf_counter()
        if not self.enabled or (now - self._last < (0.2 if self._tty else self.every) and not force):
            return
        self._last = now
        elapsed = now - self.start
        fraction = min(max(t / self.end_time, 0.0), 1.0)
        left = f"~{elapsed * (1.0 - fraction) / fraction:4.0f} s left" if fraction > 0.01 else ""
        width = 24
        bar = "#" * int(width * fraction) + "-" * (width - int(width * fraction))
        # sphere 1's gap to z = 0, then each neighbouring pair's surface gap over the lower sphere's D
        d = self.diameters
        where = f"gap/D {gaps[0] / d[0]:7.4f}"
        if len(gaps) > 1:
            between = (np.diff(gaps) - d[:-1]) / d[:-1]
            where += "  pair gap/D " + ", ".join(f"{s:8.5f}" for s in between)
        where += "  V " + ", ".join(f"{v:+.4f}" for v in velocities) + " m/s"
        line = f"[{bar}] t = {t:.4f}/{self.end_time:g} s  step {steps}  {where}  {elapsed:5.0f} s elapsed {left}"
        print(("\r" + line) if self._tty else line, end="" if self._tty else "\n", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.enabled and self._tty:
            print(file=sys.stderr)


# The step floor: a run whose steps, over STEP_FLOOR_WINDOW of them, advance less than STEP_FLOOR time units each on
# average (sqrt(D/g), or D over the launch speed) cannot reach its end (one time unit would take 1e9 steps, days of
# the ode model's ~2,000 steps a second): it ends as diverged.  The adaptive integrators restart at 1e-7 time units
# after an event (integrator._new_ts) and grow tenfold a step, so no healthy run comes near it.
STEP_FLOOR = 1e-9
STEP_FLOOR_WINDOW = 1000


class Monitor:
    """What the run calls after each step: the bar, the stop requests and the step floor (module docstring)."""

    def __init__(self, bar: ProgressBar, comm, interrupts, writers=(), time_unit: float = 0.0):
        """`interrupts`: an Interrupts (its `signum` is set by SIGINT/SIGTERM) or None; `writers`: rank 0's
        output.TrajectoryWriters (none elsewhere and when the run writes nothing); `time_unit` [s]: the scene's,
        for the step floor (0: none)."""
        self.bar, self.comm, self.interrupts, self.writers = bar, comm, interrupts, list(writers)
        self.floor = STEP_FLOOR * time_unit
        self.steps = 0
        self._window: tuple[int, float] | None = None  # (steps, t) where the floor's window began

    def __call__(self, t: float, steps: int, gaps: np.ndarray, velocities: np.ndarray, force: bool = False) -> None:
        self.steps = steps
        self.bar(t, steps, gaps, velocities, force=force)
        failed = next((writer.failure for writer in self.writers if writer.failure is not None), None)
        flags = np.array([self.interrupts.signum if self.interrupts is not None else 0, int(failed is not None)])
        if self.comm.size > 1:
            from mpi4py import MPI

            self.comm.Allreduce(MPI.IN_PLACE, flags, op=MPI.MAX)
        if flags[1]:
            raise RunFailed(str(failed) if failed is not None else "rank 0 could not write the trajectory")
        if flags[0]:
            signum = int(flags[0])
            raise RunInterrupted(f"interrupted by {signal.Signals(signum).name} at t = {t:.6g} s", signum)
        self._check_floor(t, steps, gaps, velocities)

    def _check_floor(self, t: float, steps: int, gaps: np.ndarray, velocities: np.ndarray) -> None:
        """End the run (RunDiverged) when its last STEP_FLOOR_WINDOW steps advanced less than the floor each on
        average (identical on every rank: the bodies' integrators are)."""
        if self._window is None or steps < self._window[0]:
            self._window = (steps, t)
        taken, start = steps - self._window[0], self._window[1]
        if taken < STEP_FLOOR_WINDOW:
            return
        self._window = (steps, t)
        if t - start >= taken * self.floor:
            return
        d = self.bar.diameters
        where = ", ".join(f"{gap / d[0]:.4g}" for gap in gaps)
        speeds = ", ".join(f"{v:+.3g}" for v in velocities)
        raise RunDiverged(
            f"the step fell below its floor: the last {taken} steps advanced {t - start:.3g} s to t = {t:.6g} s, "
            f"{(t - start) / taken:.3g} s a step against a floor of {STEP_FLOOR:g} time units ({self.floor:.3g} s): "
            f"the bodies' integration has stalled (gaps {where} D, V {speeds} m/s), a contact or a coupling too stiff "
            "for its step; nothing was computed wrong up to here")
