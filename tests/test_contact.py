"""The contact model's functions: end points, midpoints and the Hertz scale (docs/physics.md section 2)."""
import math

import numpy as np
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
    model = contact.ContactModel(scene.load("li2011-case3", {"contact.model": "li2011"}))
    assert model.e_star == pytest.approx(e_star, rel=1e-12)
    assert model.e_star == pytest.approx(67.5e9, rel=2e-3)
    # eq. 4.7 by hand: (4/3) a^2 E* (5 pi rho V^2 / (4 E*))^(3/5)
    a, rho, v = 0.00475, 7780.0, 0.4
    by_hand = 4 / 3 * a**2 * e_star * math.exp(0.6 * math.log(5 * math.pi * rho * v**2 / (4 * e_star)))
    assert model.law.engage(0.4) == pytest.approx(by_hand, rel=1e-12)
    assert 95.0 < model.law.engage(0.4) < 115.0


def test_papers_spring_uses_dry_restitution_and_gap():
    law = contact.ContactModel(scene.load("li2011-case3", {"contact.model": "li2011"})).law
    assert law.force(0.0, -0.1, 100.0) == pytest.approx(97.0)
    assert law.force(law.boundary(0.4), -0.1, 100.0) == 0.0
    assert law.boundary(0.4) == pytest.approx(0.017 * 0.0095)


def test_contact_gap_is_the_elastohydrodynamic_gap_or_the_roughness():
    """h_c = max(combined roughness, x_d) with x_d = (4 theta mu V a^1.5)^0.4, theta = 1 / (pi E*): 0.43 um
    for case 3's impact speed (docs/physics.md section 2), 0.04 um of roughness at a slow approach."""
    law = contact.ContactModel(scene.load("li2011-case3")).law
    assert law.boundary(0.393) == pytest.approx(0.43e-6, rel=0.02)
    theta = 1.0 / (math.pi * law.e_star)
    assert law.boundary(0.393) == pytest.approx((4 * theta * 0.0502 * 0.393 * 0.00475**1.5) ** 0.4, rel=1e-12)
    assert law.boundary(1e-6) == pytest.approx(4e-8, rel=1e-12)  # sphere and wall, 0.02 um each
    assert law.engage(0.393) == law.boundary(0.393)
    assert law.boundary(0.1, engaged=3e-7) == 3e-7  # a contact ends where it began


def _dry_impact(law, speed, mass):
    """Integrate m x'' = -f(h_c - x) through one contact with nothing but the law: (rebound speed, largest
    force, contact time)."""
    from scipy.integrate import solve_ivp

    h_c = law.engage(speed)

    def rhs(t, y):
        return [y[1], law.force(y[0], y[1], h_c) / mass]

    def leaves(t, y):
        return y[0] - h_c if t > 0 else -1.0
    leaves.terminal, leaves.direction = True, 1
    time_scale = contact.hertz_contact_time(law.radius, mass, law.e_star, speed)
    solution = solve_ivp(rhs, (0, 10 * time_scale), [h_c, -speed], events=leaves, rtol=1e-10, atol=1e-16,
                         method="DOP853", max_step=time_scale / 200, dense_output=True)
    times = np.linspace(0, solution.t_events[0][0], 4001)
    states = solution.sol(times)
    forces = [law.force(h, v, h_c) for h, v in states.T]
    return solution.y_events[0][0][1], max(forces), solution.t_events[0][0]


@pytest.mark.parametrize("dry", [0.97, 0.6])
def test_dry_restitution_is_e_d_at_every_speed(dry):
    """Tsuji's damping makes the dry restitution independent of the impact speed: e = e_d from 1 cm/s to
    4 m/s (a damped Hertz law, Tsuji, Tanaka & Ishida 1992)."""
    sc = scene.load("li2011-case3", {"contact.dry_restitution": dry})
    law = contact.ContactModel(sc).law
    for speed in (0.01, 0.4, 4.0):
        rebound, _, _ = _dry_impact(law, speed, sc.sphere.mass)
        assert rebound / speed == pytest.approx(dry, abs=2e-4)


