"""What a run shows while it runs, and how it is asked to stop between two steps.

    bar = ProgressBar(end_time=0.2, diameters=[0.012], enabled=comm.rank == 0)
    monitor = Monitor(bar, comm, interrupts, writer)   # the run calls monitor(t, steps, gaps, velocities)

The bar is one status line on stderr (rank 0); the monitor draws it after every step and ends the run
on every rank together when a signal has arrived (run.Interrupts) or rank 0 could not write the
trajectory (output.TrajectoryWriter.failure).
"""
from __future__ import annotations

import signal
import sys
import time

import numpy as np

from .errors import RunFailed, RunInterrupted


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


class Monitor:
    """What the run calls after each step: the bar, and the stop requests (module docstring)."""

    def __init__(self, bar: ProgressBar, comm, interrupts, writer):
        """`interrupts`: a run.Interrupts (its `signum` is set by SIGINT/SIGTERM) or None; `writer`: rank 0's
        output.TrajectoryWriter (None elsewhere and when the run writes nothing)."""
        self.bar, self.comm, self.interrupts, self.writer = bar, comm, interrupts, writer
        self.steps = 0

    def __call__(self, t: float, steps: int, gaps: np.ndarray, velocities: np.ndarray, force: bool = False) -> None:
        self.steps = steps
        self.bar(t, steps, gaps, velocities, force=force)
        flags = np.array([self.interrupts.signum if self.interrupts is not None else 0,
                          int(self.writer is not None and self.writer.failure is not None)])
        if self.comm.size > 1:
            from mpi4py import MPI

            self.comm.Allreduce(MPI.IN_PLACE, flags, op=MPI.MAX)
        if flags[1]:
            raise RunFailed(str(self.writer.failure) if self.writer is not None and self.writer.failure
                            else "rank 0 could not write the trajectory")
        if flags[0]:
            signum = int(flags[0])
            raise RunInterrupted(f"interrupted by {signal.Signals(signum).name} at t = {t:.6g} s", signum)
