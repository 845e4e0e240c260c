"""Where fem_bounce keeps what it can make again: generated meshes (meshes/) and the finished runs that
studies reuse (runs/).

    $FEM_BOUNCE_CACHE              when set
    $XDG_CACHE_HOME/fem_bounce     else, when XDG_CACHE_HOME is set to an absolute path (the XDG base directory
                                   rule: a relative one is invalid and ignored)
    ~/.cache/fem_bounce            else

Never the source tree nor the working directory, nor inside a run directory (a run's folder is the run's alone:
`--force` may replace it); the folder may be deleted at any time.
"""
from __future__ import annotations

import os
from pathlib import Path

from .errors import OutputError

VARIABLE = "FEM_BOUNCE_CACHE"
RUN_MARKER = ".fem-bounce-run"  # the file that marks a run directory (output.MARKER; output imports this module)


def root() -> Path:
    if os.environ.get(VARIABLE):
        return Path(os.environ[VARIABLE])
    if os.path.isabs(os.environ.get("XDG_CACHE_HOME", "")):
        return Path(os.environ["XDG_CACHE_HOME"]) / "fem_bounce"
    return Path.home() / ".cache" / "fem_bounce"


def checked_root() -> Path:
    """root(), or OutputError naming it and the variable when it lies in a run directory (whose folder is the
    run's alone: `--force` may replace it), checked before anything is made there."""
    path = root()
    try:
        run = next((p for p in (path, *path.resolve().parents) if (p / RUN_MARKER).is_file()), None)
    except OSError:  # a loop of links, ...: folder() says so
        return path
    if run is not None:
        raise OutputError(f"fem_bounce's cache {path} is inside the run directory {run}, which is the run's alone: "
                          f"set {VARIABLE} to a folder of its own")
    return path


def folder(kind: str) -> Path:
    """checked_root()/kind, made when missing; OutputError naming the folder and the variable when it cannot be."""
    path = checked_root() / kind
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise OutputError(f"cannot use {path} as fem_bounce's cache: {err.strerror or err} (set {VARIABLE} to a "
                          "writable directory)") from None
    return path
