"""Finished runs, reused: a study asks for (scene, model) and gets the run directory.

A run is keyed by its resolved scene (as TOML), its model and the code that computes it (a hash of
the package's numerical sources; plotting and command-line code are left out), so redrawing a figure
never re-runs a simulation, and changing the physics never reuses a stale answer.  An interrupted
study resumes where it stopped: finished runs are found, unfinished ones run again.

    run_dir = cached_run(scene, "fd", comm)                 # results/cache/<key>/
"""
from __future__ import annotations

import functools
import hashlib
import json
from pathlib import Path

from . import scene as scenes
from .run import RunDiverged, simulate

DEFAULT_ROOT = Path("results") / "cache"
_NOT_NUMERICS = {"cli.py", "plots.py", "cache.py", "compare.py", "fields.py", "__main__.py"}


@functools.cache
def code_version() -> str:
    """Hash of the source files that decide a run's numbers."""
    package = Path(__file__).parent
    digest = hashlib.sha256()
    for path in sorted(package.rglob("*")):
        relative = path.relative_to(package)
        if path.is_dir() or relative.parts[0] == "studies" or path.name in _NOT_NUMERICS:
            continue
        if path.suffix in (".py", ".toml", ".csv"):
            digest.update(str(relative).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def run_key(scene: scenes.Scene, model: str) -> str:
    text = f"{model}\n{code_version()}\n{scenes.dumps(scene)}"
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def cached_run(scene: scenes.Scene, model: str, comm, root: Path = DEFAULT_ROOT, progress: bool = False) -> Path:
    """The directory of a finished run of `model` on `scene` (completed or diverged), running it if needed."""
    run_dir = Path(root) / f"{scene.name}-{model}-{run_key(scene, model)}"
    summary = run_dir / "summary.json"
    if not summary.exists():
        try:
            simulate(scene, model, comm, run_dir, force=True, progress=progress, plots=False,
                     command=f"cached run of {scene.name} with {model}")
        except RunDiverged:
            pass  # recorded in summary.json; a study classifies it
    return run_dir


def load_summary(run_dir: Path) -> dict:
    return json.loads((Path(run_dir) / "summary.json").read_text())
