"""How a run ends early, for every layer: the models raise these, the controller (run.py) records
them in summary.json and the command line turns them into one line and an exit status.

Low in the package on purpose: a model imports its errors from here, never from the run module
that drives it.
"""
from __future__ import annotations


class RunFailed(RuntimeError):
    """A run ended before its end; its summary.json says why."""


class RunDiverged(RunFailed):
    """NaN, a solver failure, the sphere inside the wall, or energy the sphere cannot have."""


class RunInterrupted(RunFailed):
    """SIGINT or SIGTERM, acted on between two steps."""

    def __init__(self, message: str, signum: int):
        super().__init__(message)
        self.signum = signum

    def __reduce__(self):  # pickled whole: a study's worker process hands it back to the study
        return type(self), (str(self), self.signum)
