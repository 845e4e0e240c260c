"""Restitution against Stokes number the paper's way (section 5.4): the Table 3 sets released from
0.5-7 D, e from 2 ms means and 0 when the sphere stays in the contact layer."""
import pytest

from fem_bounce import scene
from fem_bounce.studies import restitution_planning as restitution
from fem_bounce.bounces import REBOUND_MIN_APEX_IN_CONTACT_LAYERS


def test_gap_for_stokes_hits_the_target():
    gap = restitution.gap_for_stokes("li2011-table3-steel-78", 60.0)
    steel = scene.load("li2011-table3-steel-78")
    assert restitution.first_bounce(steel, gap, rebound=False)["St"] == pytest.approx(60.0, rel=0.01)


def test_gap_for_stokes_names_the_reachable_range():
    with pytest.raises(scene.SceneError, match=r"out of reach for li2011-table3-steel-95: released from 0.5-7 D"):
        restitution.gap_for_stokes("li2011-table3-steel-95", 500.0)


def test_plan_releases_outside_the_lubrication_layer_and_spans_one_to_a_thousand():
    planned = restitution.plan(12)
    diameter = scene.load("li2011-case3").sphere.diameter  # every Table 3 sphere has D = 9.5 mm
    gaps = [gap / diameter for _, _, gap in planned]
    assert min(gaps) >= 0.5 * (1 - 1e-6) and max(gaps) <= 7.0 * (1 + 1e-6)
    stokes = [st for _, st, _ in planned]
    assert stokes[0] == pytest.approx(1.0, rel=0.01) and stokes[-1] == pytest.approx(1000.0, rel=0.01)
    assert planned[0][0] == "li2011-table3-steel-95" and planned[-1][0] == "li2011-table3-dense48-78"


def test_viscous_set_does_not_rebound_and_dense_spheres_approach_the_dry_value():
    """Runs 25-29 (95 % glycerol, St < 10) do not rebound; St ~ 1000 comes close to e_d = 0.97."""
    low = restitution.first_bounce(scene.load("li2011-table3-steel-95"),
                                   restitution.gap_for_stokes("li2011-table3-steel-95", 2.0))
    assert low["St"] == pytest.approx(2.0, rel=0.02)
    assert low["restitution"] == 0.0 and not low["rebounded"]
    contact_gap = 0.017 * scene.load("li2011-table3-steel-95").sphere.diameter
    assert low["apex_gap"] < REBOUND_MIN_APEX_IN_CONTACT_LAYERS * contact_gap  # the reason it counts as none
    high = restitution.first_bounce(scene.load("li2011-table3-dense48-78"),
                                    restitution.gap_for_stokes("li2011-table3-dense48-78", 1000.0))
    assert high["rebounded"] and high["restitution"] == pytest.approx(0.97, abs=0.03)


def test_restitution_rises_with_stokes_number_within_a_set():
    name = "li2011-table3-steel-85"
    lo, hi = restitution.stokes_band(name)[1][[0, -1]]
    values = [restitution.first_bounce(scene.load(name), restitution.gap_for_stokes(name, st))["restitution"]
              for st in (lo * 1.01, (lo * hi) ** 0.5, hi * 0.99)]
    assert values[0] < values[1] < values[2]


def test_restitution_command_runs_any_model_and_draws_the_figure(tmp_path, monkeypatch):
    from fem_bounce import cli

    monkeypatch.chdir(tmp_path)  # the study cache goes to results/ under the current directory
    assert cli.main(["restitution", "--model", "ode", "--points", "3", "--out", "sweep"]) == 0
    rows = (tmp_path / "sweep" / "restitution.csv").read_text().splitlines()
    assert rows[0].startswith("scene,target_St,gap_over_D") and len(rows) == 4
    assert (tmp_path / "sweep" / "restitution.png").stat().st_size > 10_000
