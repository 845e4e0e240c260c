"""Two-sphere Stokes resistance (fem_bounce/pair_theory.py) against closed forms, limits and asymptotes."""
import math

import numpy as np
import pytest

from fem_bounce import pair_theory, reference, theory

GAPS = (1e-3, 1e-2, 0.1, 1.0, 10.0, 100.0)  # h / a


@pytest.mark.parametrize("h", GAPS)
def test_equal_spheres_moving_together_match_stimson_jeffery(h):
    x = pair_theory.resistance(1.0, 1.0, h)
    assert x[0, 0] + x[0, 1] == pytest.approx(pair_theory.stimson_jeffery(1.0, h), rel=1e-8, abs=0)
    assert x[1, 1] + x[1, 0] == pytest.approx(pair_theory.stimson_jeffery(1.0, h), rel=1e-8, abs=0)


def test_stimson_jeffery_limits():
    # touching equal spheres: 0.645 (the contact limit of Stimson & Jeffery's series; Cooley & O'Neill 1969)
    assert pair_theory.stimson_jeffery(1.0, 1e-6) == pytest.approx(0.645, abs=5e-4)
    assert pair_theory.stimson_jeffery(2.0, 2e-6) == pytest.approx(pair_theory.stimson_jeffery(1.0, 1e-6), rel=1e-12)
    assert pair_theory.stimson_jeffery(1.0, 1e4) == pytest.approx(1.0, abs=1e-3)


@pytest.mark.parametrize("h", GAPS)
def test_equal_spheres_approaching_match_brenner_free_surface(h):
    # the mid-plane of two spheres approaching at +-U is a free-slip plane of symmetry:
    # Brenner's (1961) free-surface series at gap h/2, a closed form independent of the 4x4 solves
    x = pair_theory.resistance(1.0, 1.0, h)
    assert x[0, 0] - x[0, 1] == pytest.approx(pair_theory.equal_spheres_approach(1.0, h), rel=1e-9, abs=0)


def test_equal_spheres_approaching_are_not_the_rigid_wall_case():
    # a rigid wall at h/2 would give 4 times the pair's leading lubrication term: the no-slip
    # wall is NOT the plane of symmetry (docs/pair_theory.md)
    h = 1e-3
    wall = theory.brenner_series(0.5 * h / 2.0)
    pair = pair_theory.equal_spheres_approach(1.0, h)
    assert wall / pair == pytest.approx(4.0, rel=0.02)


@pytest.mark.parametrize("row", reference.table("brenner1961_wall_drag"), ids=lambda r: f"delta={r['delta']}")
def test_large_second_sphere_tends_to_the_wall(row):
    # a1 = 1 at gap h = 2 delta beside a sphere of radius 1e3 and 1e4: Brenner's wall factor,
    # with a curvature error of order a1/a2 that shrinks tenfold with the radius
    wall = row["lambda_brenner"]
    errors = [abs(pair_theory.approach_fixed(1.0, big, 2.0 * row["delta"]) / wall - 1.0) for big in (1e3, 1e4)]
    assert errors[0] < 3e-3 and errors[1] < 3e-4
    assert errors[1] < errors[0] / 5.0


@pytest.mark.parametrize("a1,a2", [(1.0, 1.0), (1.0, 3.0), (2.0, 0.5)])
def test_far_field_is_the_point_force_interaction(a1, a2):
    d = 20.0 * (a1 + a2)
    x = pair_theory.resistance(a1, a2, d - a1 - a2)
    # the Oseen tensor on the axis: sphere 2 pushes the liquid with 6 pi mu a2 U2, which moves at
    # F / (4 pi mu d) = (3 a2 / 2d) U2 at sphere 1, so X12 = -3 a2 / (2 d); the next term is O(d^-3)
    assert x[0, 1] == pytest.approx(-1.5 * a2 / d, rel=2e-3)
    assert x[1, 0] == pytest.approx(-1.5 * a1 / d, rel=2e-3)
    # X11 - 1 is the second reflection 9 a1 a2 / (4 d^2), the next term O(d^-4)
    assert x[0, 0] - 1.0 == pytest.approx(9.0 * a1 * a2 / (4.0 * d * d), rel=0.05)
    assert 0.0 < x[0, 0] - 1.0 < 2e-3
    # and the reflections through d^-3 to the size of the neglected d^-4 terms
    assert np.abs(x - pair_theory.far_field(a1, a2, d - a1 - a2)).max() < 5e-6


