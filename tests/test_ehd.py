"""The elastohydrodynamic film collision (fem_bounce/ehd.py, docs/ehd.md): its two limits and its
convergence, at toy size (seconds each)."""
import math

import numpy as np
import pytest
from scipy.integrate import quad
from scipy.optimize import brentq

from fem_bounce import contact, ehd, materials

# a steel sphere (D = 9.5 mm) in 85 % glycerol on Zerodur (li2011-table3-steel-85) at St 20, h0 = 20 um
STEEL_ZERODUR = materials.reduced_modulus(200e9, 0.33, 91e9, 0.24)
A, RHO, MU, H0 = 0.00475, 7600.0, 0.109, 20e-6
MASS = 4.0 / 3.0 * math.pi * A**3 * RHO


def test_groups_in_si_match_their_definitions():
    speed = 9.0 * MU * 20.0 / (RHO * 2 * A)  # St = rho_p V D / (9 mu) = 20
    assert ehd.film_stokes(MASS, A, MU, speed) == pytest.approx(20.0, rel=1e-12)
    eps = ehd.elasticity_parameter(A, STEEL_ZERODUR, MU, speed, H0)
    # epsilon at the gap x_d is one: x_d = (4 theta mu V a^1.5)^0.4 (materials.elastohydrodynamic_gap)
    x_d = materials.elastohydrodynamic_gap(A, STEEL_ZERODUR, MU, speed)
    assert ehd.elasticity_parameter(A, STEEL_ZERODUR, MU, speed, x_d) == pytest.approx(1.0, rel=1e-12)
    assert eps == pytest.approx((x_d / H0) ** 2.5, rel=1e-12)
    # Hertz's deepest overlap in DSH's groups equals contact.hertz_depth
    depth = contact.hertz_depth(A, MASS, STEEL_ZERODUR, speed)
    assert ehd.hertz_depth_scaled(20.0, eps) * H0 == pytest.approx(depth, rel=1e-10)


def test_kernel_gives_hertz_deflection_under_hertz_pressure():
    """The static load problem: Hertz's pressure p0 sqrt(1 - r^2/c^2) on two half-spaces displaces the
    surfaces by w(r) = pi p0 (2 c^2 - r^2) / (4 c E*) inside the contact (Johnson 1985, eq. 3.41), i.e.
    M P = pi^2 (2 c^2 - R^2) / (16 c) in the kernel's units (w = 4 theta int ...)."""
    grid = ehd.radial_grid(2.0, 8.0, 200, 40)
    kernel = ehd.elastic_kernel(grid)
    c = 1.0
    r = grid.nodes
    pressure = np.sqrt(np.clip(1.0 - r[:-1] ** 2 / c**2, 0.0, None))
    exact = math.pi**2 * (2 * c**2 - r**2) / (16 * c)
    inside = r <= c
    assert np.max(np.abs(kernel[inside] @ pressure / exact[inside] - 1.0)) < 5e-3
    # outside (Johnson 1985, eq. 3.42b): w = p0 [(2 c^2 - r^2) asin(c / r) + r c sqrt(1 - c^2 / r^2)] / (2 c E*)
    out = r > 1.05 * c
    outside = math.pi / (8 * c) * ((2 * c**2 - r[out] ** 2) * np.arcsin(c / r[out])
                                   + r[out] * c * np.sqrt(1.0 - c**2 / r[out] ** 2))
    assert np.max(np.abs(kernel[out] @ pressure / outside - 1.0)) < 5e-3
    # and far away the load's point-force field (1 - nu^2) F / (pi E r) of each body: M P -> F / (4 R)
    load = 2.0 / 3.0 * math.pi * c**2
    assert kernel[-1] @ pressure == pytest.approx(load / (4.0 * r[-1]), rel=0.01)


def _truncated_reynolds_force(separation, outer=8.0):
    """The undeformed film's force approaching at V0 with p = 0 at R_out (units mu V0 a^2 / h0):
    6 pi (1/X - 1/H_R) - 3 pi R_out^2 / H_R^2, H_R = X + R_out^2 / 2; 6 pi / X for R_out -> infinity."""
    h_out = separation + 0.5 * outer**2
    return 6.0 * math.pi * (1.0 / separation - 1.0 / h_out) - 3.0 * math.pi * outer**2 / h_out**2


