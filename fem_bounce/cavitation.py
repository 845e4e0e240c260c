"""The rigid Reynolds film between a sphere and a plane when the liquid cannot pull harder than it holds.

A sphere of radius a at the gap h from a plane, moving away from it at V > 0, draws liquid into the gap.
In Reynolds' lubrication theory (the gap h(r) = h + r^2 / (2a), a flux through every circle r that fills
the growing gap; e.g. Hamrock, Fundamentals of Fluid Film Lubrication, ch. 7) the film's gauge pressure is

    p(r) = -3 mu a V / h(r)^2,        F = 2 pi int p r dr = -6 pi mu a^2 V / h        (toward the plane),

the singular part of Brenner's (1961) drag.  No liquid holds an arbitrary tension: where the absolute
pressure would fall below the liquid's cavitation pressure the liquid vaporises or releases its gas, and
the pressure there stays at the floor, gauge p >= -dp (dp = p_ambient + rho g H - p_vapour, the package's
minus Scene.cavitation_pressure).  The suction first reaches the floor on the axis, when h falls to

    h_on = sqrt(3 mu a V / dp).

Below it a cavity of constant pressure -dp fills the middle of the gap out to the film's edge r_c, where
the film takes over with the Swift-Stieber (Reynolds) conditions p = -dp and dp/dr = 0 (no flux crosses the
edge; Dowson & Taylor 1979, Annu. Rev. Fluid Mech. 11, 35-66; the same complementarity the resolved film of
fem_bounce.ehd solves).  Outside the edge Reynolds' equation integrates with zero flux at r_c,

    r h^3 dp/dr = 6 mu V (r^2 - r_c^2),

and with x = h(r), b = h, c = h(r_c) and q = b / c this gives, in closed form (derived here; the integrals
are rational functions of x with one logarithm),

    p(x)   = -6 mu V a [1/(2 x^2) - (c - b) sum_{k>=3} b^(k-3) / (k x^k)]          for x >= c,
    p(c)   = -dp    <=>    q^2 g(q) = (h / h_on)^2 / 2,   g(q) = 1/6 + sum_{m>=1} q^m / ((m + 2)(m + 3)),
    F      = -2 pi a dp h_on G(s),    s = h / h_on,
    G      = sqrt(2 g) [1 - q + j(q) / g(q)],              j(q) = sum_{m>=0} 2 q^m / ((m + 1)(m + 2)(m + 3)).

G(1) = 1 joins the uncavitated film F = -2 pi a dp h_on / s at the onset, and as h -> 0 the force tends to
-6 pi a^(3/2) sqrt(mu V dp) (G(0) = sqrt 3): finite where the uncavitated film's grows without bound, and
13 % below the force of a pressure merely truncated at the floor, -2 pi a dp (2 h_on - h) (which breaks
the film's volume balance at the cavity's edge).

The package adds the difference to its lubrication force: `tension_relief` = F_cavitated - F_Reynolds >= 0,
zero while the film holds (approach, or h >= h_on), so Brenner's exact drag is unchanged wherever the
floor is not reached.  For two spheres, a is the reduced radius a* and V the rate the gap opens.
"""
from __future__ import annotations

import math

import numpy as np

_SERIES_TERMS = 60  # the series in q converge as 0.5^m below q = 0.5; above it the closed forms are used


