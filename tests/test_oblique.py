"""Oblique collisions in the reduced model (fem_bounce.oblique): the scene's checks, the dry limit against the
rigid-body theory of Coulomb friction (Foerster et al. 1994's glass), energy, sliding and rolling, the liquid's
part, the Jacobian's tangential block against differences, and the head-on motion left as it was."""
from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from fem_bounce import models
from fem_bounce import scene as scenes
from fem_bounce.integrator import BodyIntegrator
from fem_bounce.run import simulate
from fem_bounce.tangential_contact import oblique_rigid_theory, sliding_threshold
from residual_differences import central

GLASS_D, GLASS_SPEED, GLASS_MU, GLASS_E = 3.18e-3, 1.7, 0.125, 0.83  # Foerster, Louge, Chang & Allia (1994)


def dry_glass(psi_in: float) -> scenes.Scene:
    """Foerster's glass sphere at 1.7 m/s onto glass, the liquid made negligible (1e-7 Pa s, 1e-3 kg/m3)."""
    return scenes.load("li2011-case3", {
        "run.bounces": 1, "gravity": 0.0, "initial_gap": 0.05 * GLASS_D, "initial_velocity": -GLASS_SPEED,
        "tangential_velocity": psi_in * GLASS_SPEED, "contact.friction": GLASS_MU, "contact.dry_restitution": GLASS_E,
        "contact.history": "off", "sphere.diameter": GLASS_D, "sphere.density": 2500.0, "sphere.youngs_modulus": 7e10,
        "sphere.poisson_ratio": 0.22, "wall.youngs_modulus": 7e10, "wall.poisson_ratio": 0.22,
        "liquid.viscosity": 1e-7, "liquid.density": 1e-3})


def impact(scene: scenes.Scene, station: str = "contact") -> dict:
    summary = simulate(scene, "ode", MPI.COMM_SELF, None, progress=False, plots=False)
    return summary["oblique_impacts"][0][station]


def case3_oblique(angle: float, friction: float = 0.02) -> scenes.Scene:
    """Case 3's sphere launched at the wall from 0.5 D at 0.39 m/s (its impact speed), `angle` degrees off the
    normal, without gravity; steel on Zerodur wet (Joseph & Hunt 2004's steel: 0.02)."""
    speed, theta = 0.39, math.radians(angle)
    return scenes.load("li2011-case3", {"run.bounces": 1, "gravity": 0.0, "initial_gap": 0.5 * 0.0095,
                                        "initial_velocity": -speed * math.cos(theta),
                                        "tangential_velocity": speed * math.sin(theta), "contact.friction": friction})


def test_the_axisymmetric_models_refuse_an_oblique_scene():
    scene = case3_oblique(30.0)
    for name in ("fd", "ib", "ale"):
        with pytest.raises(models.ModelError, match="axisymmetric.*--model ode"):
            models.check_scene(models.info(name), scene)
    models.check_scene(models.info("ode"), scene)


@pytest.mark.parametrize(("changes", "message"), [
    ({"tangential_velocity": 0.1}, "needs contact.friction"),
    ({"spin": 10.0, "contact.friction": 0.1, "contact.model": "li2011"}, 'needs contact.model = "lubricated-hertz"'),
    ({"gravity_angle": 20.0, "contact.friction": 0.1, "wall.present": False}, "one free sphere and a wall"),
])
def test_an_oblique_scene_is_checked(changes, message):
    with pytest.raises(scenes.SceneError, match=message):
        scenes.load("li2011-case3", changes)


@pytest.mark.slow
@pytest.mark.parametrize("psi_in", [1.1, 1.4])
def test_dry_sliding_follows_the_rigid_theory(psi_in):
    """Above (7/2) mu (1 + e_n) the contact slides throughout: psi_out = psi_in - (7/2) mu (1 + e_n) and the
    tangential impulse is mu times the normal one (measured within 1e-4 of both)."""
    found = impact(dry_glass(psi_in))
    assert found["normal_restitution"] == pytest.approx(GLASS_E, rel=1e-3)
    rigid = oblique_rigid_theory(found["psi_in"], found["normal_restitution"], GLASS_MU)
    assert rigid.sliding
    assert found["psi_out"] == pytest.approx(rigid.psi_out, rel=0.01)
    assert found["effective_friction"] == pytest.approx(GLASS_MU, rel=0.01)