def test_rigid_limit_gives_reynolds_force_at_constant_approach():
    settings = ehd.FilmSettings(inner_cells=240, outer_cells=120, tolerance=1e-5)
    film = ehd.FilmCollision(0.0, 1.0, settings, prescribed_speed=True)
    result = film.run(end_separation=0.002)
    assert result.outcome == "reached"
    for target in (0.5, 0.1, 0.01, 0.002):
        i = int(np.argmin(np.abs(result.separation - target)))
        x = result.separation[i]
        assert result.force[i] == pytest.approx(_truncated_reynolds_force(x), rel=0.01)
    # at the smallest gap the outer boundary no longer matters: Reynolds' 6 pi mu a^2 V / h itself
    assert result.force[-1] == pytest.approx(6.0 * math.pi / result.separation[-1], rel=0.01)


@pytest.mark.parametrize("stokes", [2.0, 4.0])
def test_rigid_free_sphere_stops_where_the_film_has_taken_its_momentum(stokes):
    """E* -> infinity: m dV = -F dt with F = 6 pi mu a^2 U g(X) gives St = int_X_stop^1 g dX: the sphere
    stops at X_stop and never rebounds."""
    settings = ehd.FilmSettings(inner_cells=80, outer_cells=160, tolerance=1e-5)  # the film's R ~ 1 resolved
    result = ehd.FilmCollision(0.0, stokes, settings).run()
    assert result.outcome == "stopped" and result.restitution == 0.0
    assert np.all(result.velocity < 1e-4)  # the integrator's overshoot near rest, no rebound

    def taken(x_stop):
        return quad(lambda x: _truncated_reynolds_force(x) / (6.0 * math.pi), x_stop, 1.0)[0] - stokes
    x_stop = brentq(taken, 1e-6, 0.99)
    assert x_stop == pytest.approx(math.exp(-stokes), rel=0.1)  # ln(1 / X_stop) = St, untruncated
    assert result.separation[-1] == pytest.approx(x_stop, rel=0.02)


@pytest.mark.parametrize("stokes", [300.0, 1000.0])
def test_near_inviscid_film_gives_hertz_contact_time(stokes):
    """St -> infinity at a fixed Hertz overlap (x_m = 0.3 h0): the film is a thin lubricant and the
    undeformed surfaces overlap for Hertz's 2.94 x_m / V (Johnson 1985, eq. 11.24); e tends to 1 (no
    solid dissipation in the model)."""
    eps = 0.3**2.5 / (ehd.HERTZ_DEPTH_FACTOR * stokes)
    result = ehd.FilmCollision(eps, stokes, ehd.FilmSettings(inner_cells=80, outer_cells=40)).run()
    assert result.outcome == "rebound"
    assert result.contact_time == pytest.approx(ehd.hertz_contact_time_scaled(stokes, eps), rel=0.02)
    assert 1.0 - 40.0 / stokes < result.restitution < 1.0


def test_elastic_film_rebounds_at_st_20():
    """Steel on Zerodur in 85 % glycerol at St 20, h0 = 20 um: the rigid film would stop the sphere at
    X = exp(-20) h0 (previous test); the deformed film returns it (docs/ehd.md: e = 0.33)."""
    eps = 1.022e-4
    elastic = ehd.FilmCollision(eps, 20.0, ehd.FilmSettings(inner_cells=60, outer_cells=30)).run()
    assert elastic.outcome == "rebound" and 0.25 < elastic.restitution < 0.45
    assert 0.0 < elastic.min_gap < eps**0.4  # the film thins below x_d at its rim


