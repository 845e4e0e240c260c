"""The registry of models agrees with the scene's numerics and with the models' code."""
import dataclasses

import pytest

from fem_bounce import models
from fem_bounce import scene as scenes
from fem_bounce.models.registry import MODELS


def test_every_model_has_a_numerics_table_and_every_table_a_model():
    assert [f.name for f in dataclasses.fields(scenes.Numerics)] == list(MODELS)


@pytest.mark.parametrize("name", list(MODELS))
def test_every_key_the_registry_names_is_a_scene_setting(name):
    entry, scene = MODELS[name], scenes.load("li2011-case3")
    for key in (entry.resolution_key, entry.time_step_key, entry.checkpoint_every_key, entry.fields_key,
                entry.trajectory_interval_key, *entry.scaled_with_time_step):
        if key is not None:
            assert key.startswith(f"numerics.{name}.")
            entry.setting(scene, key)  # raises AttributeError for a stale key
    assert entry.default_resolution() == entry.resolution(scene)
    assert entry.ladder == tuple(sorted(entry.ladder, reverse=entry.resolution_unit == ""))


def test_labels_and_the_unknown_model():
    assert MODELS["fd"].label(24) == "fd, 24 cells/D"
    assert MODELS["ode"].label(1e-5) == "ode, rtol 1e-05"
    with pytest.raises(models.ModelError, match="unknown model 'fdd': choose one of ode, fd, ib, ale"):
        models.get("fdd")


@pytest.mark.parametrize("name", list(MODELS))
def test_every_model_names_a_stepper_and_its_cadences(name):
    from fem_bounce.steppers import STEPPERS

    entry, scene = MODELS[name], scenes.load("li2011-case3")
    assert entry.stepper in STEPPERS
    fields, checkpoints = entry.cadences(scene)
    assert fields == (entry.setting(scene, entry.fields_key) if entry.fields_key else 0)
    assert checkpoints == (entry.setting(scene, entry.checkpoint_every_key) if entry.restarts else 0)


def test_the_stepper_is_the_registry_s_unless_the_scene_holds_the_bodies_steady():
    from fem_bounce.integrator import BodyIntegrator
    from fem_bounce.models.ode import OdeModel
    from fem_bounce.steppers import OdeStep, SteadyStep, stepper_for

    scene = scenes.load("li2011-case3")
    integrator = BodyIntegrator(scene)
    try:
        ode = OdeModel(scene, None)
        assert type(stepper_for(MODELS["ode"], ode, integrator)) is OdeStep
        ode.steady = True  # a model whose scene holds its bodies at a steady state
        assert type(stepper_for(MODELS["ode"], ode, integrator)) is SteadyStep
    finally:
        integrator.destroy()


def test_a_release_above_what_a_resolved_model_meshes_is_refused_before_the_run():
    high = scenes.load("li2011-case3", {"initial_gap": 0.0095 * 150})  # 150 D
    for name in ("fd", "ib", "ale"):
        with pytest.raises(scenes.SceneError, match=f"the {name} model meshes the whole path, allowed up to 100 D"):
            models.check_scene(MODELS[name], high)
    models.check_scene(MODELS["ode"], high)  # the ode model meshes nothing
    with pytest.raises(models.ModelError, match="the ib model cannot run a pair of spheres"):
        models.check_scene(MODELS["ib"], scenes.load("yang-hunt2006-pair"))


def test_the_flow_model_interface_does_not_import_the_registry():
    """The controller reads the registry and hands the flow model what it needs (no upward import)."""
    import ast
    from pathlib import Path

    import fem_bounce.flow_model as flow_model

    tree = ast.parse(Path(flow_model.__file__).read_text())
    imported = {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    assert not any("models" in (module or "") for module in imported)
