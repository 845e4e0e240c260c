"""What a model refuses or warns about in the scene it is given: a resolution below what it resolves, a sphere, a
pair or a mesh its domain cannot hold, settings it ignores, the serial model under mpiexec.  A refusal is one line,
exit 2, nothing written."""
import subprocess
import sys

import pytest

from helpers import ODE, assert_one_line, refused, refused_same_listing, run_cli


# -- resolution -------------------------------------------------------------------------------------------------------


def test_ib_too_coarse_for_its_kernel_says_so(tmp_path, monkeypatch, capsys):
    """At 2 cells/D the ib model said the sphere left a region that its own numbers placed it inside."""
    monkeypatch.chdir(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", "--model", "ib", "--quiet",
                            "--set", "numerics.ib.cells_per_diameter=2")
    assert status == 2
    assert_one_line(lines, "error: numerics.ib: at 2 cells/D the delta kernel reaches 0.75 D",
                    "raise numerics.ib.cells_per_diameter")
    assert list(tmp_path.iterdir()) == []


def test_fd_below_what_it_resolves_warns(tmp_path, capsys):
    """fd at 2 cells/D ran without a word (V_i -13 %, apex -22 % against 12 cells/D)."""
    status, lines = run_cli(capsys, "run", "li2011-case3", "--model", "fd", "--quiet", "--set",
                            "numerics.fd.cells_per_diameter=2", "--set", "run.end_time=0.002",
                            "--out", str(tmp_path / "run"))
    assert status == 0
    assert_one_line(lines, "warning: numerics.fd.cells_per_diameter = 2 puts 0.4 fine cells across the delta_sl gap")


# -- what the domain holds --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("model", ["ale", "fd"])
def test_a_sphere_wider_than_the_domain_is_refused(model, tmp_path, monkeypatch, capsys):
    """second_sphere.diameter = 1000: a ValueError with ale, a std::bad_alloc abort with fd."""
    refused(capsys, tmp_path, monkeypatch, "run", "pair-settling-wall", "--model", model, "--quiet", "--out", "r",
            "--set", "second_sphere.diameter=1000",
            message=f"second_sphere.diameter = 1000 m does not fit in the {model} model's domain")


@pytest.mark.parametrize("model", ["ale", "fd"])
def test_a_mesh_beyond_memory_is_refused(model, tmp_path, monkeypatch, capsys):
    """container.radius = height = 100 m: the ale model meshed the whole container (2.6e8 triangles) ignoring
    SIGTERM."""
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", "--model", model, "--quiet", "--out", "r",
            "--set", "container.radius=100", "--set", "container.height=100",
            message=f"numerics.{model}: its mesh of this scene would have ~2.6e+08 triangles")


def test_pair_refused_by_fd_writes_nothing(tmp_path, monkeypatch, capsys):
    """The refusal came after the marker, scene.toml, a header-only trajectory and a 64 kB reserve."""
    refused_same_listing(
        capsys, tmp_path, monkeypatch, "run", "yang-hunt2006-pair", "--model", "fd", "--quiet", "--out", "r",
        "--set", "numerics.fd.cells_per_diameter=6", "--set", "numerics.fd.constraint=penalty",
        "--set", "numerics.fd.mesh=fixed", message="spheres' indicators overlap")


# -- settings a model ignores -----------------------------------------------------------------------------------------


def test_the_ode_model_says_it_ignores_the_container(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--out", "r", "--set", "run.bounces=1",
                            "--set", "container.radius=0.02", "--set", "container.height=0.1")
    assert status == 0
    assert_one_line([line for line in lines if "warning" in line], "ignores [container]")


