"""The rigid Reynolds film with the liquid's tension limited (fem_bounce.cavitation) against its own
derivation integrated numerically, against the resolved film model (fem_bounce.ehd) with rigid surfaces,
and its properties: the uncavitated film where the floor is not reached, the onset, the small-gap limit."""
import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from fem_bounce import cavitation, ehd

A, MU, V, DP = 4.75e-3, 0.05, 0.1, 1e5  # case 3's sphere leaving the wall at 0.1 m/s, one atmosphere
H_ON = cavitation.onset_gap(A, MU, V, DP)


def swift_stieber_force(gap: float) -> float:
    """The same film solved from its equations by quadrature: p(x) = -int_x^inf 6 mu V a (xi - c) / ((xi - h)
    xi^3) dxi outside the cavity edge c, which p(c) = -dp fixes; F = 2 pi a int p dx over the film and the
    cavity (x = h(r), r dr = a dx)."""
    def integral(f, x):  # int_x^inf f over pieces that quad resolves (f varies on the scale x near x)
        pieces = (x, 2 * x, 100 * x, np.inf)
        return sum(quad(f, lo, hi, epsabs=0.0, epsrel=1e-9, limit=200)[0] for lo, hi in zip(pieces, pieces[1:]))

    def pressure(x, edge):
        return -integral(lambda xi: 6 * MU * V * A * (xi - edge) / ((xi - gap) * xi**3), x)

    edge = brentq(lambda c: pressure(c, c) + DP, gap * (1 + 1e-9), H_ON * 10)
    film = integral(lambda x: pressure(x, edge), edge)
    return 2 * math.pi * A * (-DP * (edge - gap) + film)


@pytest.mark.filterwarnings("ignore::scipy.integrate.IntegrationWarning")  # round-off near 1e-9 in the reference
@pytest.mark.parametrize("s", [0.9, 0.5, 0.2])
def test_closed_form_is_the_swift_stieber_film_integrated(s):
    assert cavitation.film_force(s * H_ON, V, A, MU, DP) == pytest.approx(swift_stieber_force(s * H_ON), rel=1e-5)


@pytest.mark.parametrize("tension", [1e3, 1e5])
def test_closed_form_matches_the_resolved_film_with_rigid_surfaces(tension):
    """fem_bounce.ehd's film (finite volumes, the cavitation condition as a complementarity, p = 0 at its outer
    radius) in DSH's units (a = mu = V = 1, gaps in h0): within 1 % (the finite outer radius costs 0.5 % of
    the uncavitated force at X = 0.01), while a pressure merely truncated at the floor is 10-16 % above."""
    film = ehd.FilmCollision(0.0, 1.0, ehd.FilmSettings(inner_cells=240, outer_cells=120),
                             cavitation_pressure=-tension)
    h_on = cavitation.onset_gap(1.0, 1.0, 1.0, tension)
    for s in (0.5, 0.1):
        pressure = film.rigid_film(s * h_on, 1.0)
        assert pressure.min() == pytest.approx(-tension, rel=1e-9)  # the floor is reached and held
        resolved = film.force(pressure)
        assert resolved == pytest.approx(cavitation.film_force(s * h_on, 1.0, 1.0, 1.0, tension), rel=0.01)
        assert cavitation.truncated_film_force(s * h_on, 1.0, 1.0, 1.0, tension) < 1.09 * resolved


def test_the_film_holds_where_the_floor_is_not_reached():
    reynolds = -6 * math.pi * MU * A**2 * V
    assert cavitation.film_force(2 * H_ON, V, A, MU, DP) == pytest.approx(reynolds / (2 * H_ON), rel=1e-12)
    assert cavitation.film_force(0.01 * H_ON, -V, A, MU, DP) == pytest.approx(-reynolds / (0.01 * H_ON), rel=1e-12)
    assert cavitation.tension_relief(0.01 * H_ON, -V, A, MU, DP) == (0.0, 0.0, 0.0)  # approaching: no tension
    assert cavitation.tension_relief(1.5 * H_ON, V, A, MU, DP) == (0.0, 0.0, 0.0)


def test_onset_continuity_and_small_gap_limit():
    below, above = (cavitation.film_force(f * H_ON, V, A, MU, DP) for f in (1 - 1e-9, 1 + 1e-9))
    assert below == pytest.approx(above, rel=1e-6)
    limit = -6 * math.pi * A**1.5 * math.sqrt(MU * V * DP)  # the cavity covers the film's middle as h -> 0
    assert cavitation.film_force(1e-9 * H_ON, V, A, MU, DP) == pytest.approx(limit, rel=1e-6)
    relief = [cavitation.tension_relief(f * H_ON, V, A, MU, DP)[0] for f in (0.9, 0.5, 0.1, 0.01)]
    assert all(r > 0 for r in relief) and relief == sorted(relief)  # more relief the thinner the film


@pytest.mark.parametrize("s", [0.999, 0.7, 0.05, 1e-4])
def test_relief_derivatives_match_differences(s):
    relief, d_gap, d_velocity = cavitation.tension_relief(s * H_ON, V, A, MU, DP)
    step = 1e-6
    by_gap = [cavitation.tension_relief(s * H_ON * (1 + k * step), V, A, MU, DP)[0] for k in (-1, 1)]
    by_speed = [cavitation.tension_relief(s * H_ON, V * (1 + k * step), A, MU, DP)[0] for k in (-1, 1)]
    assert d_gap == pytest.approx((by_gap[1] - by_gap[0]) / (2 * step * s * H_ON), rel=1e-4)
    assert d_velocity == pytest.approx((by_speed[1] - by_speed[0]) / (2 * step * V), rel=1e-4)


def test_a_liquid_that_holds_no_tension_pulls_nothing():
    assert cavitation.film_force(1e-6, V, A, MU, 0.0) == 0.0
    relief = cavitation.tension_relief(1e-6, V, A, MU, 0.0)[0]
    assert relief == pytest.approx(6 * math.pi * MU * A**2 * V / 1e-6, rel=1e-12)