def test_undamped_law_is_hertz():
    """With e_d = 1 the law is Hertz's: peak force (4/3) E* a^(1/2) x_m^(3/2) and contact time 2.94 x_m / V
    (Johnson 1985, section 11.1), for a sphere of 3.5 g at 0.4 m/s: about 105 N for 50 us."""
    sc = scene.load("li2011-case3", {"contact.dry_restitution": 1.0})
    law, mass, speed = contact.ContactModel(sc).law, sc.sphere.mass, 0.4
    rebound, peak, duration = _dry_impact(law, speed, mass)
    assert rebound == pytest.approx(speed, rel=1e-6)
    assert peak == pytest.approx(contact.hertz_peak_force(law.radius, mass, law.e_star, speed), rel=1e-4)
    assert duration == pytest.approx(contact.hertz_contact_time(law.radius, mass, law.e_star, speed), rel=2e-3)
    assert 95.0 < peak < 115.0 and 40e-6 < duration < 60e-6


def test_lubrication_is_continuous_at_the_contact_gap_and_fades_to_contact():
    """Inside a contact the film is held at h_c and its share falls linearly to 0 at h = 0: the drag is
    continuous at h_c and its wall excess is gone at h = 0 (the sphere then feels the free drag)."""
    model = contact.ContactModel(scene.load("li2011-case3"))
    law, theory = model.law, model.theory
    h_c = law.engage(0.3)
    above = theory.drag(h_c * (1 + 1e-9), -0.3)
    below = theory.drag(*law.film(h_c * (1 - 1e-9), h_c)[:1], -0.3, law.film(h_c * (1 - 1e-9), h_c)[1])
    assert below == pytest.approx(above, rel=1e-6)
    gap, share = law.film(0.0, h_c)
    assert gap == h_c and share == 0.0
    assert theory.drag(gap, -0.3, share) == pytest.approx(theory.drag(1e9, -0.3), rel=1e-12)
    assert law.film(-1e-6, h_c)[1] == 0.0  # deeper in: nothing left
    assert law.film(2 * h_c, h_c) == (2 * h_c, 1.0) and law.film(1e-7, None) == (1e-7, 1.0)


def test_pair_law_tends_to_the_wall_law():
    """One law, written once: a second sphere of growing radius and mass (and the wall's material) gives
    the wall's contact gap, Hertz stiffness and force."""
    from fem_bounce.pair_contact import PairContactModel

    single = scene.load("li2011-case3")
    big_diameter = 1e3  # the largest a scene allows
    # a* = a1 a2 / (a1 + a2) differs from a1 by a1 / a2 relatively; the law's gaps and forces go as a*^(1/2)
    # to a*^(3/5), so they differ by less; the mass ratio (1e-17) is negligible
    rel = single.sphere.diameter / big_diameter
    for model in ("lubricated-hertz", "li2011"):
        wall_law = contact.ContactModel(single.replace(**{"contact.model": model})).law
        big = single.replace(**{"contact.model": model, "contact.history": "off", "second_sphere": {
            "diameter": big_diameter, "density": 1e5, "youngs_modulus": 91e9, "poisson_ratio": 0.24, "gap": 0.01,
            "roughness": single.wall.roughness, "mode": "free"}})
        pair_law = PairContactModel(big).law
        assert pair_law.radius == pytest.approx(wall_law.radius, rel=rel)
        assert pair_law.radius != pytest.approx(wall_law.radius, rel=0.1 * rel)  # the difference is a1 / a2
        assert pair_law.boundary(0.4) == pytest.approx(wall_law.boundary(0.4), rel=rel)
        engaged = (pair_law.engage(0.4), wall_law.engage(0.4))
        assert engaged[0] == pytest.approx(engaged[1], rel=rel)
        gap = 0.5 * engaged[1] if model == "li2011" else engaged[1] - 2e-6
        assert pair_law.force(gap, -0.2, engaged[0]) == pytest.approx(wall_law.force(gap, -0.2, engaged[1]), rel=rel)


def test_damping_coefficient_of_the_dry_restitution():
    assert contact.tsuji_damping(1.0) == 0.0
    assert contact.tsuji_damping(0.97) == pytest.approx(0.0218, rel=0.01)
    assert contact._damped_restitution(contact.tsuji_damping(0.5)) == pytest.approx(0.5, abs=1e-8)
    assert contact._damped_restitution(contact.tsuji_damping(0.0)) == 0.0


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