@pytest.mark.parametrize("a1,a2", [(1.0, 1.0), (1.0, 4.0), (3.0, 1.0)])
def test_near_contact_tends_to_lubrication(a1, a2):
    a_star = pair_theory.reduced_radius(a1, a2)
    remainders = []
    for gap in (1e-2, 1e-3, 1e-4):
        x = pair_theory.resistance(a1, a2, gap * a_star)
        lubrication = pair_theory.lubrication(a1, a2, gap * a_star)
        relative_force = a1 * x[0, 0] / a_star  # F_1 / (6 pi mu a* U1), sphere 2 held
        assert relative_force / lubrication == pytest.approx(1.0, abs=30 * gap)
        assert -a1 * x[0, 1] / a_star / lubrication == pytest.approx(1.0, abs=30 * gap)
        assert a2 * x[1, 1] / a_star / lubrication == pytest.approx(1.0, abs=30 * gap)
        remainders.append(relative_force - lubrication)
    # both singular terms are right: what is left tends to a constant (Jeffrey & Onishi 1984);
    # a 1 % error in the log coefficient would move it by 0.01 ln 10 / 5 per decade
    assert abs(remainders[2] - remainders[1]) < 2e-3
    assert abs(remainders[2] - remainders[1]) < abs(remainders[1] - remainders[0]) / 5


@pytest.mark.parametrize("a1,a2", [(1.0, 2.5), (1.0, 40.0), (0.3, 1.0)])
@pytest.mark.parametrize("gap", [1e-3, 0.3, 30.0])
def test_reciprocal_theorem_makes_the_resistance_symmetric(a1, a2, gap):
    x = pair_theory.resistance(a1, a2, gap * pair_theory.reduced_radius(a1, a2))
    # 6 pi mu a_i X_ij is symmetric; the two off-diagonal terms come from separate 4x4 solves
    assert a1 * x[0, 1] == pytest.approx(a2 * x[1, 0], rel=1e-10)
    swapped = pair_theory.resistance(a2, a1, gap * pair_theory.reduced_radius(a1, a2))
    assert swapped[0, 0] == pytest.approx(x[1, 1], rel=1e-12)


def test_series_hands_over_to_the_lubrication_form():
    a1, a2 = 1.0, 3.0
    switch = pair_theory.SERIES_MIN_GAP * pair_theory.reduced_radius(a1, a2)
    for h in (switch * (1 - 1e-9), 0.3 * switch, 0.1 * switch):
        asymptotic = pair_theory.resistance(a1, a2, h)
        series = pair_theory.exact_series(a1, a2, h)
        assert np.abs(asymptotic - series).max() < 1e-7 * np.abs(series).max()
    with pytest.raises(ValueError):
        pair_theory.resistance(a1, a2, 0.0)


@pytest.mark.parametrize("a1,a2", [(1.0, 1.0), (1.0, 7.0), (1e-3, 2.5e-3)])
def test_table_agrees_with_the_series(a1, a2):
    table = pair_theory.PairResistance(a1, a2)
    midpoints = np.sqrt(table.gaps[1:] * table.gaps[:-1])[::3]  # halfway between knots: the worst place
    for h in midpoints:
        tabulated, series = table(h), pair_theory.exact_series(a1, a2, h)
        for i in range(2):
            scale = abs(series[i, 0]) + abs(series[i, 1])
            assert np.abs(tabulated[i] - series[i]).max() < table.INTERPOLATION_TOLERANCE * scale
    # beyond both ends: the same asymptotic forms as resistance(), continuous at the ends
    for h in (0.3 * table.h_min, 3.0 * table.h_max):
        assert table(h) == pytest.approx(pair_theory.resistance(a1, a2, h), rel=1e-6)
    for edge in (table.h_min, table.h_max):
        assert table(edge * (1 - 1e-9)) == pytest.approx(table(edge * (1 + 1e-9)), rel=1e-7, abs=1e-8)
    # forces: F_i = -6 pi mu a_i sum_j X_ij U_j
    f1, f2 = table.forces(0.1 * a1, 0.2, -0.1, 1e-3)
    x = table(0.1 * a1)
    assert f1 == pytest.approx(-6 * math.pi * 1e-3 * a1 * (0.2 * x[0, 0] - 0.1 * x[0, 1]), rel=1e-14)
    assert f2 == pytest.approx(-6 * math.pi * 1e-3 * a2 * (0.2 * x[1, 0] - 0.1 * x[1, 1]), rel=1e-14)


