"""The ladder of models, cheapest first.  What each model is (its name, resolution, whether it
restarts, its cost label and colour, ...) is in registry.MODELS; each model's code implements the
FlowModel interface (fem_bounce.flow_model) and shares the scene, the contact model, the sphere
integrator, the run controller (fem_bounce.run) and the outputs.
Modules are imported on demand so the ODE model needs neither dolfinx nor gmsh.
"""
from __future__ import annotations

import importlib

from ..errors import Error
from .registry import BEST_FIRST, MODELS, ModelInfo


class ModelError(Error, ValueError):
    """An unknown model, or one whose libraries are not installed; or a model that cannot do what the
    scene asks (a pair, a restart)."""


def info(name: str) -> ModelInfo:
    """The registry's entry for a --model value."""
    if name not in MODELS:
        raise ModelError(f"unknown model {name!r}: choose one of {', '.join(MODELS)}")
    return MODELS[name]


def get(name: str):
    """The model class for a --model value."""
    entry = info(name)
    try:
        return getattr(importlib.import_module(entry.module), entry.class_name)
    except ModuleNotFoundError as err:
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