@pytest.mark.parametrize("case", ["pause with ale", "cavitation true", "serial warning under mpiexec"])
def test_settings_say_what_they_do(case, tmp_path, monkeypatch, capsys, mpiexec):
    """history_across_contact = "pause" had no effect with ale, silently; cavitation_pressure = true said "must be
    a string" though numbers are allowed; under mpiexec the "serial model" warning came before a refusal."""
    if case == "pause with ale":
        status, lines = run_cli(capsys, "run", "li2011-case3", "--model", "ale", "--quiet", "--out",
                                str(tmp_path / "r"), "--set", "contact.history_across_contact=pause",
                                "--set", "run.end_time=0.005", "--set", "numerics.ale.cells_per_diameter=4")
        assert status == 0
        assert_one_line(lines, 'warning: contact.history_across_contact = "pause" has no effect with the ale model')
    elif case == "cavitation true":
        refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r", "--set",
                "contact.cavitation_pressure=true", message="contact.cavitation_pressure = True must be 'auto', "
                "'liquid', 'off' or a number in [-1e+08, 0] Pa")
    else:
        (tmp_path / "notes").mkdir()
        (tmp_path / "notes" / "keep.txt").write_text("keep")
        ended = subprocess.run([mpiexec, "-n", "2", sys.executable, "-m", "fem_bounce", "run", "li2011-case3", *ODE,
                                "--out", "notes", "--force"], cwd=tmp_path, capture_output=True, text=True, timeout=120)
        assert ended.returncode == 2
        assert_one_line(ended.stderr.splitlines(), "error: notes is not a fem-bounce run directory")


# -- settings a mode reads nowhere (models/unread.py) -----------------------------------------------------------------

# a scene in each mode of models/unread.py RULES (preset, settings), and a value away from the default for each
# setting a rule names
MODE_SCENES = {
    ("fd", "steady_stokes = true"): ("brenner-approach", {"numerics.fd.steady_stokes": True}),
    ("fd", 'steady_stokes = true with constraint = "implicit"'): ("brenner-approach",
                                                                  {"numerics.fd.steady_stokes": True}),
    ("fd", 'the fixed mesh (mesh = "fixed", or steady_stokes)'): ("li2011-case3", {"numerics.fd.mesh": "fixed"}),
    ("fd", "every sphere held, on the fixed mesh"): ("brenner-approach", {"numerics.fd.mesh": "fixed"}),
    ("fd", "every sphere held, on the moving mesh"): ("brenner-approach", {}),
    ("fd", "the fixed mesh without patches (patch = false, or every sphere held)"):
        ("li2011-case3", {"numerics.fd.mesh": "fixed", "numerics.fd.patch": False}),
    ("fd", "the fixed mesh without a wall box (wall_cells_per_diameter no finer than cells_per_diameter, or a "
           "stream)"): ("li2011-case3", {"numerics.fd.mesh": "fixed"}),
    ("fd", 'fixed steps (adaptive_step false, set or resolved: constraint = "penalty", time_order 3)'):
        ("li2011-case3", {"numerics.fd.adaptive_step": False}),
    ("fd", 'constraint = "implicit"'): ("li2011-case3", {}),
    ("fd", "the moving mesh"): ("li2011-case3", {}),
    ("fd", "a container"): ("tencate2002-e4", {}),
    ("ale", 'every sphere held and fixed_solver = "steady"'): ("sphere-drag-re100", {}),
    ("ale", "fixed steps (adaptive_step = false)"): ("li2011-case3", {"numerics.ale.adaptive_step": False}),
    ("ale", 'factorisation = "every-step"'): ("li2011-case3", {"numerics.ale.factorisation": "every-step"}),
    ("ale", "a sphere not held"): ("li2011-case3", {}),
    ("ale", "the near-wall correction holding every contact"): ("yang-hunt2006-pair", {}),
    ("ale", "every sphere held"): ("brenner-approach", {}),
    ("ale", "a container"): ("tencate2002-e4", {}),
    ("ib", "a container"): ("tencate2002-e4", {}),
    ("ib", "a stream"): ("sphere-drag-re100", {}),
    ("ib", "a held sphere"): ("sphere-drag-re100", {}),
}
AWAY = {"adaptive_step": False, "min_step_factor": 0.1, "max_step_factor": 1.0, "gap_fraction": 0.2,
        "coupling": "explicit", "time_order": 1, "solver": "fieldsplit", "surface_refinement": 3.0,
        "min_quality": 0.2, "min_gap_cells": 3.0, "patch": False, "patch_margin": 0.5,
        "wall_cells_per_diameter": 4.0, "wall_layer": 0.5, "wall_radius": 1.0, "forcing_number": 0.05,
        "far_field": 20.0, "cfl": 0.2, "factorisation": "every-step", "factorisation_cost": 10.0,
        "reuse_iterations": 10, "krylov_rtol": 1e-6, "fixed_solver": "march", "hold_delta": 0.01,
        "wall_exclusion": 1.0}
