"""Two spheres meeting off their line of centres in the reduced model (fem_bounce.pair_oblique): the film's
resistance across the line (its checks against Jeffrey & Onishi's limits, the wall's, reciprocity and a rigid
rotation), the turning frame's kinematics, the dry limit against the rigid-body theory with momentum, angular
momentum and energy, the scene's checks, and the head-on pair left as it was."""
from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from fem_bounce import models
from fem_bounce import scene as scenes
from fem_bounce.integrator import BodyIntegrator
from fem_bounce.pair_oblique import pair_lubrication
from fem_bounce.run import simulate
from fem_bounce.tangential_contact import oblique_rigid_theory

A, MU_L = 1e-3, 1e-3  # a sphere radius [m] and a viscosity [Pa s] for the resistances
DRY = {"liquid.density": 1e-6, "liquid.viscosity": 1e-12}  # the liquid switched off (as tests/test_pair.py does)


@pytest.mark.parametrize("ratio", [1.0, 0.5, 3.0])
def test_the_film_is_reciprocal_dissipative_and_spares_a_rigid_rotation(ratio):
    a1, a2 = A, ratio * A
    for gap in (1e-6, 1e-4, 0.3 * A):
        resistance, _ = pair_lubrication(a1, a2, MU_L, gap)
        assert np.abs(resistance - resistance.T).max() <= 1e-14 * np.abs(resistance).max()
        scale = 1.0 / np.sqrt(np.diag(resistance))  # a congruence keeps the signs of the eigenvalues
        assert np.linalg.eigvalsh(scale[:, None] * resistance * scale[None, :]).min() >= -1e-12
        # the pair turning rigidly at w about its contact point: U_1 = -w a_1, U_2 = w a_2, both spins w (the
        # lubrication limit's statement: at a gap h the film resists it by O(h))
        w = 3.0
        rigid = np.array([-w * a1, w * a2, w, w])
        assert np.abs(resistance @ rigid).max() <= 1e-12 * (np.abs(resistance) @ np.abs(rigid)).max()


def test_the_film_has_jeffrey_and_onishis_equal_sphere_coefficients_and_the_walls_limit():
    gap = 1e-3 * A
    size = math.log(A / gap)  # ln(1/xi), xi = 2 h / (a_1 + a_2)
    equal, _ = pair_lubrication(A, A, MU_L, gap)
    # Y^A_11 = L / 6 in 6 pi mu a, Y^B_11 L / 4 in 4 pi mu a^2, Y^C_11 L / 5 in 8 pi mu a^3, Y^C_12 L / 20 in
    # pi mu (2 a)^3 (Jeffrey & Onishi 1984, lambda = 1)
    assert equal[0, 0] / (6 * math.pi * MU_L * A * size) == pytest.approx(1 / 6, rel=1e-12)
    assert equal[0, 2] / (4 * math.pi * MU_L * A**2 * size) == pytest.approx(1 / 4, rel=1e-12)
    assert equal[2, 2] / (8 * math.pi * MU_L * A**3 * size) == pytest.approx(1 / 5, rel=1e-12)
    assert equal[2, 3] / (math.pi * MU_L * (2 * A) ** 3 * size) == pytest.approx(1 / 20, rel=1e-12)
    # sphere 2 a wall (lambda -> infinity): O'Neill & Stewartson's 8/15, Goldman, Cox & Brenner's 1/10 and 2/5
    big = 1e7 * A
    wall, _ = pair_lubrication(A, big, MU_L, gap)
    size = math.log((A + big) / (2.0 * gap))
    assert wall[0, 0] / (6 * math.pi * MU_L * A * size) == pytest.approx(8 / 15, rel=1e-6)
    assert wall[2, 0] / (8 * math.pi * MU_L * A**2 * size) == pytest.approx(1 / 10, rel=1e-6)
    assert wall[2, 2] / (8 * math.pi * MU_L * A**3 * size) == pytest.approx(2 / 5, rel=1e-6)
    # nothing from the gap the mean radius outward
    assert not np.any(pair_lubrication(A, 2 * A, MU_L, 1.5 * A)[0])


def pair(changes: dict) -> scenes.Scene:
    """The Yang & Hunt-style pair (12.7 mm steel, a projectile at 0.3 m/s onto a target at rest), friction 0.1."""
    return scenes.load("yang-hunt2006-pair", {"contact.friction": 0.1, **changes})


def rows_of(scene: scenes.Scene) -> dict[str, np.ndarray]:
    """Every trajectory column of the ode run of `scene`, at each of its steps."""
    integrator = BodyIntegrator(scene)
    found: list[dict] = []
    integrator.observers.append(found.append)
    try:
        integrator.advance(scene.run.end_time)
    finally:
        integrator.destroy()
    return {key: np.array([row[key] for row in found]) for key in found[0]}


def inertial(rows: dict, k: int) -> np.ndarray:
    """Sphere k's velocity (x, z) from its components along the line of centres and across it."""
    theta = rows["theta"]
    normal, across = np.stack([np.sin(theta), np.cos(theta)]), np.stack([np.cos(theta), -np.sin(theta)])
    return rows[f"velocity_{k}"] * normal + rows[f"tangential_velocity_{k}"] * across


def test_spheres_that_miss_move_on_straight_lines():
    """Without liquid the projectile passes the target (its path 1.4 D off the target's centre): the turning frame's
    terms keep both centres on straight lines at their start velocities."""
    rows = rows_of(pair({**DRY, "second_sphere.tangential_velocity": 0.3, "run.end_time": 0.1}))
    t = rows["t"]
    assert np.abs(rows["x_1"]).max() <= 1e-9 and np.abs(rows["z_1"] - rows["z_1"][0]).max() <= 1e-9
    assert rows["x_2"] == pytest.approx(0.3 * t, abs=1e-6 * 0.03)
    assert rows["z_2"] == pytest.approx(rows["z_2"][0] - 0.3 * t, abs=1e-6 * 0.03)
    assert rows["theta"][-1] > 0.5  # the line of centres has turned