@pytest.mark.slow
def test_dry_sliding_begins_where_the_rigid_theory_says():
    """psi_out crosses 0 at psi_in = (7/2) mu (1 + e_n), found between two runs either side (within 2 %; measured
    within 0.1 %); below it the tangential spring gives the rebound a reversed contact point (psi_out < 0), as
    Maw, Barber & Fawcett's compliant theory has it, where the rigid theory has psi_out = 0."""
    low, high = 0.74, 0.86
    below, above = impact(dry_glass(low)), impact(dry_glass(high))
    assert below["psi_out"] < 0.0 < above["psi_out"]
    crossing = low + (high - low) * -below["psi_out"] / (above["psi_out"] - below["psi_out"])
    assert crossing == pytest.approx(sliding_threshold(GLASS_E, GLASS_MU), rel=0.02)


@pytest.mark.slow
@pytest.mark.parametrize("psi_in", [0.3, 0.6, 1.1])
def test_a_stiff_tangential_spring_gives_the_rigid_theory_on_both_branches(psi_in):
    """With the tangential spring 1e4 times the normal stiffness (contact.tangential_stiffness) the sticking
    contact point stops dead: below (7/2) mu (1 + e_n) the sphere rolls off, psi_out = 0 and v_t out = 5/7 of v_t
    in; above, it slides as with Mindlin's spring (within 1 %)."""
    found = impact(dry_glass(psi_in).replace(**{"contact.tangential_stiffness": 1e4}))
    rigid = oblique_rigid_theory(found["psi_in"], found["normal_restitution"], GLASS_MU)
    assert rigid.sliding == (psi_in > sliding_threshold(GLASS_E, GLASS_MU))
    if rigid.sliding:
        assert found["psi_out"] == pytest.approx(rigid.psi_out, rel=0.01)
    else:
        assert abs(found["psi_out"]) < 1e-3 * found["psi_in"]
        assert found["tangential_velocity_out"] == pytest.approx(5.0 / 7.0 * found["tangential_velocity_in"], rel=1e-3)


@pytest.mark.slow
@pytest.mark.parametrize("psi_in", [0.3, 0.6, 1.2])
def test_a_dry_collision_creates_no_energy(psi_in):
    """The kinetic energy of translation and spin after the contact is below that before it (the Hertz damping
    and the friction take it; the spring stores and returns), whether the contact sticks or slides."""
    found = impact(dry_glass(psi_in))
    a = 0.5 * GLASS_D

    def energy(normal, along, spin):
        return normal**2 + along**2 + 0.4 * (a * spin) ** 2  # 2 E / m, I = (2/5) m a^2

    before = energy(found["normal_speed_in"], found["tangential_velocity_in"], found["spin_in"])
    after = energy(found["normal_speed_out"], found["tangential_velocity_out"], found["spin_out"])
    assert after < before
    assert found["effective_friction"] <= GLASS_MU * (1.0 + 1e-3)  # Coulomb's bound on the impulse


