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
