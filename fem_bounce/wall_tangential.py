"""Stokes resistance of a sphere sliding along a plane wall and spinning about a wall-parallel axis, with the coupling.

Geometry and signs: the wall is the plane z = 0; the sphere of radius a has its centre at the height l = a + delta
(delta the gap, eps = delta / a, z = a / l).  It translates at U along x and spins at Omega about y, positive in the
rolling sense: the point of the sphere nearest the wall moves at U - a Omega (zero when it rolls).  The liquid's force
F (along x) and torque T (about y) are

    [F, T / a] = -6 pi mu a K(eps) [U, a Omega],    K = [[f_xx, -(4/3) c_yx], [-(4/3) c_yx, (4/3) c_yy]],

with f_xx, c_yx, c_yy the resistance functions in the units of Chaoui & Feuillebois (2003): the drag in 6 pi mu a U,
the torque from translation in 8 pi mu a^2 U, the torque resisting rotation in 8 pi mu a^3 Omega (far from the wall
f_xx = c_yy = 1, c_yx = 0).  K is symmetric at every gap (reciprocity: the force from rotation,
6 pi mu a^2 (4/3) c_yx Omega, equals the torque from translation, 8 pi mu a^2 c_yx U) and positive definite (the
liquid only dissipates).  c_yx > 0: a sphere sliding forward is turned toward rolling, and a sphere spinning in the
rolling sense is pushed forward.  In SI units (`wall_tangential_resistance`)

    [F, T] = -R [U, Omega],   R = 6 pi mu a S K S,   S = diag(1, a).

Three pieces, each symmetric, joined by a C^2 blend (`smooth_step`) of the matrices:
- eps <= 0.15 (`lubrication_matrix`): Chaoui & Feuillebois (2003) eq. 5.4-5.6 with their tables 11 and 13, six-term
  series sum_k (alpha_k ln eps + beta_k) eps^k fitted to their exact solution for 1e-6 <= eps <= ~0.2 (their
  statement).  Its first terms are the lubrication asymptotes of Goldman, Cox & Brenner (1967) and O'Neill &
  Stewartson (1967): -(8/15) ln eps - (64/375) eps ln eps, -(1/10) ln eps - (43/250) eps ln eps and
  -(2/5) ln eps - (66/125) eps ln eps, with the constants 0.9543, -0.1930, 0.3709 refining theirs (0.9588, -0.1895,
  0.3817).
- 0.3 <= eps <= 10 (`pade_matrix`): Chaoui & Feuillebois (2003) eq. 5.1, Pade approximants in z with their tables 9,
  10 and 12 (data/chaoui2003_pade_wall_resistance.csv).  Between eps 0.15 and 0.3 both agree with the exact series to
  1e-6 relative, and with each other to 1e-7 in value and slope.
- eps >= 20 (`reflection_matrix`): the method of reflections' mobilities, inverted as one matrix (not entry by
  entry): translation 1 - (9/16) z + (1/8) z^3 - (45/256) z^4 - (1/16) z^5 (Faucheux & Libchaber 1994, Phys. Rev. E
  49, 5158), rotation (3/4) [1 - (5/16) z^3 - (15/256) z^6] (Swan & Brady 2007, Phys. Fluids 19, 113306, for the z^3
  term; the z^6 term's size as the reference note gives it, its sign from the exact series, which gives -0.05859
  for eps 20-50: benchmarks/wall_tangential_exact.py), coupling (3/32) z^4 (Swan & Brady 2007; the leading term of
  Chaoui & Feuillebois' table 10).  Past eps 10 it agrees with the Pade values to 1e-5 in f_xx and c_yy; its one-term
  coupling is 10 % high at eps 10 and 5 % at eps 20, on a c_yx below 1e-5.

Below eps = EPS_MIN (trial states of an implicit step may reach the wall; contact is the contact law's) K is held and
its derivative is zero.  Every function returns the matrix and its derivative in the gap: the integrator's Jacobians
are exact.
"""
from __future__ import annotations

import functools
import math

import numpy as np

from . import reference

EPS_MIN = 1e-6  # the smallest gap of Chaoui & Feuillebois' fit
LUBRICATION_END, PADE_START = 0.15, 0.3  # eps: the blend from the lubrication series to the Pade approximants
PADE_END, REFLECTION_START = 10.0, 20.0  # eps: the blend from the Pade approximants to the reflections

