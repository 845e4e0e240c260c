"""How a run ends early, for every layer: the models raise these, the controller (run.py) records
them in summary.json and the command line turns them into one line and an exit status.

Every error the package raises on purpose derives from Error (fem_bounce.Error): a scene value out of
range (scene.SceneError), an unusable run directory or cache (OutputError, CheckpointError), --jobs or
--executor asked for what cannot be (RunnerError), a run that ended early (RunFailed and its kinds).  The
command line prints each as one line; a Python caller may catch them all with `except fem_bounce.Error`.

Low in the package on purpose: a model imports its errors from here, never from the run module
that drives it.
"""
from __future__ import annotations


class Error(Exception):
    """Every error fem_bounce raises on purpose; the message is one line naming the field, path or cause."""


class OutputError(Error, RuntimeError):
    """A run directory, a cache or one of their files cannot be used; the message names the path and the reason."""


class CheckpointError(OutputError):
    """A run directory's checkpoint is missing, unreadable or not this run's."""


class RunnerError(Error, ValueError):
    """--jobs or --executor cannot be used as asked; the message says what to do instead."""


class RunFailed(Error, RuntimeError):
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
