"""The ladder of models, cheapest first.  What each model is (its name, resolution, whether it
restarts, its cost label and colour, ...) is in registry.MODELS; each model's code implements the
FlowModel interface (fem_bounce.flow_model) and shares the scene, the contact model, the sphere
integrator, the run controller (fem_bounce.run) and the outputs.
Modules are imported on demand so the ODE model needs neither dolfinx nor gmsh.
"""
from __future__ import annotations

import importlib
from collections.abc import Sequence

from ..errors import Error
from ..scene import SceneError
from . import registry
from .registry import BEST_FIRST, FRONT_PICKS, MODELS, ModelInfo


class ModelError(Error, ValueError):
    """An unknown model, or one whose libraries are not installed; or a model that cannot do what the
    scene asks (a pair, a restart)."""


def info(name: str) -> ModelInfo:
    """The registry's entry for a --model value."""
    if not isinstance(name, str) or name not in MODELS:
        raise ModelError(f"unknown model {name!r}: choose one of {', '.join(MODELS)}")
    return MODELS[name]


def get(name: str):
    """The model class for a --model value."""
    return flow_model_class(info(name))


def flow_model_class(entry: ModelInfo, scene=None):
    """The FlowModel class of a registry entry (imported on demand); for a `scene`, the one its chooser picks."""
    name = entry.name
    try:
        module = importlib.import_module(entry.module)
    except ModuleNotFoundError as err:
        raise ModelError(f"model {name!r} needs {err.name}, which is not installed (see README.md)") from None
    if scene is not None and entry.chooser:
        return getattr(module, entry.chooser)(scene)
    return getattr(module, entry.class_name)


def model_list(names: str | Sequence[str]) -> list[str]:
    """The models of a comparison ("ode,fd" or a list, as --models), each known and installed."""
    if isinstance(names, str):
        names = names.split(",")
    try:
        names = list(names)
    except TypeError:
        names = [names]
    wrong = [name for name in names if not isinstance(name, str)]  # a list: the wrong entry may be None itself
    if wrong:
        raise ModelError(f"--models: {wrong[0]!r} is not a model's name: choose from {', '.join(MODELS)}")
    names = [name.strip() for name in names if name.strip()]
    if not names:
        raise ModelError("--models needs at least one model, e.g. --models ode,ib")
    if len(set(names)) < len(names):
        twice = sorted({name for name in names if names.count(name) > 1})
        raise ModelError(f"--models names {', '.join(twice)} more than once: each model runs once")
    for name in names:
        get(name)
    return names


def check_scene(entry: ModelInfo, scene) -> None:
    """Refuse a scene the model cannot run at all, before anything is written: more spheres than it runs
    (ModelError), or a release above what it meshes (scene.SceneError)."""
    spheres = len(scene.spheres)
    # off the axis only the models that run it, and as many spheres
    able = [name for name in registry.running(spheres) if MODELS[name].oblique or not scene.oblique]
    if spheres > entry.max_spheres:
        what = "a pair of spheres ([second_sphere])" if spheres == 2 else f"{spheres} spheres ([[further_spheres]])"
        raise ModelError(f"the {entry.name} model cannot run {what}: it runs at most {entry.max_spheres}; use "
                         f"{'one of ' * (len(able) > 1)}{', '.join(able)}")
    if scene.oblique and not entry.oblique:
        what = ("a pair off its line of centres (second_sphere.tangential_velocity or spin != 0)" if spheres > 1 else
                "a scene with tangential_velocity, spin or gravity_angle != 0")
        raise ModelError(f"the {entry.name} model is axisymmetric: {what} leaves the axis; run it with --model "
                         f"{' or '.join(able)}")
    if not entry.containers and not scene.container.unbounded:
        raise SceneError(f'the {entry.name} model meshes a box, not a cylindrical container: give container = '
                         '"unbounded", or use another model')
    d = scene.sphere.diameter
    if entry.max_initial_gap is not None and scene.initial_gap > entry.max_initial_gap * d:
        raise SceneError(
            f"initial_gap = {scene.initial_gap:.4g} m is {scene.initial_gap / d:.3g} D: the {entry.name} model meshes "
            f"the whole path, allowed up to {entry.max_initial_gap:g} D (a sphere reaches its terminal speed within "
            "~10-20 D); start it lower, or use the ode model")


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
    """The highest-fidelity model installed (registry.BEST_FIRST); a run without a model takes choose(scene)."""
    have = available()
    return next(name for name in BEST_FIRST if name in have)


def scene_kind(scene) -> str:
    """Which of registry.FRONT_PICKS a scene is: "oblique" (it leaves the axis: Scene.oblique), "spheres" (more
    than one sphere on the axis) or "head-on" (one sphere on the axis)."""
    if scene.oblique:
        return "oblique"
    return "spheres" if len(scene.spheres) > 1 else "head-on"


def cannot_run(entry: ModelInfo, scene, installed=None) -> str | None:
    """Why the model cannot run the scene, in a few words (None: it can).  installed: the names to take as
    installed (None: those whose module imports)."""
    spheres = len(scene.spheres)
    if spheres > entry.max_spheres:
        return f"at most {entry.max_spheres} sphere{'s' if entry.max_spheres > 1 else ''}"
    if scene.oblique and not entry.oblique:
        return "head-on only so far"
    if not entry.containers and not scene.container.unbounded:
        return "no container"
    if entry.max_initial_gap is not None and scene.initial_gap > entry.max_initial_gap * scene.sphere.diameter:
        return f"releases up to {entry.max_initial_gap:g} D"
    if installed is not None:
        return None if entry.name in installed else "not installed"
    try:
        get(entry.name)
    except ModelError as err:
        needs = str(err).partition(" needs ")[2].partition(",")[0]
        return f"not installed (needs {needs})" if needs else "not installed"
    return None


def choose(scene, installed=None) -> tuple[str, str]:
    """The model a run takes when none is named, and the line that says which and why: the first model of the
    scene's registry.FRONT_PICKS that runs it and is installed (`installed`: the names to take as installed;
    None: those whose module imports).  docs/usage.md, "Which model a run takes"."""
    pick = FRONT_PICKS[scene_kind(scene)]
    skipped: dict[str, list[str]] = {}  # why not -> the models passed over for it
    for name in pick.order:
        why_not = cannot_run(MODELS[name], scene, installed)
        if why_not is None:
            passed = "; ".join(f"{', '.join(names)}: {reason}" for reason, names in skipped.items())
            why = f"{pick.kind}, and {passed}" if passed else pick.why
            return name, f"model: {name} ({why}; --model to choose)"
        skipped.setdefault(why_not, []).append(name)
    passed = "; ".join(f"{', '.join(names)}: {reason}" for reason, names in skipped.items())
    raise ModelError(f"no installed model runs {pick.kind} here ({passed}): name one with --model")
