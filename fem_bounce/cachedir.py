"""Where fem_bounce keeps what it can make again: generated meshes (meshes/) and the finished runs that
studies reuse (runs/).

    $FEM_BOUNCE_CACHE              when set
    $XDG_CACHE_HOME/fem_bounce     else, when XDG_CACHE_HOME is set
    ~/.cache/fem_bounce            else

Never the source tree nor the working directory; the folder may be deleted at any time.
"""
from __future__ import annotations

import os
from pathlib import Path

from .errors import OutputError

VARIABLE = "FEM_BOUNCE_CACHE"


def root() -> Path:
    if os.environ.get(VARIABLE):
        return Path(os.environ[VARIABLE])
    if os.environ.get("XDG_CACHE_HOME"):
        return Path(os.environ["XDG_CACHE_HOME"]) / "fem_bounce"
    return Path.home() / ".cache" / "fem_bounce"


def folder(kind: str) -> Path:
    """root()/kind, made when missing; OutputError naming the folder and the variable when it cannot be."""
    path = root() / kind
    try:
        path.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise OutputError(f"cannot use {path} as fem_bounce's cache: {err.strerror or err} (set {VARIABLE} to a "
                          "writable directory)") from None
    return path