# Chaoui & Feuillebois (2003) tables 11 (f_xx, c_yx) and 13 (c_yy): value = sum_k (alpha_k ln eps + beta_k) eps^k,
# k = 0..5 (transcribed from the public code ilent2/ott, +ott/+drag/ChaouiSphere.m; its first alphas are the exact
# 8/15, 64/375, 1/10, 43/250, 2/5 and 66/125 = 0.528 of the lubrication theory).
_LUBRICATION = {
    "f_xx": ((-8 / 15, -64 / 375, 0.011595712294862, -0.002559314461340, 0.002165777707452, 0.000351260314552),
             (0.954293724783876, 0.429450132564500, -0.001897844702304, 0.002058408405495, 0.000096108639584,
              -0.001248147281379)),
    "c_yx": ((-1 / 10, -43 / 250, -0.036913066460225, 0.001486892317125, 0.000012689734456, 0.000103798994187),
             (-0.192952745666190, 0.100579155700110, 0.094493729126963, 0.003821112414990, -0.000819028830091,
              -0.000097511506358)),
    "c_yy": ((-2 / 5, -0.528001276176667, -0.212879560114862, -0.035965644690736, -0.006385459746252,
              0.000167620439255),
             (0.370892565890165, 0.340079923061464, 0.225531274283815, 0.097897336215370, 0.005878696055717,
              0.001503759398496)),
}


def coefficient_matrix(f_xx: float, c_yx: float, c_yy: float) -> np.ndarray:
    """K of the module docstring from the three resistance functions (Chaoui & Feuillebois' units)."""
    coupling = -4.0 / 3.0 * c_yx
    return np.array([[f_xx, coupling], [coupling, 4.0 / 3.0 * c_yy]])


def coefficients(matrix: np.ndarray) -> tuple[float, float, float]:
    """(f_xx, c_yx, c_yy) of a matrix K (the inverse of `coefficient_matrix`)."""
    return float(matrix[0, 0]), float(-0.75 * matrix[0, 1]), float(0.75 * matrix[1, 1])


def _log_series(alphas, betas, eps: float) -> tuple[float, float]:
    """sum_k (alpha_k ln eps + beta_k) eps^k and its derivative in eps."""
    log_eps = math.log(eps)
    value = slope = 0.0
    for k, (alpha, beta) in enumerate(zip(alphas, betas)):
        term = alpha * log_eps + beta
        value += term * eps**k
        slope += alpha * eps ** (k - 1) + (k * term * eps ** (k - 1) if k else 0.0)
    return value, slope


def lubrication_matrix(eps: float) -> tuple[np.ndarray, np.ndarray]:
    """(K, dK/d eps) near contact: Chaoui & Feuillebois (2003) tables 11 and 13 (module docstring); held below
    EPS_MIN."""
    held = eps <= EPS_MIN
    eps = max(eps, EPS_MIN)
    (f_xx, df), (c_yx, dc), (c_yy, dr) = (_log_series(*_LUBRICATION[name], eps) for name in ("f_xx", "c_yx", "c_yy"))
    slope = np.zeros((2, 2)) if held else coefficient_matrix(df, dc, dr)
    return coefficient_matrix(f_xx, c_yx, c_yy), slope


@functools.cache
def _pade_tables() -> tuple[tuple[float, ...], ...]:
    """The six coefficient columns of data/chaoui2003_pade_wall_resistance.csv, highest power first, as plain floats
    for a scalar Horner evaluation (numpy's overhead would dominate 39 terms)."""
    rows = reference.table("chaoui2003_pade_wall_resistance")
    names = ("fxx_num", "fxx_den", "cyx_num", "cyx_den", "cyy_num", "cyy_den")
    return tuple(tuple(float(row[name]) for row in reversed(rows)) for name in names)


def _horner(coefficients: tuple[float, ...], z: float) -> tuple[float, float]:
    """(p(z), p'(z)) of the polynomial with these coefficients, highest power first."""
    value = slope = 0.0
    for coefficient in coefficients:
        slope = slope * z + value
        value = value * z + coefficient
    return value, slope


def _rational(numerator: tuple[float, ...], denominator: tuple[float, ...], z: float) -> tuple[float, float]:
    (p, dp), (q, dq) = _horner(numerator, z), _horner(denominator, z)
    return p / q, (dp * q - p * dq) / q**2


def pade_matrix(eps: float) -> tuple[np.ndarray, np.ndarray]:
    """(K, dK/d eps) from Chaoui & Feuillebois (2003) eq. 5.1, tables 9, 10 and 12 (module docstring); eps > 0."""
    z = 1.0 / (1.0 + eps)
    tables = _pade_tables()
    values = [_rational(tables[2 * i], tables[2 * i + 1], z) for i in range(3)]
    dz = -z * z  # dz/d eps
    return (coefficient_matrix(*(value for value, _ in values)),
            coefficient_matrix(*(slope * dz for _, slope in values)))


