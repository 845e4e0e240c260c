"""fem_bounce: a sphere falling through a viscous liquid onto a wall, and its bounces.

Li, Hunt & Colonius (2011), J. Fluid Mech. 691, 123-145: the contact model,
here shared by a ladder of models (ode, fd, ib, ale); see README.md.

From Python (the command line's scenes, runs and studies; docs/usage.md, section Python):

    import fem_bounce as fb
    scene = fb.load("li2011-case3", {"run.bounces": 2})      # a preset or TOML file, checked as --set
    result = fb.simulate(scene, "ode")                        # kept in memory; out="DIR" writes a run directory
    result.impacts[0].impact_speed, result.trajectory["t"]    # records and NumPy arrays

Scenes:   Scene (scene.replace(**{"key": value}) is a checked variant), load, save, presets, model_names
Runs:     simulate, resume, Result (impacts, rebounds, collisions, trajectory, to_pandas, draw),
          Impact, Rebound, Collision
Studies:  restitution (e against St), compare (several models on one scene), band (predictions with bands), Table
Errors:   Error, the base of SceneError, ModelError, OutputError, CheckpointError, RunnerError,
          RunFailed, RunDiverged, RunInterrupted
"""
import os

from ._version import __version__ as __version__  # re-exported

# One OpenBLAS thread per process unless the caller says otherwise: the solvers' many small back-solves and
# Krylov steps ran 2-3 times slower with OpenBLAS's threads on a busy 2-core machine, and under mpiexec every
# rank's threads would share the same cores (docs/performance.md, "The stack").  OpenBLAS reads it when it
# loads, with PETSc: so it is set before anything here imports petsc4py.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

try:  # PyPI's FEniCSx wheel (dolfinx-solver-real) loads MPI ahead of PETSc and dolfinx only when imported first
    import dolfinx_solver  # noqa: F401
except ImportError:  # conda-forge or a system FEniCSx: nothing to order
    pass

from .api import (
    Collision, CheckpointError, Error, Impact, ModelError, OutputError, Rebound, Result, RunDiverged, RunFailed,
    RunInterrupted, RunnerError, Scene, SceneError, Table, band, compare, load, model_names, presets, restitution,
    resume, save, simulate)

__all__ = [  # what help(fem_bounce) lists
    "Scene", "load", "save", "presets", "model_names",
    "simulate", "resume", "Result", "Impact", "Rebound", "Collision",
    "restitution", "compare", "band", "Table",
    "Error", "SceneError", "ModelError", "OutputError", "CheckpointError", "RunnerError",
    "RunFailed", "RunDiverged", "RunInterrupted",
]