AWAY_ALE = {"max_step_factor": 2.0}  # the ale model's own default is fd's AWAY value


def _unread_cases():
    from fem_bounce.models.unread import RULES

    for model, rules in RULES.items():
        for rule in rules:
            if rule.refused_by:  # refused (and tested) where it was written first
                continue
            for name in rule.names:
                yield pytest.param(model, rule, name, id=f"{model}-{name}-{rule.mode}")


@pytest.mark.parametrize("model, rule, name", list(_unread_cases()))
def test_a_setting_its_mode_reads_nowhere_is_refused(model, rule, name):
    """Each setting of a numerics table that a mode of its model reads nowhere (models/unread.py: the fixed fd mesh's
    surface_refinement, forcing_number under the implicit constraint, the adaptive steps' bounds with fixed steps,
    ale's reuse settings with every-step factorisations, far_field with a container, ...) would run silently.  Set
    away from its default it is refused by the model's scene check, before anything is written, in one line saying
    why and what to set instead; the same scene without it is admitted (a default is never refused)."""
    from mpi4py import MPI

    from fem_bounce import models
    from fem_bounce import scene as scenes

    preset, settings = MODE_SCENES[(model, rule.mode)]
    value = (AWAY_ALE if model == "ale" else {}).get(name, AWAY[name])

    def build(scene):
        return models.flow_model_class(models.info(model), scene)(scene, MPI.COMM_SELF)  # its scene check

    build(scenes.load(preset, settings))  # admitted: its flow is made later (FlowModel.build)
    scene = scenes.load(preset, {**settings, f"numerics.{model}.{name}": value})
    with pytest.raises(scenes.SceneError) as refusal:
        build(scene)
    message = str(refusal.value)
    reason = rule.reason(scene) if callable(rule.reason) else rule.reason
    assert message.startswith(f"numerics.{model}.{name} = ") and message.endswith(reason), message
    assert "\n" not in message and ("unset it" in message)


def test_a_setting_read_nowhere_is_refused_before_anything_is_written(tmp_path, monkeypatch, capsys):
    """The command line's refusal of one (numerics.fd.forcing_number under the default implicit constraint): exit 2,
    one line, nothing written."""
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", "--model", "fd", "--quiet", "--out", "r",
            "--set", "numerics.fd.forcing_number=0.05",
            message='numerics.fd.forcing_number = 0.05 has no effect with numerics.fd.constraint = "implicit"')


def test_a_time_step_ladder_scales_only_the_limits_the_run_reads():
    """The fd model's time-step ladder scales forcing_number with peak_cfl (the one-shot penalty's dt is usually set by
    it), but the default implicit constraint reads it nowhere: the ladder leaves it out there, so that a study's runs
    are not refused."""
    from fem_bounce import scene as scenes
    from fem_bounce.studies import common

    assert common.LADDERS["fd"].time_step(scenes.load("li2011-case3"), 0.4) == {"numerics.fd.peak_cfl": 0.4}


def test_a_convergence_study_takes_no_time_ladder_where_the_run_takes_no_steps(tmp_path, monkeypatch, capsys):
    """Held spheres the ale model solves steady read no numerics.ale.cfl: the study's --cfls are refused up front
    (without them it leaves the time ladder out: four equal steady solves before)."""
    refused(capsys, tmp_path, monkeypatch, "study", "convergence", "sphere-drag-re100", "--model", "ale", "--cfls",
            "0.2,0.1", "--out", "s", message="numerics.ale.cfl = 0.2 is read nowhere here: every sphere is held")
