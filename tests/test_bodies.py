"""Bodies on the axis (issue 25): a scene's spheres as bodies, one integrator for any number of them, and
the three-sphere preset with the ode model."""
from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest
from mpi4py import MPI

from fem_bounce import models, output
from fem_bounce import scene as scenes
from fem_bounce.bodies import scene_bodies
from fem_bounce.integrator import BodyIntegrator
from fem_bounce.run import simulate

THREE = "three-spheres-wall"


def test_the_bodies_answer_for_the_scene():
    """Sphere 1 is [sphere] with [motion]; the others stand one surface gap above the one below."""
    sc = scenes.load(THREE)
    bodies = scene_bodies(sc)
    assert [b.key for b in bodies] == ["sphere", "second_sphere", "further_spheres[0]"]
    assert [b.initial_gap for b in bodies] == pytest.approx(sc.initial_gaps)
    assert sc.initial_gaps == pytest.approx([0.0152, 0.0152 + 2 * 0.0095, 0.0152 + 4 * 0.0095])
    volume = np.pi * 0.0095**3 / 6.0
    for body in bodies:
        assert body.free and not body.held and body.start_velocity == 0.0
        assert body.displaced_mass == pytest.approx(1203.0 * volume)
        assert body.net_weight == pytest.approx((7780.0 - 1203.0) * volume * 9.81)
    single = scene_bodies(scenes.load("li2011-case3", {"motion.mode": "prescribed", "motion.velocity": -0.1}))
    (body,) = single
    assert not body.free and body.start_velocity == -0.1 and body.prescribed(0.3) == (-0.1, 0.0)


def test_a_three_sphere_scene_round_trips_through_toml():
    sc = scenes.load(THREE)
    again = scenes.from_dict(tomllib.loads(scenes.dumps(sc)))
    assert again == sc and len(again.spheres) == 3


@pytest.mark.parametrize("changes,message", [
    ({"further_spheres": [{"diameter": 0.01, "density": -1.0, "youngs_modulus": 2e11, "poisson_ratio": 0.3,
                           "gap": 0.01}]}, "further_spheres[0].density = -1.0 kg/m3 is out of range"),
    ({"further_spheres": [{"diameter": 0.01, "density": 7780.0, "youngs_modulus": 2e11, "poisson_ratio": 0.3}]},
     "missing key further_spheres[0].gap"),
    ({"further_spheres": {"diameter": 0.01}}, "further_spheres must be an array of tables ([[further_spheres]]"),
])
def test_bad_further_spheres_name_the_field(changes, message):
    with pytest.raises(scenes.SceneError) as err:
        scenes.load(THREE, changes)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_further_spheres_need_a_second_sphere():
    data = scenes.to_dict(scenes.load(THREE))
    data.pop("second_sphere")
    with pytest.raises(scenes.SceneError, match=r"give \[second_sphere\] first"):
        scenes.from_dict(data)


@pytest.mark.parametrize("model", ["fd", "ale", "ib"])
def test_a_resolved_model_refuses_three_spheres_before_writing(model, tmp_path):
    with pytest.raises(models.ModelError) as err:
        simulate(scenes.load(THREE), model, MPI.COMM_SELF, tmp_path / "run", progress=False)
    assert f"the {model} model cannot run 3 spheres" in str(err.value) and "ode" in str(err.value)
    assert not (tmp_path / "run").exists()


@pytest.mark.parametrize("preset,changes,pause,end", [
    ("li2011-case3", {"run.bounces": 2}, 0.05, None),  # one sphere: through two bounces
    ("yang-hunt2006-pair", {}, 0.01, 0.02),
    (THREE, {}, 0.02, 0.04),
])
def test_checkpoint_state_round_trip(preset, changes, pause, end):
    """A state saved (through JSON) and loaded into a fresh integrator continues as the first one does:
    not bit for bit (PETSc's event and step-size history restart), but far inside the tolerances."""
    sc = scenes.load(preset, changes)
    end = end or sc.run.end_time
    first = BodyIntegrator(sc)
    first.advance(pause)
    state = json.loads(json.dumps(first.state_dict()))
    first.advance(end)
    second = BodyIntegrator(sc)
    second.load_state_dict(state)
    second.advance(end)
    for integrator in (first, second):
        integrator.finish()
    assert second.gaps == pytest.approx(first.gaps, rel=1e-7)
    assert len(second.collisions()) == len(first.collisions())
    assert [i.impact_speed for i in second.impacts] == pytest.approx([i.impact_speed for i in first.impacts],
                                                                     rel=1e-7)
    first.destroy()
    second.destroy()


def test_three_spheres_settle_onto_the_wall_with_the_ode_model(tmp_path):
    """The preset to its first collision of the upper pair (~3000 steps, ~25 s): sphere 1 bounces on the
    wall, meets the second sphere coming down, which then meets the third; no gap falls below its contact
    law's floor (a tenth of the reduced radius into a Hertz contact), and the column's kinetic and
    potential energy never rises above its value at release (the liquid and the contacts only take)."""
    sc = scenes.load(THREE, {"run.end_time": 0.105})
    summary = simulate(sc, "ode", MPI.COMM_SELF, tmp_path / "run", progress=False, plots=False)
    assert summary["status"] == "completed"
    kinds = [c["kind"] for c in summary["collisions"]]
    assert kinds[:3] == ["wall", "pair_12", "wall"] and "pair_23" in kinds
    assert [i["time"] for i in summary["impacts"]] == [c["time"] for c in summary["collisions"]
                                                       if c["kind"] == "wall"]
    first = summary["collisions"][0]
    assert 0.3 < first["impact_speed"] < 0.45 and 0.5 < first["restitution"] < 0.9  # as pair-settling-wall's
    rows = output.read_trajectory(tmp_path / "run")
    assert tuple(rows) == output.trajectory_columns(3)
    radius = 0.5 * 0.0095
    assert rows["gap_1"].min() > -0.1 * radius and rows["gap_1"].min() < 1e-6  # it reached the wall
    for gap in ("pair_gap_12", "pair_gap_23"):
        assert rows[gap].min() > -0.1 * radius / 2 and rows[gap].min() < 1e-6  # a* = a / 2; they touched
    bodies = scene_bodies(sc)
    masses = np.array([b.mass for b in bodies])
    weights = np.array([b.net_weight for b in bodies])
    heights = np.array([rows[f"gap_{k}"] for k in (1, 2, 3)])
    speeds = np.array([rows[f"velocity_{k}"] for k in (1, 2, 3)])
    energy = 0.5 * masses @ speeds**2 + weights @ heights
    assert energy.max() <= energy[0] * (1.0 + 1e-6)
    assert energy[-1] < 0.5 * energy[0]  # the liquid and the contacts took half of it by now