def test_a_wet_oblique_impact_slows_and_spins_the_sphere():
    """Case 3's sphere at 30 degrees: the film and the friction slow its sliding contact point and spin it up in
    the rolling sense.  Without the lift (contact.lift, tests/test_wall_lift.py) the normal rebound is the head-on
    one's (nothing else of the tangential motion acts back), but with contact.inertial_speed = "whole", whose drag's
    inertial factor is the whole speed's: the approach is then slower than head-on."""
    without_lift = case3_oblique(30.0).replace(**{"contact.lift": "off"})
    found = impact(without_lift, "outer")
    assert 0.0 < found["psi_out"] < found["psi_in"]
    assert found["spin_out"] > 0.0
    assert 0.0 < found["tangential_restitution"] < 1.0
    head_on = simulate(scenes.load("li2011-case3", {"run.bounces": 1, "gravity": 0.0, "initial_gap": 0.5 * 0.0095,
                                                    "initial_velocity": -0.39 * math.cos(math.radians(30.0))}),
                       "ode", MPI.COMM_SELF, None, progress=False, plots=False)
    # the same normal motion where it crosses delta_sl D, to the step control's tolerance (the tangential unknowns
    # enter its error norm)
    speeds = {c["direction"]: abs(c["speed"]) for c in head_on["blend_crossings"]}
    assert found["normal_speed_in"] == pytest.approx(speeds["in"], rel=1e-4)
    assert found["normal_restitution"] == pytest.approx(speeds["out"] / speeds["in"], rel=1e-4)
    whole = impact(without_lift.replace(**{"contact.inertial_speed": "whole"}), "outer")
    assert 0.0 < 1.0 - whole["normal_speed_in"] / speeds["in"] < 0.02


def test_the_normal_motion_is_the_head_on_one():
    """A vanishing tangential velocity: the normal impact and rebound as without the tangential unknowns,
    within the integrator's tolerance (rtol 1e-5)."""
    head_on = simulate(scenes.load("li2011-case3", {"run.bounces": 1}), "ode", MPI.COMM_SELF, None, progress=False,
                       plots=False)
    barely = simulate(scenes.load("li2011-case3", {"run.bounces": 1, "tangential_velocity": 1e-9,
                                                   "contact.friction": 0.02}),
                      "ode", MPI.COMM_SELF, None, progress=False, plots=False)
    for key in ("impact_speed", "Re", "min_gap"):
        assert barely["impacts"][0][key] == pytest.approx(head_on["impacts"][0][key], rel=1e-4), key
    assert barely["rebounds"][0]["restitution"] == pytest.approx(head_on["rebounds"][0]["restitution"], rel=1e-4)


@pytest.mark.parametrize(("engaged", "slip", "stretch"), [(False, 0.18, 0.0), (True, 0.18, 1e-9), (True, 1e-5, 1e-10)],
                         ids=["film", "contact, friction at its limit", "contact, spring and damper"])
def test_the_tangential_block_of_the_jacobian(engaged, slip, stretch):
    """The tangential rows' derivatives in the tangential unknowns are exact (in the film and, within its
    sticking or sliding state, in the contact), and so is the film's coupling to the gap; the friction's
    dependence on the normal state is left out (oblique.py) and not checked here.  Steps of 1e-6 of each
    unknown's size (a tenth of the stretch's, in which the friction is linear within its state): far above
    round-off, far below the scales on which the terms vary."""
    integrator = BodyIntegrator(case3_oblique(30.0))
    try:
        rng = np.random.default_rng(3)
        y = np.array(integrator.y.array_r)
        along = integrator.tangential_slice
        gap = 1.5e-7 if engaged else 2e-5
        y[0], y[1] = gap, -0.3
        y[2:along.start] = 1e-3 * rng.normal(size=along.start - 2)
        radius = integrator.bodies[0].sphere.radius
        tangential = integrator.tangential
        y[along.start:along.start + 4] = (1e-4, 0.2, (0.2 - slip) / radius, stretch)
        y[along.start + 4:along.stop] = 1e-3 * rng.normal(size=along.stop - along.start - 4)  # the history modes
        ydot = rng.normal(size=len(y))
        if engaged:
            integrator.wall.record.contact_crossing(y[0], -0.35)
        shift, t = 1e3, 0.01
        exact = integrator.jacobian(t, y, ydot, shift)[along]
        steps = dict(zip(range(along.start, along.start + 4), (1e-10, 1e-9, 1e-7, 0.1 * max(stretch, 1e-9))))
        for modes in (tangential.translation, tangential.rotation):  # the residual is linear in them: any step
            steps.update({along.start + k: 1e-6 for k in (modes.start, modes.stop - 1)})
        if not engaged:
            steps[0] = 1e-4 * gap
        # round-off: a few hundred ulps of the size of each row's terms, over the step
        terms = np.abs(exact) @ np.abs(y) + np.abs(integrator.residual(t, y, ydot)[along])
        for column, step in steps.items():
            derivative = (central(integrator, t, y, ydot, column, step)
                          + shift * central(integrator, t, y, ydot, column, 1e-3, rates=True))[along]
            allowed = 1e-5 * np.abs(derivative) + 1e-13 * terms / step
            assert np.all(np.abs(exact[:, column] - derivative) <= allowed), (column, exact[:, column], derivative)
    finally:
        integrator.destroy()


