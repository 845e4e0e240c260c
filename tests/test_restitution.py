"""Restitution against Stokes number the paper's way (section 5.4): the Table 3 sets released from
0.5-7 D or launched, e from 2 ms means and 0 when the sphere stays in the lubrication film."""
import csv
import json

import pytest

from fem_bounce import scene
from fem_bounce.studies import restitution_planning as restitution


def test_launch_speed_for_stokes_hits_the_target():
    speed = restitution.launch_for_stokes("li2011-table3-steel-78", 60.0)
    steel = scene.load("li2011-table3-steel-78")
    assert restitution.first_bounce(steel, speed, rebound=False)["St"] == pytest.approx(60.0, rel=0.01)


def test_launch_for_stokes_names_the_reachable_range():
    with pytest.raises(scene.SceneError, match=r"out of reach for li2011-table3-steel-95: launched from 2 D at"):
        restitution.launch_for_stokes("li2011-table3-steel-95", 5000.0)


def test_plan_launches_outside_the_lubrication_layer_and_spans_one_to_a_thousand():
    with pytest.warns(UserWarning, match="no Table 3 set reaches St 1000"):  # dropped, and said so
        planned = restitution.plan(12)
    stokes = [st for _, st, _ in planned]
    assert stokes[0] == pytest.approx(1.0, rel=0.01) and stokes[-1] > 500.0  # St 1000 is past Re 250
    assert planned[0][0] == "li2011-table3-steel-95" and planned[-1][0] == "li2011-table3-dense48-78"
    # a point every factor ~1.3 between St 3 and 30, where e rises from 0
    low = [st for st in stokes if 3.0 <= st <= 30.0]
    assert len(low) >= 9 and max(b / a for a, b in zip(low, low[1:])) <= 1.31
    trial = restitution.bounce_scene(scene.load(planned[0][0]), planned[0][2])
    assert trial.gravity == 0.0 and trial.initial_gap == pytest.approx(2.0 * trial.sphere.diameter)
    assert trial.initial_velocity == pytest.approx(-planned[0][2])


def test_sweep_refuses_a_set_that_defeats_its_plan():
    with pytest.raises(scene.SceneError, match="--set initial_gap: the restitution sweep sets initial_gap"):
        restitution.check_overrides({"initial_gap": 5.0})


def test_slow_spheres_stall_in_the_film_and_dense_ones_approach_the_dry_value():
    """A sphere launched at St 2 stops in the film (no rebound, the run ends there); St ~ 800 comes close
    to e_d = 0.97 (the Legendre et al. fit gives 0.93 there)."""
    viscous = scene.load("li2011-table3-steel-95")
    low = restitution.first_bounce(viscous, restitution.launch_for_stokes("li2011-table3-steel-95", 2.0))
    assert low["St"] == pytest.approx(2.0, rel=0.03)  # the plan interpolates a tabulated band
    assert low["restitution"] == 0.0 and low["speed_out"] == 0.0 and "stalled" in low["stop_reason"]
    dense = "li2011-table3-dense48-78"
    high = restitution.first_bounce(scene.load(dense), restitution.launch_for_stokes(dense, 800.0))
    assert high["restitution"] == pytest.approx(0.93, abs=0.02)


def test_restitution_rises_with_stokes_number_within_a_set():
    name = "li2011-table3-dense24-78"
    lo, hi = restitution.stokes_band(name)[1][[0, -1]]
    values = [restitution.first_bounce(scene.load(name), restitution.launch_for_stokes(name, st))["restitution"]
              for st in (40.0, 120.0, hi * 0.99)]
    assert 0.0 < values[0] < values[1] < values[2] < 0.97


def test_restitution_command_runs_any_model_and_draws_the_figure(tmp_path, monkeypatch):
    from fem_bounce import cli

    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "cache"))  # a study cache of its own
    assert cli.main(["restitution", "--model", "ode", "--points", "3", "--st-min", "30", "--st-max", "300",
                     "--out", "sweep"]) == 0
    rows = list(csv.DictReader((tmp_path / "sweep" / "restitution.csv").open()))
    assert [row["status"] for row in rows] == ["completed"] * 3  # St 30 (from both grids), 95, 300
    assert all(float(row["St"]) > 25.0 and row["failed"] == "False" for row in rows)
    assert json.loads((tmp_path / "sweep" / "restitution.json").read_text())["compared_runs"] == 3
    assert (tmp_path / "sweep" / "restitution.png").stat().st_size > 10_000


def test_a_sweep_with_failed_runs_exits_nonzero_and_marks_them(tmp_path, monkeypatch, capsys):
    """A run that diverges is a failed run, not e = 0: the paper's spring at delta_ss = 0.001 cannot stop
    the heavier spheres (issue 23)."""
    from fem_bounce import cli

    monkeypatch.chdir(tmp_path)
    code = cli.main(["restitution", "--model", "ode", "--points", "2", "--st-min", "400", "--out", "sweep",
                     "--set", "contact.model=li2011", "--set", "contact.delta_ss=0.0003"])
    assert code == 1
    rows = list(csv.DictReader((tmp_path / "sweep" / "restitution.csv").open()))
    failed = [row for row in rows if row["failed"] == "True"]
    assert failed and all(row["status"].startswith("diverged") and row["restitution"] == "" for row in failed)
    assert "runs failed (marked in restitution.csv and the figure, not counted as e = 0)" in capsys.readouterr().err
