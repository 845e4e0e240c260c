"""The ladder of models, cheapest first.  Each module defines a class with

    name: str               the --model value
    resolved: bool          True when f_sim comes from a flow solver
    __init__(scene, comm)
    run(integrator, progress, out_dir, restart) -> dict(steps=..., sizes=..., extra=...)

and shares the scene, the contact model, the sphere integrator and the outputs.
Modules are imported on demand so the ODE model needs neither dolfinx nor gmsh.
"""
from __future__ import annotations

import importlib

MODELS = {
    "ode": ("fem_bounce.models.ode", "OdeModel"),
    "fd": ("fem_bounce.models.fd", "FictitiousDomainModel"),
    "ib": ("fem_bounce.models.ib", "ImmersedBoundaryModel"),
    "ale": ("fem_bounce.models.ale", "AleModel"),
}
BEST_FIRST = ("fd", "ib", "ode")  # the default model: the first of these that imports


class ModelError(ValueError):
    pass


def get(name: str):
    """The model class for a --model value."""
    if name not in MODELS:
        raise ModelError(f"unknown model {name!r}: choose one of {', '.join(MODELS)}")
    module, cls = MODELS[name]
    try:
        return getattr(importlib.import_module(module), cls)
    except ModuleNotFoundError as err:
        if err.name and err.name.startswith("fem_bounce.models"):
            raise ModelError(f"model {name!r} is not implemented yet") from None
        raise ModelError(f"model {name!r} needs {err.name}, which is not installed (see README.md)") from None


def available() -> list[str]:
    found = []
    for name in MODELS:
        try:
            get(name)
            found.append(name)
        except ModelError:
            pass
    return found


def default() -> str:
    have = available()
    return next(name for name in BEST_FIRST if name in have)