def _g_j(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """g(q), j(q) and their derivatives for 0 <= q < 1 (module docstring)."""
    q = np.asarray(q, dtype=float)
    g, j = np.empty_like(q), np.empty_like(q)
    dg, dj = np.empty_like(q), np.empty_like(q)
    small = q <= 0.5
    m = np.arange(_SERIES_TERMS, dtype=float)[:, None]
    qs = q[small][None, :]
    g_terms = 1.0 / ((m + 2.0) * (m + 3.0))
    j_terms = 2.0 / ((m + 1.0) * (m + 2.0) * (m + 3.0))
    g[small] = 1.0 / 6.0 + np.sum((g_terms * qs**m)[1:], axis=0)
    dg[small] = np.sum((m * g_terms * qs ** (m - 1))[1:], axis=0)
    j[small] = np.sum(j_terms * qs**m, axis=0)
    dj[small] = np.sum((m * j_terms * qs ** (m - 1))[1:], axis=0)
    big = ~small
    qb = q[big]
    log = -np.log1p(-qb)  # -ln(1 - q)
    series = (log - qb - 0.5 * qb**2) / qb**3  # sum_{k>=3} q^(k-3) / k
    d_series = (1.0 / (1.0 - qb) - 1.0 - qb) / qb**3 - 3.0 * series / qb
    g[big] = 0.5 - (1.0 - qb) * series
    dg[big] = series - (1.0 - qb) * d_series
    j[big] = (1.0 - qb) ** 2 * log / qb**3 + (2.0 * qb - 1.0) / qb**2 - 0.5 / qb
    dj[big] = (-2.0 * (1.0 - qb) * log / qb**3 + (1.0 - qb) / qb**3 - 3.0 * (1.0 - qb) ** 2 * log / qb**4
               + (2.0 - 2.0 * (2.0 * qb - 1.0) / qb) / qb**2 + 0.5 / qb**2)
    return g, j, dg, dj


def _branch(q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(s, G, dG/ds, ds/dq) of the cavitated film at the parameter q = b / c."""
    g, j, dg, dj = _g_j(q)
    root = np.sqrt(2.0 * g)
    s = q * root
    big_g = root * (1.0 - q + j / g)
    ds_dq = root + q * dg / root
    dG_dq = dg / root * (1.0 - q + j / g) + root * (-1.0 + dj / g - j * dg / g**2)
    return s, big_g, dG_dq / ds_dq, ds_dq


def _table(nodes: int = 4001) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """G and dG/ds on a grid of s in [0, 1]: the branch is parametrised by q, so q(s) is found by Newton
    on s(q) = s from q = s sqrt(3) (the small-gap limit s -> q / sqrt 3)."""
    s_nodes = np.linspace(0.0, 1.0, nodes)
    q = np.clip(s_nodes * math.sqrt(3.0), 1e-12, 1.0 - 1e-15)
    for _ in range(60):
        s, _, _, ds_dq = _branch(q)
        step = (s - s_nodes) / ds_dq
        q = np.clip(q - step, 1e-300, 1.0 - 1e-16)
        if np.max(np.abs(step)) < 1e-15:
            break
    _, big_g, slope, _ = _branch(q)
    big_g[0], slope[0] = math.sqrt(3.0), _branch(np.array([1e-9]))[2][0]
    # the onset: the cavity has shrunk to the axis, and the slope tends (logarithmically slowly) to the
    # uncavitated film's -1/s^2 = -1
    big_g[-1], slope[-1] = 1.0, -1.0
    return s_nodes, big_g, slope


# the cavitated branch's table: s = h / h_on from 0 to 1, G(s) and dG/ds at each node (cubic Hermite between)
_S, _G, _DG = _table()
_DS = _S[1] - _S[0]


def cavitated_shape(s: float) -> tuple[float, float]:
    """(G(s), dG/ds) of the cavitated film, 0 <= s <= 1 (cubic Hermite on the table)."""
    k = min(int(s / _DS), len(_S) - 2)
    t = (s - _S[k]) / _DS
    g0, g1, d0, d1 = _G[k], _G[k + 1], _DG[k] * _DS, _DG[k + 1] * _DS
    t2, t3 = t * t, t * t * t
    value = (2 * t3 - 3 * t2 + 1) * g0 + (t3 - 2 * t2 + t) * d0 + (-2 * t3 + 3 * t2) * g1 + (t3 - t2) * d1
    slope = ((6 * t2 - 6 * t) * g0 + (3 * t2 - 4 * t + 1) * d0 + (-6 * t2 + 6 * t) * g1 + (3 * t2 - 2 * t) * d1)
    return value, slope / _DS


def onset_gap(radius: float, viscosity: float, speed: float, tension: float) -> float:
    """h_on = sqrt(3 mu a V / dp) [m]: the gap below which a film opening at `speed` [m/s] > 0 cavitates
    (`tension` dp [Pa] > 0 the most the liquid holds below the ambient pressure)."""
    return math.sqrt(3.0 * viscosity * radius * speed / tension)


def _cavitated(gap: float, velocity: float, radius: float, viscosity: float,
               tension: float) -> tuple[float, float, float, float]:
    """(dp h_on [N/m], s, G(s), dG/ds) for a film opening at `velocity` > 0 with a `tension` dp > 0 (the
    uncavitated film's 1/s, -1/s^2 from the onset s = 1 up).  dp h_on is sqrt(3 mu a V dp), not dp times h_on,
    so that a tension many decades below the film's scale (down to the smallest float) gives the limit of a
    film that holds none: h_on grows to infinity, s and dp h_on fall to 0, with no inf * 0 on the way."""
    suction = math.sqrt(3.0 * viscosity * radius * velocity * tension)
    s = gap / onset_gap(radius, viscosity, velocity, tension) if suction > 0.0 else 0.0
    if s >= 1.0:
        return suction, s, 1.0 / s, -1.0 / (s * s)
    return suction, s, *cavitated_shape(s)


def film_force(gap: float, velocity: float, radius: float, viscosity: float, tension: float) -> float:
    """The Reynolds film's force on the sphere [N] (positive away from the plane), `velocity` [m/s] positive
    away from it: -6 pi mu a^2 V / h where the film holds, the cavitated film's below the onset gap."""
    if velocity <= 0.0 or tension == math.inf:
        return -6.0 * math.pi * viscosity * radius**2 * velocity / gap
    if tension <= 0.0:  # a liquid that holds no tension: the gap fills with vapour or gas at once
        return 0.0
    suction, _, shape, _ = _cavitated(gap, velocity, radius, viscosity, tension)
    return -2.0 * math.pi * radius * suction * shape


def tension_relief(gap: float, velocity: float, radius: float, viscosity: float,
                   tension: float) -> tuple[float, float, float]:
    """(dF, d(dF)/dh, d(dF)/dV): what the tension limit takes off the Reynolds film's suction [N, N/m,
    N s/m], dF = F_cavitated - (-6 pi mu a^2 V / h) >= 0; (0, 0, 0) while the film holds.  The two films'
    forces side by side, with F_cavitated = -2 pi a dp h_on G(h / h_on) (no 1/s, which overflows for a tiny
    tension: _cavitated)."""
    if velocity <= 0.0 or tension == math.inf or gap <= 0.0:
        return 0.0, 0.0, 0.0
    reynolds = 6.0 * math.pi * viscosity * radius**2  # the uncavitated film's suction is reynolds V / h
    suction, s, shape, slope = (0.0, 0.0, 0.0, 0.0) if tension <= 0.0 else _cavitated(
        gap, velocity, radius, viscosity, tension)  # no tension: the relief is the whole Reynolds film
    if s >= 1.0:
        return 0.0, 0.0, 0.0
    scale = -2.0 * math.pi * radius
    return (scale * suction * shape + reynolds * velocity / gap,
            scale * tension * slope - reynolds * velocity / gap**2,
            scale * (suction * shape - tension * gap * slope) / (2.0 * velocity) + reynolds / gap)


def truncated_film_force(gap: float, velocity: float, radius: float, viscosity: float, tension: float) -> float:
    """The film's force with its pressure merely cut off at -dp (Reynolds' solution, then max(p, -dp)) [N]:
    -2 pi a dp (2 h_on - h) below the onset gap.  Not what the package uses (it breaks the film's volume
    balance at the cavity's edge); kept for the comparison in docs/physics.md and the tests."""
    if velocity <= 0.0:
        return film_force(gap, velocity, radius, viscosity, tension)
    h_on = onset_gap(radius, viscosity, velocity, tension)
    if gap >= h_on:
        return -6.0 * math.pi * viscosity * radius**2 * velocity / gap
    return -2.0 * math.pi * radius * tension * (2.0 * h_on - gap)