def reflection_mobility(eps: float) -> tuple[np.ndarray, np.ndarray]:
    """(M, dM/d eps): the far-field mobility, [U, a Omega] = M [F, T / a] / (6 pi mu a), of the method of reflections
    (module docstring: Faucheux & Libchaber 1994; Swan & Brady 2007)."""
    z = 1.0 / (1.0 + eps)
    translation = 1.0 - 9.0 / 16.0 * z + z**3 / 8.0 - 45.0 / 256.0 * z**4 - z**5 / 16.0
    d_translation = -9.0 / 16.0 + 3.0 / 8.0 * z**2 - 45.0 / 64.0 * z**3 - 5.0 / 16.0 * z**4
    rotation = 0.75 * (1.0 - 5.0 / 16.0 * z**3 - 15.0 / 256.0 * z**6)
    d_rotation = 0.75 * (-15.0 / 16.0 * z**2 - 90.0 / 256.0 * z**5)
    coupling, d_coupling = 3.0 / 32.0 * z**4, 3.0 / 8.0 * z**3
    dz = -z * z
    mobility = np.array([[translation, coupling], [coupling, rotation]])
    slope = np.array([[d_translation, d_coupling], [d_coupling, d_rotation]]) * dz
    return mobility, slope


def reflection_matrix(eps: float) -> tuple[np.ndarray, np.ndarray]:
    """(K, dK/d eps) far from the wall: the inverse of `reflection_mobility`, dK = -K dM K."""
    mobility, d_mobility = reflection_mobility(eps)
    matrix = np.linalg.inv(mobility)
    matrix = 0.5 * (matrix + matrix.T)  # symmetric to round-off, as the mobility is
    slope = -matrix @ d_mobility @ matrix
    return matrix, 0.5 * (slope + slope.T)


def smooth_step(x: float, start: float, end: float) -> tuple[float, float]:
    """(w, dw/dx): 0 below start, 1 above end, the quintic s^3 (10 - 15 s + 6 s^2) between (C^2 at both ends)."""
    if x <= start:
        return 0.0, 0.0
    if x >= end:
        return 1.0, 0.0
    width = end - start
    s = (x - start) / width
    return s**3 * (10.0 - 15.0 * s + 6.0 * s * s), 30.0 * s * s * (1.0 - s) ** 2 / width


def _blend(near, far, weight: float, weight_slope: float) -> tuple[np.ndarray, np.ndarray]:
    (a, da), (b, db) = near, far
    return (1.0 - weight) * a + weight * b, (1.0 - weight) * da + weight * db + weight_slope * (b - a)


def tangential_resistance(eps: float) -> tuple[np.ndarray, np.ndarray]:
    """(K, dK/d eps) at the gap eps = delta / a: the dimensionless symmetric resistance of the module docstring,
    joined from the lubrication series, the Pade approximants and the reflections."""
    if eps <= LUBRICATION_END:
        return lubrication_matrix(eps)
    if eps < PADE_START:
        return _blend(lubrication_matrix(eps), pade_matrix(eps), *smooth_step(eps, LUBRICATION_END, PADE_START))
    if eps <= PADE_END:
        return pade_matrix(eps)
    if eps < REFLECTION_START:
        return _blend(pade_matrix(eps), reflection_matrix(eps), *smooth_step(eps, PADE_END, REFLECTION_START))
    return reflection_matrix(eps)


def tangential_coefficients(eps: float) -> tuple[float, float, float]:
    """(f_xx, c_yx, c_yy) at the gap eps, in Chaoui & Feuillebois' units (module docstring)."""
    return coefficients(tangential_resistance(eps)[0])


def wall_tangential_resistance(radius: float, viscosity: float, gap: float) -> tuple[np.ndarray, np.ndarray]:
    """(R, dR/d gap): [F [N], T [N m]] = -R [U [m/s], Omega [1/s]] for a sphere of `radius` [m] at the `gap` [m] in
    a liquid of `viscosity` [Pa s] (module docstring for the signs).  R = 6 pi mu a S K S, S = diag(1, a): symmetric,
    entries in N s/m, N s and N m s; dR/d gap in the same units per metre."""
    if radius <= 0.0 or viscosity <= 0.0:
        raise ValueError(f"radius and viscosity must be positive (got {radius}, {viscosity})")
    matrix, slope = tangential_resistance(gap / radius)
    scale = np.array([1.0, radius])
    factor = 6.0 * math.pi * viscosity * radius * np.outer(scale, scale)
    return factor * matrix, factor * slope / radius
