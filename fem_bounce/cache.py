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

import functools
import hashlib
from importlib import metadata
from pathlib import Path

from . import cachedir, models
from . import scene as scenes
from .errors import RunDiverged
from .models.registry import CORE_SOURCES
from .output import read_summary
from .run import simulate

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
    text = f"{model}\n{code_version(model)}\n{stack_version()}\n{scenes.dumps(scene)}"
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def run_directory(scene: scenes.Scene, model: str, root: Path | None = None) -> Path:
    """Where the run of `model` on `scene` is (or will be) cached (root: default_root())."""
    return Path(root or default_root()) / f"{scene.name}-{model}-{run_key(scene, model)}"


def finished(run_dir: Path) -> Path | None:
    """run_dir if it holds a finished run (completed or diverged), else None: a run killed before its
    summary, interrupted or failed is not finished and runs again."""
    summary = Path(run_dir) / "summary.json"
    if not summary.exists():
        return None
    try:
        status = read_summary(run_dir).get("status", "")
    except (OSError, ValueError):  # a summary cut short by a kill
        return None
    return None if status.startswith(("interrupted", "failed")) else Path(run_dir)


def cached_run(scene: scenes.Scene, model: str, comm, root: Path | None = None, progress: bool = False,
               command: str = "") -> Path:
    """The directory of a finished run of `model` on `scene` (completed or diverged), running it if needed."""
    run_dir = run_directory(scene, model, root)
    # decided on rank 0 for every rank: a rank that arrives after rank 0 has finished the run would
    # otherwise skip the run's collectives that the others are in
    if not comm.bcast(finished(run_dir) is not None if comm.rank == 0 else None, root=0):
        try:
            simulate(scene, model, comm, run_dir, force=True, progress=progress, plots=False,
                     command=command or f"cached run of {scene.name} with {model}")
        except RunDiverged:
            pass  # recorded in summary.json; a study classifies it (an interrupted or failed run is redone)
    return run_dir