def test_the_whole_speeds_drag_couples_the_normal_and_tangential_rows_exactly():
    """contact.inertial_speed = "whole", the drag's inertial factor at the whole speed's Re (oblique.py,
    theory.TheoryForces.drag_slopes): the normal velocity's row's derivative in the velocity along the wall and the
    tangential rows' in the normal velocity are exact, in the film (no contact: the friction's dependence on the
    normal state is left out, oblique.py), with the default screened law and the paper's multiplied one."""
    for law in ("screened", "schiller-naumann"):
        integrator = BodyIntegrator(case3_oblique(30.0).replace(**{"contact.inertial_factor": law,
                                                                   "contact.inertial_speed": "whole"}))
        try:
            y = np.array(integrator.y.array_r)
            along = integrator.tangential_slice
            y[0], y[1] = 0.3 * 0.0127, -0.3  # a gap of 0.3 D: the screening's share varies there
            y[along.start + 1], y[along.start + 2] = 0.2, 5.0
            ydot = np.zeros(len(y))
            t, velocity, sliding = 0.01, 1, along.start + 1
            exact = integrator.jacobian(t, y, ydot, 0.0)
            for row, column in ((velocity, sliding), (along, velocity)):
                derivative = central(integrator, t, y, ydot, column, 1e-7)[row]
                terms = np.abs(integrator.residual(t, y, ydot)[row]) + 1e-30
                assert np.all(np.abs(exact[row, column] - derivative) <= 1e-6 * np.abs(derivative) + 1e-12 * terms
                              / 1e-7), (law, row, exact[row, column], derivative)
            assert abs(exact[velocity, sliding]) > 1e-6  # the coupling is there (N s/m; the drag's scale 1e-4 N s/m)
        finally:
            integrator.destroy()


# -- a resolved flow's force along the wall (the fd3d model's, kinematics.PlaneForce) ------------------------------

PLANE_MASS = np.array([[2.0e-3, 1.0e-4, -2.0e-7], [3.0e-4, 1.5e-3, 4.0e-7], [-1.0e-7, 2.0e-7, 3.0e-9]])  # over V, U, Om


def resolved_integrator(explicit=(2.0e-3, -1.0e-3, 4.0e-7)) -> BodyIntegrator:
    """Case 3's sphere far from the wall (no film, no correction) with a resolved flow's linearised force over
    (V, U, Omega) handed over as a fluid step would: explicit - PLANE_MASS (V', U', Omega')'."""
    from fem_bounce.kinematics import FluidForce, PlaneForce

    integrator = BodyIntegrator(scenes.load("li2011-case3", {"run.bounces": 1, "gravity": 0.0, "initial_gap": 0.02,
                                                              "initial_velocity": -0.3, "tangential_velocity": 0.2,
                                                              "contact.friction": 0.02}), resolved=True)
    integrator.fluid = FluidForce(np.array(explicit[:1]), PLANE_MASS[:1, :1],
                                  PlaneForce(np.array(explicit[1:]), PLANE_MASS))
    integrator.tangential.fluid = integrator.fluid.plane
    return integrator