# -- the pair's added mass in potential flow (added_mass_series and friends) ---------------------------------

ZETA3 = 1.2020569031595942  # Apery's constant, zeta(3)


@pytest.mark.parametrize("h", (1e-6, 1e-3, 0.1, 1.0, 10.0))
def test_equal_spheres_approaching_have_the_walls_added_mass_at_half_the_gap(h):
    # potential flow: the mid-plane of two equal spheres approaching at +-U carries no normal velocity, so
    # it is a wall at gap h/2 (tangential slip is free in potential flow): C11 - C12 is the wall's
    # C_M = (1 + 3 W) / 2 of theory.exact_w (Milne-Thomson's image sum), an independent series
    c = pair_theory.added_mass_series(1.0, 1.0, h)
    w, _ = theory.exact_w(0.5 * h / 2.0)
    assert c[0, 0] - c[0, 1] == pytest.approx(0.5 * (1.0 + 3.0 * w), rel=1e-12)
    assert c[1, 1] - c[1, 0] == pytest.approx(0.5 * (1.0 + 3.0 * w), rel=1e-12)


def test_touching_equal_spheres_have_the_zeta3_values():
    # touching: C11 = 1/2 + (3/2)((7/8) zeta(3) - 1), C12 = -(3/16) zeta(3) (the image series at h = 0)
    contact = pair_theory.added_mass_at_contact(1.0, 1.0)
    assert contact[0, 0] == pytest.approx(0.5 + 1.5 * (0.875 * ZETA3 - 1.0), rel=1e-12)
    assert contact[0, 1] == pytest.approx(-3.0 / 16.0 * ZETA3, rel=1e-12)
    assert contact[0, 0] == pytest.approx(0.57770, abs=1e-5) and contact[0, 1] == pytest.approx(-0.22539, abs=1e-5)
    # approaching: the sphere touching a wall, 1/2 + (3/2)(zeta(3) - 1) = 0.80309; together: 0.35231
    assert contact[0, 0] - contact[0, 1] == pytest.approx(0.80309, abs=1e-5)
    assert contact[0, 0] + contact[0, 1] == pytest.approx(0.35231, abs=1e-5)


@pytest.mark.parametrize("a1,a2", [(1.0, 1.0), (1.0, 3.0), (2.0, 0.7), (1.0, 1e3)])
def test_the_series_tends_to_its_contact_values(a1, a2):
    contact = pair_theory.added_mass_at_contact(a1, a2)
    a_star = pair_theory.reduced_radius(a1, a2)
    errors = [np.abs(pair_theory.added_mass_series(a1, a2, g * a_star) - contact).max() for g in (1e-4, 1e-6, 1e-8)]
    # C - C(0) ~ h ln h: each factor 100 in the gap shrinks the difference at least 50-fold
    assert errors[2] < 3e-7 and errors[2] < errors[1] / 50.0 < errors[0] / 2500.0  # measured 1.3e-7 (a2 = 1e3 a1)


@pytest.mark.parametrize("delta", (1e-3, 0.01, 0.1, 1.0))
def test_a_large_second_sphere_gives_the_walls_added_mass(delta):
    # a1 = 1 at gap h = 2 delta beside a sphere of radius 1e6: the wall's C_M = (1 + 3 W(delta)) / 2
    w, _ = theory.exact_w(delta)
    c = pair_theory.added_mass_series(1.0, 1e6, 2.0 * delta)
    assert c[0, 0] == pytest.approx(0.5 * (1.0 + 3.0 * w), rel=1e-5)  # measured 6e-7 at delta = 0.01
    assert pair_theory.added_mass_at_contact(1.0, 1e6)[0, 0] == pytest.approx(0.5 + 1.5 * (ZETA3 - 1.0), rel=1e-5)


