"""What the libraries say during a run, kept for the run directory's run.log instead of the terminal; and the
package's one-line messages on the terminal, which a library's warning also becomes.

On a form's first compile ffcx leaves its C file open (a ResourceWarning) and cffi's distutils logs the
compiler's command lines at INFO on the root logger (ffcx's import put a stderr handler there), between the
run's own lines; whether that happens depends on the machine's form cache, not on the run.  Inside
`library_output()` the root logger's records go to LIBRARY_LOG alone; run.run_logged (behind `fem-bounce run`
and fem_bounce.simulate) appends them to the run directory's run.log once the run has begun.  The command line
sets RANK and LIBRARY_LOG.verbose (`fem-bounce run --verbose`: every line on the terminal as well) and sends
the libraries' warnings here too.  `quiet_on_a_closed_pipe()` keeps a command quiet when its reader goes away
(`fem-bounce scenes | head -1`).
"""
from __future__ import annotations

import contextlib
import logging
import os
import signal
import sys
import warnings
from pathlib import Path

from . import output

RANK = 0  # this process's MPI rank, as the command line found it (cli.main): only rank 0 speaks


def say(text: str) -> None:
    """One line on stderr, once under mpiexec (every rank meets the same error)."""
    if RANK == 0:
        print(f"fem-bounce: {text}", file=sys.stderr, flush=True)


class LibraryLog(logging.Handler):
    """What the libraries say, kept for the run directory's run.log instead of the terminal (the module
    docstring)."""

    def __init__(self):
        super().__init__(logging.DEBUG)
        self.setFormatter(logging.Formatter("%(levelname)s:%(name)s:%(message)s"))
        self.lines: list[str] = []
        self.verbose = False  # run --verbose: every line on the terminal (stderr) as well

    def emit(self, record: logging.LogRecord) -> None:
        self._add(self.format(record))
        if not self.verbose and record.levelno >= logging.WARNING:  # a library's own warning still shows, on one line
            say(f"{record.levelname.lower()}: {record.name}: {record.getMessage().splitlines()[0]}")

    def add_warning(self, message, category, filename: str, lineno: int) -> None:
        self._add(warnings.formatwarning(message, category, filename, lineno, "").rstrip())

    def _add(self, line: str) -> None:
        """A line for run.log, and under --verbose for the terminal too (rank 0)."""
        self.lines.append(line)
        if self.verbose and RANK == 0:
            print(line, file=sys.stderr, flush=True)

    def keep(self, run_dir: Path | None, comm) -> None:
        """Append what was said to run_dir/run.log (rank 0; nothing to say, no file); dropped without a run
        directory.  Called only once the run has begun: a refused run leaves its --out as it was."""
        lines, self.lines = self.lines, []
        if comm.rank != 0 or not lines or run_dir is None or not output.is_run_directory(run_dir):
            return
        with contextlib.suppress(OSError):  # a courtesy: an unwritable directory has said so already
            with open(Path(run_dir) / "run.log", "a") as stream:
                stream.write("\n".join(lines) + "\n")


LIBRARY_LOG = LibraryLog()


@contextlib.contextmanager
def library_output():
    """The libraries' logging into LIBRARY_LOG alone while a command or a run goes on; as it was afterwards."""
    root = logging.getLogger()
    if LIBRARY_LOG in root.handlers:  # already (a run inside a command): as it is
        yield
        return
    before = root.handlers[:]
    for handler in before:
        root.removeHandler(handler)
    root.addHandler(LIBRARY_LOG)  # and ffcx's logging.basicConfig() on import does nothing
    if not LIBRARY_LOG.verbose:
        for name in ("ffcx", "FFCX", "UFL"):  # their INFO lines would go to run.log only anyway
            logging.getLogger(name).setLevel(logging.WARNING)
    LIBRARY_LOG.lines.clear()
    try:
        yield
    finally:
        root.removeHandler(LIBRARY_LOG)
        for handler in before:
            root.addHandler(handler)


class _UntilClosed:
    """stdout or stderr that, once its reader has gone (`fem-bounce scenes | head -1`: EPIPE), sends the rest to
    /dev/null at the descriptor (what C libraries write too), so that the command goes on, a run to its summary,
    and ends quietly, as a command line tool does on a closed pipe."""

    def __init__(self, stream):
        self.stream = stream

    def write(self, text: str) -> int:
        try:
            return self.stream.write(text)
        except BrokenPipeError:
            self._discard()
            return len(text)

    def flush(self) -> None:
        try:
            self.stream.flush()
        except BrokenPipeError:
            self._discard()

    def _discard(self) -> None:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, self.stream.fileno())  # the buffered rest is flushed into it, without an error
        os.close(devnull)

    def __getattr__(self, name: str):
        return getattr(self.stream, name)


@contextlib.contextmanager
def quiet_on_a_closed_pipe():
    """SIGPIPE ignored again, as Python sets it, over PETSc's handler (which printed PETSC ERROR lines and aborted
    the job when a pipe's reader went away): a write to it then fails with EPIPE, which _UntilClosed absorbs.  And
    stdout never raises UnicodeEncodeError where the locale's encoding is ASCII (LC_ALL=C)."""
    with contextlib.suppress(ValueError):  # not the main thread: signals stay as they were
        signal.signal(signal.SIGPIPE, signal.SIG_IGN)
    streams = sys.stdout, sys.stderr
    sys.stdout, sys.stderr = _UntilClosed(sys.stdout), _UntilClosed(sys.stderr)
    with contextlib.suppress(AttributeError, ValueError):  # a stream that is not a terminal's, a pipe's or a file's
        sys.stdout.reconfigure(errors="backslashreplace")
    try:
        yield
    finally:
        if isinstance(sys.stdout, _UntilClosed):  # else /dev/null, after the output failed (cli.main)
            sys.stdout = streams[0]
        sys.stderr = streams[1]
