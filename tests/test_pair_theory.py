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