@pytest.mark.parametrize("a1,a2", [(1.0, 1.0), (1.0, 3.0), (2.5, 1.0)])
def test_far_apart_the_spheres_are_isolated_and_the_series_matches_lambs_terms(a1, a2):
    d = 20.0 * (a1 + a2)
    c = pair_theory.added_mass_series(a1, a2, d - a1 - a2)
    # Lamb (1932) section 98: M = -2 pi rho a1^3 a2^3 / d^3, i.e. C12 = -(3/2) a2^3 / d^3 per m_l,1
    assert c[0, 1] == pytest.approx(-1.5 * a2**3 / d**3, rel=1e-6)
    assert c[0, 0] - 0.5 == pytest.approx(1.5 * (a1 * a2) ** 3 / d**6, rel=1e-2)
    far, _ = pair_theory.added_mass_far_field(a1, a2, d - a1 - a2)
    assert np.abs(far - c).max() < 1e-10
    isolated = pair_theory.added_mass_series(a1, a2, 1e4 * (a1 + a2))
    assert np.abs(isolated - 0.5 * np.eye(2)).max() < 2e-12


@pytest.mark.parametrize("a1,a2", [(1.0, 2.5), (1.0, 40.0), (0.3, 1.0)])
@pytest.mark.parametrize("gap", [1e-4, 0.3, 30.0])
def test_the_added_mass_matrix_is_symmetric(a1, a2, gap):
    # m_l,1 C12 = m_l,2 C21: two sums over different poles (sinh beta against sinh alpha)
    c = pair_theory.added_mass_series(a1, a2, gap * pair_theory.reduced_radius(a1, a2))
    assert a1**3 * c[0, 1] == pytest.approx(a2**3 * c[1, 0], rel=1e-11)


@pytest.mark.parametrize("a1,a2", [(1.0, 1.0), (1.0, 3.0), (1.0, 1e3)])
@pytest.mark.parametrize("gap", [1e-4, 1e-2, 1.0, 10.0])
def test_the_added_mass_derivative_is_the_series_slope(a1, a2, gap):
    h = gap * pair_theory.reduced_radius(a1, a2)
    _, slope = pair_theory.added_mass_series(a1, a2, h, derivative=True)
    step = 1e-4 * h
    central = (pair_theory.added_mass_series(a1, a2, h + step) - pair_theory.added_mass_series(a1, a2, h - step)) / (
        2.0 * step)
    assert np.abs(slope - central).max() < 1e-6 * np.abs(slope).max()
    assert slope[0, 0] < 0.0 < slope[0, 1]  # the coupling weakens as the gap opens


@pytest.mark.parametrize("a1,a2", [(1.0, 1.0), (1.0, 7.0), (6.35e-3, 6.35e-3)])
def test_the_added_mass_table_agrees_with_the_series(a1, a2):
    table = pair_theory.PairAddedMass(a1, a2)
    for h in np.sqrt(table.gaps[1:] * table.gaps[:-1])[::3]:  # halfway between knots
        c, slope = pair_theory.added_mass_series(a1, a2, h, derivative=True)
        c_table, slope_table = table(h)
        assert np.abs(c_table - c).max() < 2e-7  # measured 1.5e-8 (equal) to 1.3e-7 (a2 = 1000 a1)
        assert np.abs(slope_table - slope).max() * h < 2e-5  # h dC/dh, measured below 5e-6
    for edge in (table.h_max,):  # the far-field form takes over continuously
        assert np.abs(table(edge * (1 - 1e-9))[0] - table(edge * (1 + 1e-9))[0]).max() < 1e-10
    below, slope_below = table(0.1 * table.h_min)  # held below the table (1e-6 a*)
    assert np.abs(below - pair_theory.added_mass_at_contact(a1, a2)).max() < 1e-4 and not slope_below.any()
