"""`fem-bounce run SCENE` without --model (and fem_bounce.simulate without a model) takes the speed-accuracy front's
model for the scene (registry.FRONT_PICKS, models.choose; docs/usage.md, "Which model a run takes") and says which
and why in one line; the 3-D model only for a scene that leaves the axis."""
import dataclasses

import pytest

import fem_bounce as fb
from fem_bounce import cli, models
from fem_bounce import scene as scenes
from fem_bounce.models import registry

OBLIQUE = {"tangential_velocity": 0.1, "contact.friction": 0.1}
FD3D_TOY = {"numerics.fd3d.cells_per_diameter": 4, "numerics.fd3d.surface_refinement": 1}  # a few seconds a step


def test_a_head_on_sphere_takes_the_resolved_model_of_the_front():
    scene = scenes.load("li2011-case3")
    assert models.scene_kind(scene) == "head-on"
    name, line = models.choose(scene, installed=set(models.MODELS))
    assert name == "fd"
    assert line == ("model: fd (the speed-accuracy front's resolved model for one sphere on the axis: "
                    "docs/performance.md; --model to choose)")
    assert models.choose(scenes.load("tencate2002-e4"), installed=set(models.MODELS))[0] == "fd"
    # without the FEniCSx stack: the next that runs it, and the line says why
    assert models.choose(scene, installed={"ib", "ode"}) == (
        "ib", "model: ib (one sphere on the axis, and fd, ale: not installed; --model to choose)")
    # a release higher than the resolved models mesh: the reduced model
    high = scenes.load("li2011-case3", {"initial_gap": 200 * scene.sphere.diameter})
    assert models.choose(high, installed=set(models.MODELS)) == (
        "ode", "model: ode (one sphere on the axis, and fd, ale, ib: releases up to 100 D; --model to choose)")


def test_an_oblique_scene_takes_the_3d_model_and_a_head_on_one_never_does(monkeypatch):
    scene = scenes.load("li2011-case3", OBLIQUE)
    assert models.scene_kind(scene) == "oblique"
    name, line = models.choose(scene, installed=set(models.MODELS))
    assert name == "fd3d" and line.startswith("model: fd3d (the resolved model that runs scenes off the axis")
    assert models.choose(scenes.load("li2011-case3"), installed=set(models.MODELS))[0] == "fd"
    # without it (or were its registry entry head-on only) the reduced model, and the line says why
    assert models.choose(scene, installed=set(models.MODELS) - {"fd3d"}) == (
        "ode", "model: ode (a scene off the axis, and fd3d: not installed; --model to choose)")
    # in a container (ten Cate's settling column), which fd3d does not mesh
    assert models.choose(scenes.load("tencate2002-e4", OBLIQUE), installed=set(models.MODELS)) == (
        "ode", "model: ode (a scene off the axis, and fd3d: no container; --model to choose)")
    monkeypatch.setitem(registry.MODELS, "fd3d", dataclasses.replace(registry.MODELS["fd3d"], oblique=False))
    assert models.choose(scene, installed=set(models.MODELS)) == (
        "ode", "model: ode (a scene off the axis, and fd3d: head-on only so far; --model to choose)")


def test_a_pair_and_a_column_take_the_resolved_model_that_runs_them_best():
    for preset in ("yang-hunt2006-pair", "pair-settling-wall", "three-spheres-wall"):
        scene = scenes.load(preset)
        assert models.scene_kind(scene) == "spheres"
        name, line = models.choose(scene, installed=set(models.MODELS))
        assert name == "fd" and "on a pair: docs/validation.md section 12" in line
    pair = scenes.load("yang-hunt2006-pair")
    assert models.choose(pair, installed={"ale", "ib", "ode"})[0] == "ale"  # ib runs one sphere only
    assert models.choose(pair, installed={"ib", "ode"}) == (
        "ode", "model: ode (spheres on the axis, and fd, ale: not installed; --model to choose)")
    with pytest.raises(models.ModelError, match="no installed model runs spheres on the axis here"):
        models.choose(pair, installed={"ib"})


def test_the_picks_table_names_known_models_ending_with_one_that_runs_any_scene():
    for kind, pick in registry.FRONT_PICKS.items():
        assert set(pick.order) <= set(registry.MODELS)
        last = registry.MODELS[pick.order[-1]]
        assert last.oblique and last.max_spheres == registry.MANY and last.max_initial_gap is None
        assert kind == "oblique" or "fd3d" not in pick.order  # the 3-D model only for scenes off the axis


def test_run_without_a_model_prints_the_pick_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    argv = ["run", "li2011-case3", "--quiet", "--no-plots", "--set", "run.end_time=0.002", "--out", "oblique",
            *(f"--set={key}={value}" for key, value in {**OBLIQUE, **FD3D_TOY}.items())]
    assert cli.main(argv) == 0
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("fem-bounce: model: fd3d (the resolved model that runs scenes off the axis")
    assert err[1].startswith("fem-bounce: li2011-case3 with the fd3d model")
    # --model named: no such line
    assert cli.main(["run", "li2011-case3", "--model", "ode", "--quiet", "--no-plots", "--set", "run.end_time=0.002",
                     "--out", "named"]) == 0
    assert "model: " not in capsys.readouterr().err


def test_run_without_a_model_runs_the_head_on_pick(tmp_path, monkeypatch, capsys):
    """What `make demo` runs (`fem-bounce run`), a few steps of it: the fd model, into runs/li2011-case3-fd."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "--quiet", "--no-plots", "--set", "run.end_time=0.002",
                     "--set", "numerics.fd.cells_per_diameter=6"]) == 0
    err = capsys.readouterr().err
    assert "fem-bounce: model: fd (the speed-accuracy front's resolved model for one sphere on the axis" in err
    assert (tmp_path / "runs" / "li2011-case3-fd" / "summary.json").exists()


def test_simulate_without_a_model_takes_the_same_pick():
    result = fb.simulate(fb.load("li2011-case3", {**OBLIQUE, **FD3D_TOY, "run.end_time": 0.002}), plots=False)
    assert result.model == "fd3d"


def test_the_chooser_passes_over_exactly_the_models_check_scene_refuses():
    high = scenes.load("li2011-case3", {"initial_gap": 200 * 0.0127})
    for scene in (scenes.load("li2011-case3"), scenes.load("li2011-case3", OBLIQUE), scenes.load("yang-hunt2006-pair"),
                  scenes.load("three-spheres-wall"), high, scenes.load("tencate2002-e4", OBLIQUE)):
        for entry in registry.MODELS.values():
            try:
                models.check_scene(entry, scene)
                refused = False
            except (models.ModelError, scenes.SceneError):
                refused = True
            assert (models.cannot_run(entry, scene, installed=set(registry.MODELS)) is not None) == refused