def test_a_resolved_flows_added_mass_couples_the_normal_and_tangential_accelerations():
    """Far from the wall the resolved force is all there is: the three accelerations solve
    (diag(m, m, I) + M) a = explicit together, and the trajectory's row says so (f_sim and the tangential liquid
    force and torque are explicit - M a)."""
    explicit = np.array([2.0e-3, -1.0e-3, 4.0e-7])
    integrator = resolved_integrator(explicit)
    try:
        tangential = integrator.tangential
        mass = np.diag([integrator.bodies[0].mass, tangential.mass, tangential.inertia]) + PLANE_MASS
        expected = np.linalg.solve(mass, explicit)
        row = integrator.row(0.0, np.array(integrator.y.array_r))
        assert tangential.mass == pytest.approx(integrator.bodies[0].mass, rel=1e-12)  # no theory added mass
        assert row["acceleration"] == pytest.approx(expected[0], rel=1e-9)
        liquid = explicit - PLANE_MASS @ expected
        assert [row["f_sim"], row["f_tangential_liquid"], row["torque_liquid"]] == pytest.approx(liquid, rel=1e-9)
        integrator.advance(1e-4)
        y = np.array(integrator.y.array_r)
        along = y[integrator.tangential_slice]
        assert [y[1], along[1], along[2]] == pytest.approx([-0.3, 0.2, 0.0] + 1e-4 * expected, rel=1e-7, abs=1e-12)
    finally:
        integrator.destroy()


def test_the_resolved_tangential_rows_jacobian():
    """The Jacobian of the rows a resolved flow's force enters (the normal row through the added mass on U' and
    Omega', the tangential rows through all three accelerations) against central differences (steps as in the
    theory's check above)."""
    integrator = resolved_integrator()
    try:
        rng = np.random.default_rng(5)
        y = np.array(integrator.y.array_r)
        ydot = rng.normal(size=len(y))
        along = integrator.tangential_slice
        rows = [1, *range(along.start, along.stop)]
        shift, t = 1e3, 0.0
        exact = integrator.jacobian(t, y, ydot, shift)[rows]
        terms = np.abs(exact) @ np.abs(y) + np.abs(integrator.residual(t, y, ydot)[rows])
        for column, step in ((1, 1e-9), (along.start + 1, 1e-9), (along.start + 2, 1e-7)):
            derivative = (central(integrator, t, y, ydot, column, step)
                          + shift * central(integrator, t, y, ydot, column, 1e-3, rates=True))[rows]
            allowed = 1e-6 * np.abs(derivative) + 1e-13 * terms / step
            assert np.all(np.abs(exact[:, column] - derivative) <= allowed), (column, exact[:, column], derivative)
    finally:
        integrator.destroy()


def test_the_spins_history_kernel_and_its_modes():
    """theory.rotation_kernel has the boundary layer's short-time limit 1 / sqrt(pi x) - 1 and the s^(-3/2) tail
    1 / (2 sqrt(pi) x^(3/2)) of the unsteady Stokes solution, and its exponential sum (the modes the reduced model
    integrates) matches it within 1e-3 from 1e-8 to 1e2 diffusion times a^2 / nu."""
    from fem_bounce.theory import HISTORY_SPAN, rotation_history_modes, rotation_kernel

    short, long = np.array([1e-10, 1e-8]), np.array([1e3, 1e4])
    assert rotation_kernel(short) == pytest.approx(1.0 / np.sqrt(np.pi * short) - 1.0, rel=1e-3)
    assert rotation_kernel(long) == pytest.approx(0.5 / np.sqrt(np.pi) * long**-1.5, rel=2e-3)
    theta, weights = rotation_history_modes(3)
    assert np.all(weights >= 0.0)
    x = np.logspace(*np.log10(HISTORY_SPAN), 400)
    fit = np.exp(-x[:, None] / theta[None, :]) @ weights
    assert np.max(np.abs(fit / rotation_kernel(x) - 1.0)) < 1e-3