def test_grid_and_step_convergence_of_the_restitution():
    """Two finest grids, and two finest tolerances, within 1 % in e (St 20, the case of the test above)."""
    eps, stokes = 1.022e-4, 20.0
    grids = [ehd.FilmCollision(eps, stokes, ehd.FilmSettings(inner_cells=n, outer_cells=n // 2)).run().restitution
             for n in (40, 80, 160)]
    assert abs(grids[2] - grids[1]) < 0.01 * grids[2]
    assert abs(grids[2] - grids[1]) < abs(grids[1] - grids[0])  # and converging
    steps = [ehd.FilmCollision(eps, stokes, ehd.FilmSettings(inner_cells=60, outer_cells=30, tolerance=tol))
             .run().restitution for tol in (1e-3, 2.5e-4, 6.25e-5)]
    assert abs(steps[2] - steps[1]) < 0.01 * steps[2]


def test_cavitation_limit_holds_the_pressure_and_lets_the_sphere_go():
    eps, stokes = 1.022e-4, 20.0
    settings = ehd.FilmSettings(inner_cells=50, outer_cells=25)
    free = ehd.FilmCollision(eps, stokes, settings).run()
    held = ehd.FilmCollision(eps, stokes, settings, cavitation_pressure=-1.0).run()
    assert free.min_pressure < -100.0  # the film's tension on rebound, without a limit
    assert held.min_pressure >= -1.0 - 1e-9
    assert held.restitution > free.restitution + 0.1


def test_collide_in_si_units():
    speed = 9.0 * MU * 20.0 / (RHO * 2 * A)
    result = ehd.collide(A, MASS, STEEL_ZERODUR, MU, speed, H0, ehd.FilmSettings(inner_cells=60, outer_cells=30))
    assert result.stokes == pytest.approx(20.0, rel=1e-12)
    assert 0.2 < result.restitution < 0.5


def test_snapshots_keep_the_film_at_the_asked_times_and_change_no_number():
    """collide(..., snapshot_times=...) (benchmarks/ehd_collision.py): the film at the first step at or after
    each time, consistent with the time series; the collision itself unchanged."""
    speed = 9.0 * MU * 20.0 / (RHO * 2 * A)
    settings = ehd.FilmSettings(inner_cells=40, outer_cells=20)
    plain = ehd.collide(A, MASS, STEEL_ZERODUR, MU, speed, H0, settings)
    wanted = [0.5, float(plain.time[np.argmax(plain.force)]), 0.9 * plain.end_time]
    kept = ehd.collide(A, MASS, STEEL_ZERODUR, MU, speed, H0, settings, snapshot_times=wanted)
    assert kept.steps == plain.steps and np.array_equal(kept.separation, plain.separation)
    assert kept.restitution == pytest.approx(plain.restitution, rel=1e-12)
    assert len(kept.snapshots) == len(wanted)
    for asked, (t, pressure, gap) in zip(wanted, kept.snapshots):
        step = int(np.flatnonzero(kept.time == t)[0])
        assert t >= asked and (step == 0 or kept.time[step - 1] < asked)
        assert gap[0] == pytest.approx(kept.central_gap[step], rel=1e-12)
        assert gap.min() == pytest.approx(kept.smallest_gap[step], rel=1e-12)
        assert pressure.size == gap.size - 1  # the outer node holds p = 0
    # at the largest load the film carries it: F = 2 pi int p r dr, and the surfaces are pressed in (w > 0)
    t, pressure, gap = kept.snapshots[1]
    step = int(np.flatnonzero(kept.time == t)[0])
    grid = ehd.RadialGrid(kept.radius)
    assert 2.0 * math.pi * grid.areas @ pressure == pytest.approx(kept.force[step], rel=1e-12)
    deformation = gap - kept.separation[step] - 0.5 * kept.radius**2
    assert deformation[0] > 0.5 * abs(kept.separation[step])


@pytest.mark.parametrize("field, value", [("speed", -1.0), ("handover_gap", 1e-3), ("viscosity", 0.0),
                                          ("e_star", float("nan"))])
def test_bad_input_gives_one_line_error_naming_the_field(field, value):
    args = dict(radius=A, mass=MASS, e_star=STEEL_ZERODUR, viscosity=MU, speed=0.3, handover_gap=H0)
    args[field] = value
    with pytest.raises(ehd.FilmError, match=field) as info:
        ehd.collide(**args)
    assert "\n" not in str(info.value) and "allowed" in str(info.value)
