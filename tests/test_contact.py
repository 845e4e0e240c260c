"""The contact model's functions: end points, midpoints and the Hertz scale (docs/physics.md section 2)."""
import math

import pytest

from fem_bounce import contact, scene


def test_elastic_shape_end_points():
    assert contact.elastic_shape(0.0) == pytest.approx(1.0)
    assert contact.elastic_shape(1.0) == 0.0
    assert contact.elastic_shape(1.5) == 0.0
    assert 0.0 < contact.elastic_shape(0.5) < 1.0


def test_blend_is_one_half_at_delta_sl_and_one_at_contact():
    assert contact.blend(0.2, 0.2) == pytest.approx(0.5)
    assert contact.blend(0.0, 0.2) == pytest.approx(1.0, abs=1e-4)
    assert contact.blend(1.0, 0.2) < 1e-15


def test_steel_on_zerodur_hertz_scale():
    # E* ~ 67 GPa, W_o ~ 100 N at V_I = 0.4 m/s for D = 9.5 mm steel on Zerodur
    e_star = 1.0 / ((1 - 0.33**2) / 200e9 + (1 - 0.24**2) / 91e9)
    model = contact.ContactModel(scene.load("li2011-case3"))
    assert model.e_star == pytest.approx(e_star, rel=1e-12)
    assert model.e_star == pytest.approx(67.5e9, rel=2e-3)
    # eq. 4.7 by hand: (4/3) a^2 E* (5 pi rho V^2 / (4 E*))^(3/5)
    a, rho, v = 0.00475, 7780.0, 0.4
    by_hand = 4 / 3 * a**2 * e_star * math.exp(0.6 * math.log(5 * math.pi * rho * v**2 / (4 * e_star)))
    assert model.hertz_force(0.4) == pytest.approx(by_hand, rel=1e-12)
    assert 95.0 < model.hertz_force(0.4) < 115.0


def test_elastic_force_uses_dry_restitution_and_gap():
    model = contact.ContactModel(scene.load("li2011-case3"))
    assert model.elastic(0.0, 100.0) == pytest.approx(97.0)
    assert model.elastic(model.contact_gap, 100.0) == 0.0


# -- the near-wall force of a free sphere (docs/physics.md section 3) ----------------------------------


def _free(**changes):
    return scene.load("li2011-case3", changes)


def test_default_theory_force_tends_to_the_lubrication_limit_at_contact():
    """f_thr's drag is Brenner's lambda plus the free-sphere inertial factor less one: near contact the
    lubrication term 1/(2 delta) dominates and inertia only adds a finite part (Cox & Brenner 1967)."""
    theory = contact.ContactModel(_free()).theory
    speed, diameter = -0.4, 0.0095
    lubrication = 6 * math.pi * 0.0502 * 0.00475 * 0.4 / (2 * 1e-5)
    assert theory.drag(1e-5 * diameter, speed) == pytest.approx(lubrication, rel=2e-3)
    # the multiplied form would scale the singularity by the wake factor (about 4.3 at Re 90)
    multiplied = contact.ContactModel(_free(**{"contact.inertial_factor": "schiller-naumann"})).theory
    assert multiplied.drag(1e-5 * diameter, speed) / lubrication > 4.0


def test_default_theory_force_is_the_free_sphere_drag_far_from_the_wall():
    sc = _free()
    theory = contact.ContactModel(sc).theory
    speed = -0.4
    schiller_naumann = 6 * math.pi * 0.0502 * 0.00475 * 0.4 * (1 + 0.15 * sc.reynolds(speed) ** 0.687)
    assert theory.drag(1e3 * sc.sphere.diameter, speed) == pytest.approx(schiller_naumann, rel=1e-3)


def test_correction_vanishes_where_the_flow_is_resolved_and_off_the_free_motion():
    model = contact.ContactModel(_free())
    assert model.hold_gap == pytest.approx(0.2 * 0.0095)
    assert model.correction(model.hold_gap, -0.4) == (0.0, 0.0)
    assert model.correction(0.5 * 0.0095, -0.4) == (0.0, 0.0)
    force, added_mass = model.correction(0.19 * 0.0095, -0.4)
    assert force > 0.0 and added_mass > 0.0  # resists the approach; the wall's added mass grows
    for changes in ({"contact.near_wall": "blend"}, {"motion.mode": "prescribed", "motion.velocity": -0.1}):
        other = contact.ContactModel(_free(**changes))
        assert other.hold_gap == 0.0 and other.correction(0.05 * 0.0095, -0.4) == (0.0, 0.0)


def test_held_flow_plus_correction_is_brenner_in_stokes_flow():
    """In quasi-steady Stokes flow a flow held at delta_sl gives 6 pi mu a V lambda(delta_sl); the correction
    makes the total Brenner's lambda at the true gap, at every gap below delta_sl."""
    model = contact.ContactModel(_free(**{"contact.history": "off"}))
    stokes, speed = model.theory.stokes_drag, -1e-6  # slow: the added-mass term (V^2) vanishes
    held = -stokes * speed * model.theory.wall_factor(model.hold_gap)
    for delta in (0.15, 0.05, 0.01, 1e-3):
        force, _ = model.correction(delta * 0.0095, speed)
        exact = -stokes * speed * model.theory.wall_factor(delta * 0.0095)
        assert held + force == pytest.approx(exact, rel=1e-5)


def test_correction_force_diverges_like_lubrication():
    model = contact.ContactModel(_free())
    speed = -0.4
    forces = [model.correction(delta * 0.0095, speed)[0] for delta in (1e-4, 1e-5)]
    stokes = model.theory.stokes_drag * 0.4
    assert forces[1] - forces[0] == pytest.approx(stokes * (0.5 / 1e-5 - 0.5 / 1e-4), rel=1e-3)