@pytest.mark.parametrize(("ratio", "speed"), [(1.0, 0.1), (0.5, 0.12)])
def test_a_dry_sliding_pair_follows_the_rigid_theory_and_keeps_momentum(ratio, speed):
    """A dry pair sliding through its contact (equal spheres, and a projectile half the target's size): psi_out =
    psi_in + (7/2) mu (1 + e_n) as for a sphere on a wall (m* (1/m_1 + 1/m_2) = 1 for solid spheres), the tangential
    impulse mu times the normal one (each within 1 %), and the linear and angular momentum and the energy kept."""
    changes = {**DRY, "second_sphere.tangential_velocity": speed, "second_sphere.diameter": ratio * 0.0127}
    scene = pair(changes)
    found = simulate(scene, "ode", MPI.COMM_SELF, None, progress=False, plots=False)["oblique_impacts"][0]["contact"]
    rigid = oblique_rigid_theory(found["psi_in"], found["normal_restitution"], 0.1)
    assert rigid.sliding
    assert found["psi_out"] == pytest.approx(rigid.psi_out, rel=0.01)
    assert found["effective_friction"] == pytest.approx(0.1, rel=0.01)
    rows = rows_of(scene)
    masses = [sphere.mass for sphere in scene.spheres]
    inertias = [0.4 * sphere.mass * sphere.radius**2 for sphere in scene.spheres]
    velocities = [inertial(rows, k) for k in (1, 2)]
    momentum = masses[0] * velocities[0] + masses[1] * velocities[1]
    scale = masses[1] * 0.3
    assert np.abs(momentum - momentum[:, :1]).max() <= 1e-5 * scale
    centres = [np.stack([rows[f"x_{k}"], rows[f"z_{k}"]]) for k in (1, 2)]
    angular = sum(m * (r[1] * v[0] - r[0] * v[1]) + inertia * rows[f"spin_{k}"]  # about y: z v_x - x v_z
                  for k, m, r, v, inertia in zip((1, 2), masses, centres, velocities, inertias))
    assert np.abs(angular - angular[0]).max() <= 1e-4 * scale * scene.sphere.diameter
    energy = (sum(0.5 * m * (v**2).sum(axis=0) for m, v in zip(masses, velocities)) + rows["spring_energy"]
              + sum(0.5 * inertia * rows[f"spin_{k}"] ** 2 for k, inertia in zip((1, 2), inertias)))
    assert (energy - energy[0]).max() <= 1e-5 * energy[0]
    assert energy[-1] < 0.99 * energy[0]  # the contact's damping and friction took their share


def test_a_sticking_pair_rebounds_with_its_contact_point_reversed_or_stopped():
    """Below the sliding threshold the contact point's slip is brought near rest and the spring may turn it back
    (the compliant rebound of Maw, Barber & Fawcett 1976, as for a sphere on a wall): |psi_out| well below psi_in."""
    scene = pair({**DRY, "second_sphere.tangential_velocity": 0.02})
    found = simulate(scene, "ode", MPI.COMM_SELF, None, progress=False, plots=False)["oblique_impacts"][0]["contact"]
    assert abs(found["psi_in"]) < 3.5 * 0.1 * (1.0 + found["normal_restitution"])
    assert abs(found["psi_out"]) < 0.5 * abs(found["psi_in"])
    assert found["spin_out"][0] == pytest.approx(found["spin_out"][1], rel=1e-9)  # equal spheres, equal torques


def test_a_head_on_pair_runs_no_oblique_code_and_a_grazing_one_leaves_its_normal_motion():
    head_on = BodyIntegrator(pair({}))
    assert head_on.tangential is None and head_on.pair_frame is None
    head_on.destroy()
    found = {}
    for speed in (0.0, 1e-9):
        summary = simulate(pair({"second_sphere.tangential_velocity": speed}), "ode", MPI.COMM_SELF, None,
                           progress=False, plots=False)
        found[speed] = summary["collisions"][0]["restitution"]
    assert found[1e-9] == pytest.approx(found[0.0], rel=1e-4)


@pytest.mark.parametrize(("changes", "message"), [
    ({"second_sphere.tangential_velocity": 0.1, "contact.friction": None}, "needs contact.friction"),
    ({"second_sphere.spin": 5.0, "gravity": 9.81}, "without a wall or gravity"),
    ({"second_sphere.tangential_velocity": 0.1, "wall.present": True}, "wall.present = true"),
    ({"second_sphere.tangential_velocity": 0.1, "second_sphere.mode": "prescribed"}, "fixed or prescribed"),
    ({"second_sphere.tangential_velocity": 0.1, "contact.inertial_speed": "whole"}, "component"),
])
def test_an_oblique_pair_scene_is_checked(changes, message):
    with pytest.raises(scenes.SceneError, match=message):
        pair(changes)


def test_only_the_ode_model_runs_a_pair_off_its_line_of_centres():
    scene = pair({"second_sphere.tangential_velocity": 0.1})
    for name in ("fd", "ale"):
        with pytest.raises(models.ModelError, match="a pair off its line of centres.*--model ode$"):
            models.check_scene(models.info(name), scene)
    with pytest.raises(models.ModelError, match="use ode$"):
        models.check_scene(models.info("fd3d"), scene)
    models.check_scene(models.info("ode"), scene)
    assert models.choose(scene)[0] == "ode"
