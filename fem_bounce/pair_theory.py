"""Stokes resistance of two rigid spheres translating along their line of centres (docs/pair_theory.md).

Sphere 1 (radius a1) lies below sphere 2 (radius a2) on the z axis (positive up); h > 0 is the
surface gap, d = a1 + a2 + h the centre distance, U1, U2 the velocities (positive up) in an unbounded
liquid of viscosity mu at rest far away.  The hydrodynamic forces on the spheres are

    F_1 = -6 pi mu a1 (X11 U1 + X12 U2),    F_2 = -6 pi mu a2 (X21 U1 + X22 U2),

so an isolated sphere has X11 = X22 = 1 and X12 = X21 = 0; `resistance` returns the dimensionless
matrix X.  The reciprocal theorem makes the dimensional matrix 6 pi mu a_i X_ij symmetric:
a1 X12 = a2 X21.  Approach (U1 > U2) gives X11, X22 > 0 and X12, X21 < 0.

Exact: the bispherical-coordinate solution of Stimson & Jeffery (1926), with each sphere's own
velocity (Maude 1961; Brenner 1961; Cooley & O'Neill 1969 for a fixed second sphere).  Asymptotic:
the lubrication form near contact (Jeffrey & Onishi 1984) and the method of reflections far away
(Happel & Brenner 1965, ch. 6).  All lengths in metres or any one consistent unit; X is dimensionless.
"""
from __future__ import annotations

import bisect
import math

import numpy as np
from scipy.interpolate import CubicSpline

from .scene import reduced_radius
from .theory import bispherical_drag_factor

SERIES_TOLERANCE = 1e-13  # truncation of the Gegenbauer series, relative to the isolated drag
MAX_TERMS = 400_000  # safety cap; the series needs about 36 / (alpha + beta) terms
SERIES_MIN_GAP = 1e-4  # in units of the reduced radius: below it `resistance` uses the lubrication form


def bispherical_poles(a_upper: float, a_lower: float, gap: float) -> tuple[float, float, float]:
    """(alpha, beta, c): the upper sphere is xi = alpha > 0, the lower xi = -beta < 0, c the focal length.

    Centres at z = c coth(alpha) and -c coth(beta), radii c / sinh(alpha) = a_upper, c / sinh(beta)
    = a_lower (Stimson & Jeffery 1926, section 2).  cosh(alpha) - 1 = h (h + 2 a_lower) / (2 d a_upper)
    is written without the difference d^2 - a^2, which cancels catastrophically for very unequal radii.
    """
    d = a_upper + a_lower + gap
    alpha = 2.0 * math.asinh(math.sqrt(gap * (gap + 2.0 * a_lower) / (4.0 * d * a_upper)))
    beta = 2.0 * math.asinh(math.sqrt(gap * (gap + 2.0 * a_upper) / (4.0 * d * a_lower)))
    return alpha, beta, a_upper * math.sinh(alpha)


def _series_terms(alpha: float, beta: float, n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per Gegenbauer order n: the upper sphere's drag terms for unit velocity of the upper sphere
    (minus the isolated sphere's terms) and for unit velocity of the lower sphere.

    Stream function psi = (cosh xi - cos eta)^(-3/2) sum_n U_n(xi) C_{n+1}^{-1/2}(cos eta), with
    U_n a combination of exp(+-(n - 1/2) xi), exp(+-(n + 3/2) xi) (Stimson & Jeffery 1926).
    A sphere xi = xi_s translating with V has psi = V r^2 / 2 on it, whose Gegenbauer coefficient is
    V c^2 n(n+1)/sqrt(2) [e^{-(n-1/2)|xi|}/(2n-1) - e^{-(n+3/2)|xi|}/(2n+3)]; U_n and dU_n/dxi must
    match it on both spheres: 4 equations for 4 coefficients per n.  The basis
    e^{k(xi - alpha)}, e^{-k(xi + beta)} is bounded by 1 between the spheres, so the 4x4 systems stay
    well scaled.  The force on the upper sphere is 2 sqrt(2) pi mu / c sum_n (A_n + B_n + C_n + D_n)
    (Stimson & Jeffery 1926; Brenner 1961), i.e. twice the coefficients of the growing exponentials
    e^{+k xi}; in units of 6 pi mu a_upper V each term is (2/3) sinh(alpha) (P1 e^{-k1 alpha}
    + P2 e^{-k2 alpha}).  The isolated sphere's terms (same conditions, fluid down to xi -> -inf) sum
    to exactly 1 but converge only like e^{-2 n alpha}, which is hopeless for a large sphere beside a
    small one; subtracting them leaves terms that fall like e^{-n (alpha + beta)}.
    """
    k1, k2 = n - 0.5, n + 1.5
    weight = 0.5 * n * (n + 1.0)
    span = alpha + beta
    e1, e2 = np.exp(-k1 * span), np.exp(-k2 * span)
    ones = np.ones_like(n)
    system = np.empty((len(n), 4, 4))  # rows: value, slope at alpha; value, slope at -beta
    system[:, 0] = np.stack([ones, e1, ones, e2], axis=-1)
    system[:, 1] = np.stack([k1, -k1 * e1, k2, -k2 * e2], axis=-1)
    system[:, 2] = np.stack([e1, ones, e2, ones], axis=-1)
    system[:, 3] = np.stack([k1 * e1, -k1 * ones, k2 * e2, -k2 * ones], axis=-1)

    def boundary_data(pole):
        ea1, ea2 = np.exp(-k1 * pole), np.exp(-k2 * pole)
        return weight * (ea1 / k1 - ea2 / k2), weight * (ea1 - ea2)

    rhs = np.zeros((len(n), 4, 2))
    value, slope = boundary_data(alpha)
    rhs[:, 0, 0], rhs[:, 1, 0] = value, -slope  # the upper sphere moves
    value, slope = boundary_data(beta)
    rhs[:, 2, 1], rhs[:, 3, 1] = value, slope  # the lower sphere moves
    coefficients = np.linalg.solve(system, rhs)
    ea1, ea2 = np.exp(-k1 * alpha), np.exp(-k2 * alpha)
    terms = coefficients[:, 0, :] * ea1[:, None] + coefficients[:, 2, :] * ea2[:, None]

    # isolated upper sphere: U_n = P e^{k1 (xi - alpha)} + R e^{k2 (xi - alpha)}
    value, slope = boundary_data(alpha)
    r = (-slope - k1 * value) / (k2 - k1)
    isolated = (value - r) * ea1 + r * ea2
    return terms[:, 0] - isolated, terms[:, 1]


def _upper_sphere_row(a_upper: float, a_lower: float, gap: float, n_terms: int | None) -> tuple[float, float]:
    """(X_self, X_other) for the upper sphere: F = -6 pi mu a_upper (X_self U_upper + X_other U_lower)."""
    alpha, beta, _ = bispherical_poles(a_upper, a_lower, gap)
    scale = 2.0 / 3.0 * math.sinh(alpha)
    n_max = int(36.0 / (alpha + beta)) + 8 if n_terms is None else n_terms
    while True:  # the estimate suffices in every case tried; the check guards the rest
        own, other = _series_terms(alpha, beta, np.arange(1.0, n_max + 1.0))
        x_self, x_other = 1.0 + scale * float(np.sum(own)), scale * float(np.sum(other))
        if n_terms is not None:
            return x_self, x_other
        # the terms fall geometrically, by about exp(-(alpha + beta)) per order: bound the tail
        tail = scale * max(abs(own[-1]), abs(other[-1])) / -math.expm1(-(alpha + beta))
        if tail < SERIES_TOLERANCE * max(1.0, abs(x_self)) or n_max >= MAX_TERMS:
            return x_self, x_other
        n_max = min(2 * n_max, MAX_TERMS)


def exact_series(a1: float, a2: float, h: float, n_terms: int | None = None) -> np.ndarray:
    """The bispherical series at any gap, no asymptotic switch (2x2 X as in `resistance`).

    Below about 1e-5 a* the 4x4 systems of the lowest orders lose digits (relative error 1e-10 at
    1e-5 a*, 1e-8 at 1e-6 a*, measured against the closed forms for equal spheres)."""
    # sphere 1 is the lower one; reflecting z -> -z makes it the upper one and flips every velocity
    # and force, which leaves the coefficients unchanged
    x11, x12 = _upper_sphere_row(a1, a2, h, n_terms)
    x22, x21 = _upper_sphere_row(a2, a1, h, n_terms)
    return np.array([[x11, x12], [x21, x22]])


def lubrication(a1: float, a2: float, h: float) -> float:
    """Near-contact relative-motion factor L: F_1 = -F_2 = -6 pi mu a* L (U1 - U2) + O(1) U [N],

        L = a*/h + (1 + 7 k + k^2) / (5 (1 + k)^2) ln(a*/h),   k = a2/a1,  a* = a1 a2/(a1 + a2),

    the singular terms g1/xi + g2 ln(1/xi) of X^A_11 of Jeffrey & Onishi (1984;
    g1 = 2 k^2/(1+k)^3, g2 = k (1 + 7k + k^2)/(5 (1+k)^3), xi = 2h/(a1 + a2)) rewritten with a*,
    the logarithm's argument changed to a*/h (only the O(1) constant, which is not included,
    depends on it).  Equal spheres: a/(2h) + (9/20) ln(a/(2h)); a2 -> inf: Cox & Brenner's (1967)
    a/h + (1/5) ln(a/h).  Relative error against the exact series: 2e-4 at h = 1e-4 a* (the missing
    constant), tending to zero as h -> 0.  Dimensionless; h and the radii in one unit."""
    a_star = reduced_radius(a1, a2)
    return a_star / h + _log_weight(a1, a2) * math.log(a_star / h)


def _log_weight(a1: float, a2: float) -> float:
    """The logarithm's weight in `lubrication`: (1 + 7k + k^2) / (5 (1 + k)^2), k = a2 / a1."""
    k = a2 / a1
    return (1.0 + 7.0 * k + k * k) / (5.0 * (1.0 + k) ** 2)


def _singular_part(a1: float, a2: float, h: float) -> np.ndarray:
    """The lubrication terms of X: +-(a*/a_i) L, the part of X that diverges as h -> 0."""
    a_star = reduced_radius(a1, a2)
    singular = lubrication(a1, a2, h)
    return np.array([[a_star / a1, -a_star / a1], [-a_star / a2, a_star / a2]]) * singular


def resistance(a1: float, a2: float, h: float, n_terms: int | None = None) -> np.ndarray:
    """Dimensionless resistance matrix X (module docstring): F_i = -6 pi mu a_i sum_j X_ij U_j.

    h >= SERIES_MIN_GAP a*: the exact bispherical series (`exact_series`), summed to relative 1e-13.
    Below: X = singular lubrication terms (`lubrication`) + the O(1) remainder of the series at
    SERIES_MIN_GAP a*, which Jeffrey & Onishi (1984) show tends to a constant; the neglected
    O((h/a*) ln(a*/h)) leaves a relative error below 1e-7 (measured at 1e-5 a*, docs/pair_theory.md).
    With n_terms given, exactly that many terms of the series at any gap."""
    if h <= 0.0:
        raise ValueError(f"the gap must be positive, got h = {h}")
    if n_terms is not None:
        return exact_series(a1, a2, h, n_terms)
    switch = SERIES_MIN_GAP * reduced_radius(a1, a2)
    if h >= switch:
        return exact_series(a1, a2, h)
    remainder = exact_series(a1, a2, switch) - _singular_part(a1, a2, switch)
    return _singular_part(a1, a2, h) + remainder


def stimson_jeffery(a: float, h: float) -> float:
    """lambda for two equal spheres (radius a, gap h) moving with the same velocity U along their
    line of centres: force on each -6 pi mu a U lambda (Stimson & Jeffery 1926's closed form, also in
    Happel & Brenner 1965, ch. 6):

        lambda = (4/3) sinh(alpha) sum_n n(n+1)/((2n-1)(2n+3))
                 [1 - (4 sinh^2((n+1/2) alpha) - (2n+1)^2 sinh^2 alpha)
                      / (2 sinh((2n+1) alpha) + (2n+1) sinh(2 alpha))],   cosh(alpha) = 1 + h/(2a).

    -> 1 far apart, 0.6451 at contact.  Equals X11 + X12 of `resistance(a, a, h)`."""
    alpha = 2.0 * math.asinh(math.sqrt(h / (4.0 * a)))
    return bispherical_drag_factor(alpha, 40.0, lambda k: 1.0 - (
        4.0 * np.sinh(0.5 * k * alpha) ** 2 - (k * math.sinh(alpha)) ** 2) / (
        2.0 * np.sinh(k * alpha) + k * math.sinh(2.0 * alpha)))


def equal_spheres_approach(a: float, h: float) -> float:
    """lambda for two equal spheres approaching each other at +-U: force on each -6 pi mu a U lambda
    against its own motion.  The mid-plane is a plane of symmetry: no normal velocity but free slip,
    so this is Brenner's (1961) sphere approaching a plane FREE SURFACE at gap h/2 (his second case;
    Maude 1961), not his rigid wall, whose factor is larger (by 4 at leading order):

        lambda = (4/3) sinh(alpha) sum_n n(n+1)/((2n-1)(2n+3))
                 [(4 cosh^2((n+1/2) alpha) + (2n+1)^2 sinh^2 alpha)
                  / (2 sinh((2n+1) alpha) - (2n+1) sinh(2 alpha)) - 1],   cosh(alpha) = 1 + h/(2a).

    Equals X11 - X12 of `resistance(a, a, h)`; -> a/(2h) + (9/20) ln(a/h) + 1.3456 near contact."""
    alpha = 2.0 * math.asinh(math.sqrt(h / (4.0 * a)))
    return bispherical_drag_factor(alpha, 40.0, lambda k: (
        4.0 * np.cosh(0.5 * k * alpha) ** 2 + (k * math.sinh(alpha)) ** 2) / (
        2.0 * np.sinh(k * alpha) - k * math.sinh(2.0 * alpha)) - 1.0)


def approach_fixed(a1: float, a2: float, h: float) -> float:
    """Sphere 1 moving toward (or away from) a FIXED sphere 2: F_1 = -6 pi mu a1 U1 lambda, lambda = X11
    (Cooley & O'Neill 1969).  a2 -> inf gives Brenner's (1961) wall factor at delta = h / (2 a1)."""
    return float(resistance(a1, a2, h)[0, 0])


def far_field(a1: float, a2: float, h: float) -> np.ndarray:
    """X by the method of reflections (Happel & Brenner 1965, ch. 6), d = a1 + a2 + h:

        X11 = 1 + 9 a1 a2 / (4 d^2) + O(d^-4),
        X12 = -3 a2 / (2 d) + [a2 (a1^2 + a2^2) / 2 - 27 a1 a2^2 / 8] / d^3 + O(d^-5),

    the leading X12 being the Oseen tensor's velocity on the axis, F / (4 pi mu d), of the point force
    6 pi mu a2 U2 sphere 2 exerts on the liquid; then its source dipole -a2^3 U2 / (2 d^3), Faxen's
    (a1^2/6) del^2 u, and the third reflection (3 a2/2d)(3 a1/2d)(3 a2/2d).  Rows 2 by exchange."""
    return np.array(_far_field_slopes(a1, a2, h)[0]).reshape(2, 2)


def _far_field_slopes(a1: float, a2: float, h: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(X11, X12, X21, X22) of `far_field` and their derivatives d/dh [1/m], plain floats."""
    d = a1 + a2 + h

    def row(own, other):
        dipole = 0.5 * other * (own**2 + other**2) - 27.0 / 8.0 * own * other**2
        return ((1.0 + 9.0 * own * other / (4.0 * d * d), -1.5 * other / d + dipole / d**3),
                (-9.0 * own * other / (2.0 * d**3), 1.5 * other / (d * d) - 3.0 * dipole / d**4))

    (x11, x12), (d11, d12) = row(a1, a2)
    (x22, x21), (d22, d21) = row(a2, a1)
    return (x11, x12, x21, x22), (d11, d12, d21, d22)


def _log_gap_spline(knots: list[float], coefficients: list, h: float) -> tuple[tuple[float, float, float], ...]:
    """Three cubic splines in x = ln h (knots, and per interval the coefficients of (x - knot)^3 ... ^0 of
    each, as CubicSpline.c), evaluated at the gap h [m] with their first and second derivatives in x:
    ((f11, f12, f22), (df/dx ...), (d2f/dx2 ...)), plain floats.  Ends: the first and last cubic go on."""
    x = math.log(h)
    i = min(max(bisect.bisect_right(knots, x) - 1, 0), len(coefficients) - 1)
    t = x - knots[i]
    (a11, a12, a22), (b11, b12, b22), (c11, c12, c22), (e11, e12, e22) = coefficients[i]
    return ((((a11 * t + b11) * t + c11) * t + e11, ((a12 * t + b12) * t + c12) * t + e12,
             ((a22 * t + b22) * t + c22) * t + e22),
            ((3.0 * a11 * t + 2.0 * b11) * t + c11, (3.0 * a12 * t + 2.0 * b12) * t + c12,
             (3.0 * a22 * t + 2.0 * b22) * t + c22),
            (6.0 * a11 * t + 2.0 * b11, 6.0 * a12 * t + 2.0 * b12, 6.0 * a22 * t + 2.0 * b22))


class PairResistance:
    """X(h) of `resistance` for one pair of radii, tabulated once and interpolated: the series costs
    milliseconds near contact, an ODE right-hand side needs microseconds.

    Table: gaps from TABLE_MIN a* to TABLE_MAX (a1 + a2), POINTS_PER_DECADE per decade; the far end is
    set by the larger sphere, because the far-field expansion needs d >> both radii.  Interpolated by
    cubic splines in ln h of Y_ij = X_ij h / (h + a*), which is smooth at both ends (the 1/h and ln h of
    lubrication become h ln h).  Below the table: the lubrication form with the table's O(1) remainder
    (as `resistance`); above it: `far_field`.  X21 = a1 X12 / a2 (reciprocity).
    Measured error against the series (docs/pair_theory.md, tests/test_pair_theory.py): below 2e-7 of
    |X_i1| + |X_i2| for radius ratios 1 to 1000 (INTERPOLATION_TOLERANCE is the stated 1e-6); the jumps
    at the table's ends are below 1e-8.  About 3 us per call; building the table takes 0.1-0.5 s."""

    TABLE_MIN = 1e-4  # in units of a*
    TABLE_MAX = 100.0  # in units of a1 + a2
    POINTS_PER_DECADE = 24
    INTERPOLATION_TOLERANCE = 1e-6  # stated bound on |X_table - X_series| / (|X11| + |X12|) per row

    def __init__(self, a1: float, a2: float):
        if a1 <= 0.0 or a2 <= 0.0:
            raise ValueError(f"radii must be positive, got a1 = {a1}, a2 = {a2}")
        self.a1, self.a2 = a1, a2
        self.a_star = reduced_radius(a1, a2)
        self.h_min = self.TABLE_MIN * self.a_star
        self.h_max = self.TABLE_MAX * (a1 + a2)
        decades = math.log10(self.h_max / self.h_min)
        log_gap = np.linspace(math.log(self.h_min), math.log(self.h_max), int(decades * self.POINTS_PER_DECADE) + 1)
        gaps = np.exp(log_gap)
        table = np.array([exact_series(a1, a2, h) for h in gaps])
        # the constant left after the singular terms at the table's lower end
        self._remainder = table[0] - _singular_part(a1, a2, gaps[0])
        self._remainders = tuple(self._remainder.ravel().tolist())
        squeeze = gaps / (gaps + self.a_star)
        smooth = np.stack([table[:, 0, 0], table[:, 0, 1], table[:, 1, 1]], axis=-1) * squeeze[:, None]
        spline = CubicSpline(log_gap, smooth, axis=0)
        # plain floats for a scalar evaluation without numpy overhead
        self.gaps = gaps  # [m], the table's knots
        self._knots = log_gap.tolist()
        self._coefficients = [tuple(tuple(spline.c[p, i, :].tolist()) for p in range(4))
                              for i in range(len(gaps) - 1)]

    def coefficients(self, h: float) -> tuple[float, float, float, float]:
        """(X11, X12, X21, X22) at gap h [m]: plain floats, for right-hand sides."""
        return self.coefficients_slopes(h)[0]

    def coefficients_slopes(self, h: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """((X11, X12, X21, X22), their derivatives d/dh [1/m]) at gap h [m]: of the lubrication form below
        the table, of the spline inside it (Y = X h / (h + a*), so X' = Y' / h (h + a*) / h - Y a* / h^2),
        of `far_field` above it."""
        if h < self.h_min:
            if h <= 0.0:
                raise ValueError(f"the gap must be positive, got h = {h}")
            return self._lubrication_slopes(h)
        if h > self.h_max:
            return _far_field_slopes(self.a1, self.a2, h)
        (y11, y12, y22), (dy11, dy12, dy22), _ = _log_gap_spline(self._knots, self._coefficients, h)
        unsqueeze = (h + self.a_star) / h
        squeeze_rate = -self.a_star / (h * h)  # d(unsqueeze)/dh
        x12, d12 = y12 * unsqueeze, dy12 / h * unsqueeze + y12 * squeeze_rate
        reciprocal = self.a1 / self.a2
        return ((y11 * unsqueeze, x12, self.a1 * x12 / self.a2, y22 * unsqueeze),
                (dy11 / h * unsqueeze + y11 * squeeze_rate, d12, reciprocal * d12,
                 dy22 / h * unsqueeze + y22 * squeeze_rate))

    def _lubrication_slopes(self, h: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """Below the table: the singular terms +-(a*/a_i) L(h) (`lubrication`) plus the table's O(1)
        remainder, and their derivatives, L' = -a*/h^2 - g/h."""
        a1, a2, a_star = self.a1, self.a2, self.a_star
        singular, slope = lubrication(a1, a2, h), -a_star / (h * h) - _log_weight(a1, a2) / h
        r11, r12, r21, r22 = self._remainders
        own1, own2 = a_star / a1, a_star / a2
        return ((own1 * singular + r11, -own1 * singular + r12, -own2 * singular + r21, own2 * singular + r22),
                (own1 * slope, -own1 * slope, -own2 * slope, own2 * slope))

    def __call__(self, h: float) -> np.ndarray:
        """The 2x2 X at gap h [m], as `resistance`."""
        return np.array(self.coefficients(h)).reshape(2, 2)

    def forces(self, h: float, u1: float, u2: float, viscosity: float) -> tuple[float, float]:
        """(F_1, F_2) [N] on the spheres for velocities u1, u2 [m/s] (positive up), viscosity [Pa s]."""
        x11, x12, x21, x22 = self.coefficients(h)
        stokes = 6.0 * math.pi * viscosity
        return -stokes * self.a1 * (x11 * u1 + x12 * u2), -stokes * self.a2 * (x21 * u1 + x22 * u2)


# -- the pair's added mass in potential flow ---------------------------------------------------------------

ADDED_MASS_TERMS = 14.0  # terms fall like exp(-3 n omega): n omega = 14 leaves exp(-42) ~ 6e-19 of the first


def _pole_rates(a_upper: float, a_lower: float, gap: float) -> float:
    """d(alpha)/dh of `bispherical_poles` (alpha the upper sphere's pole) [1/m]."""
    d = a_upper + a_lower + gap
    g = gap * (gap + 2.0 * a_lower) / (4.0 * d * a_upper)
    dg = ((2.0 * gap + 2.0 * a_lower) * d - gap * (gap + 2.0 * a_lower)) / (4.0 * a_upper * d * d)
    return dg / (math.sqrt(g) * math.sqrt(1.0 + g))


def added_mass_series(a1: float, a2: float, h: float, derivative: bool = False):
    """The potential-flow added-mass coefficients C of two spheres translating along their line of centres.

    Sphere 1 (radius a1) below sphere 2 (radius a2), surface gap h > 0, velocities V1, V2 along the axis; the
    liquid's kinetic energy is T = (1/2) sum_ij M_ij V_i V_j with M_ij = m_l,i C_ij, m_l,i = rho (4/3) pi a_i^3
    the liquid each sphere displaces (isolated: C = diag(1/2)).  In the bispherical coordinates of
    `bispherical_poles` (sphere 2 at xi = alpha, sphere 1 at xi = -beta, omega = alpha + beta):

        C11 = 1/2 + (3/2) sum_{n>=1} [sinh(beta) / sinh(beta + n omega)]^3,
        C12 = -(3/2) sum_{n>=1} [sinh(beta) / sinh(n omega)]^3,        (C22, C21: alpha for beta)

    derived here by the method of images that Hicks (1880) and Lamb (1932, section 98) apply to this problem
    (their texts were not available to us: docs/pair_theory.md section 8): each sphere's doublet (moment
    V a^3 / 2) is reflected in the other sphere, an axial doublet mu at distance f from the centre of a
    sphere of radius R having the image -mu (R / f)^3 at the inverse point; inversion in the sphere
    xi = alpha maps xi to 2 alpha - xi, which gives the sinh ratios.  A body's added mass is 4 pi rho (the
    doublets inside it per unit velocity) less its displaced mass, its interaction 4 pi rho (the doublets
    its motion induces inside the other body) (Taylor 1928).  Checks (tests):
    m_l,1 C12 = m_l,2 C21 (reciprocity: both equal -2 pi rho c^3 sum sinh(n omega)^-3); equal spheres
    approaching at +-U have the plane of symmetry as a wall, C11 - C12 = the wall's C_M (theory.exact_w) at
    h / 2; a2 -> infinity gives the wall's C_M; far apart C12 -> -(3/2) a2^3 / d^3 (Lamb's leading term).

    Returns the 2x2 C, and with derivative=True also dC/dh [1/m] (analytic)."""
    if h <= 0.0:
        raise ValueError(f"the gap must be positive, got h = {h}")
    alpha, beta, _ = bispherical_poles(a2, a1, h)
    omega = alpha + beta
    n = np.arange(1.0, int(ADDED_MASS_TERMS / omega) + 4.0)
    poles = (beta, alpha)  # sphere 1, sphere 2
    own = [(math.sinh(p) / np.sinh(p + n * omega)) ** 3 for p in poles]
    cross = [(math.sinh(p) / np.sinh(n * omega)) ** 3 for p in poles]
    c = np.array([[0.5 + 1.5 * np.sum(own[0]), -1.5 * np.sum(cross[0])],
                  [-1.5 * np.sum(cross[1]), 0.5 + 1.5 * np.sum(own[1])]])
    if not derivative:
        return c
    rates = (_pole_rates(a1, a2, h), _pole_rates(a2, a1, h))  # d(beta)/dh, d(alpha)/dh
    d_omega = rates[0] + rates[1]
    d_own = [3.0 * own[k] * (rates[k] / math.tanh(poles[k]) - (rates[k] + n * d_omega) / np.tanh(poles[k] + n * omega))
             for k in range(2)]
    d_cross = [3.0 * cross[k] * (rates[k] / math.tanh(poles[k]) - n * d_omega / np.tanh(n * omega)) for k in range(2)]
    dc = np.array([[1.5 * np.sum(d_own[0]), -1.5 * np.sum(d_cross[0])],
                   [-1.5 * np.sum(d_cross[1]), 1.5 * np.sum(d_own[1])]])
    return c, dc


def added_mass_at_contact(a1: float, a2: float) -> np.ndarray:
    """C of `added_mass_series` as h -> 0: alpha, beta -> 0 with alpha / beta -> a1 / a2, so

        C11 = 1/2 + (3/2) q^-3 zeta(3, 1 + 1/q),  q = 1 + a1/a2,     C12 = -(3/2) zeta(3) (a2 / (a1 + a2))^3

    (zeta(3, x) Hurwitz's zeta).  Equal spheres: C11 = 1/2 + (3/2)((7/8) zeta(3) - 1) = 0.57770,
    C12 = -(3/16) zeta(3) = -0.22539 (so C11 - C12 = 1/2 + (3/2)(zeta(3) - 1) = 0.80309, the sphere touching
    a wall, and C11 + C12 = 0.35231 for the touching pair moving together); a2 -> infinity: C11 -> 0.80309."""
    from scipy.special import zeta

    q1, q2 = 1.0 + a1 / a2, 1.0 + a2 / a1
    own = [0.5 + 1.5 * q**-3 * float(zeta(3.0, 1.0 + 1.0 / q)) for q in (q1, q2)]
    z3 = float(zeta(3.0))
    return np.array([[own[0], -1.5 * z3 * (a2 / (a1 + a2)) ** 3], [-1.5 * z3 * (a1 / (a1 + a2)) ** 3, own[1]]])


def added_mass_far_field(a1: float, a2: float, h: float) -> tuple[np.ndarray, np.ndarray]:
    """(C, dC/dh) far apart, d = a1 + a2 + h: the first image of each series, which is exact,

        C11 = 1/2 + (3/2) (a1 a2)^3 / (d^2 - a2^2)^3 + O(d^-12),    C12 = -(3/2) a2^3 / d^3 + O(d^-9)

    (the doublet of sphere 1 reflected in sphere 2, at a2^2 / d from its centre, and back; Lamb 1932,
    section 98: L = (2/3) pi rho a^3 (1 + 3 a^3 b^3 / d^6 + ...), M = -2 pi rho a^3 b^3 / d^3 + ...)."""
    d = a1 + a2 + h
    p = (a1 * a2) ** 3
    c = np.array([[0.5 + 1.5 * p / (d * d - a2 * a2) ** 3, -1.5 * a2**3 / d**3],
                  [-1.5 * a1**3 / d**3, 0.5 + 1.5 * p / (d * d - a1 * a1) ** 3]])
    dc = np.array([[-9.0 * d * p / (d * d - a2 * a2) ** 4, 4.5 * a2**3 / d**4],
                   [4.5 * a1**3 / d**4, -9.0 * d * p / (d * d - a1 * a1) ** 4]])
    return c, dc


def _far_field_curvature(a1: float, a2: float, h: float) -> tuple[float, float, float, float]:
    """d2C/dh2 [1/m2] of `added_mass_far_field`, as (C11, C12, C21, C22)."""
    d = a1 + a2 + h
    p = (a1 * a2) ** 3

    def own(other):
        s = d * d - other * other
        return -9.0 * p / s**4 + 72.0 * d * d * p / s**5
    return own(a2), -18.0 * a2**3 / d**5, -18.0 * a1**3 / d**5, own(a1)


class PairAddedMass:
    """C(h) and dC/dh of `added_mass_series` for one pair of radii, tabulated once: the series needs
    about 14 / omega terms (thousands near contact), a right-hand side needs microseconds.

    Table: gaps from TABLE_MIN a* to TABLE_MAX (a1 + a2), POINTS_PER_DECADE per decade, cubic splines in
    ln h of C11, C12, C22 (smooth: near contact C - C(0) ~ h ln h, far away ~ h^-3); dC/dh is the splines'
    own derivative, so that the Lagrangian force of `PairContactModel` is exactly that of the tabulated
    kinetic energy (an inviscid pair keeps its energy and impulse: tests/test_pair.py).  Below the table C
    is held at its value there (1e-6 a*: below any surface's roughness) with dC/dh = 0; above it,
    `added_mass_far_field`.  C21 = a1^3 C12 / a2^3 (reciprocity).  Measured against the series:
    docs/pair_theory.md section 8, tests/test_pair_theory.py."""

    TABLE_MIN = 1e-6  # in units of a*
    TABLE_MAX = 100.0  # in units of a1 + a2
    POINTS_PER_DECADE = 24

    def __init__(self, a1: float, a2: float):
        if a1 <= 0.0 or a2 <= 0.0:
            raise ValueError(f"radii must be positive, got a1 = {a1}, a2 = {a2}")
        self.a1, self.a2 = a1, a2
        self._ratio = (a1 / a2) ** 3
        self.h_min = self.TABLE_MIN * reduced_radius(a1, a2)
        self.h_max = self.TABLE_MAX * (a1 + a2)
        decades = math.log10(self.h_max / self.h_min)
        log_gap = np.linspace(math.log(self.h_min), math.log(self.h_max), int(decades * self.POINTS_PER_DECADE) + 1)
        table = np.array([added_mass_series(a1, a2, math.exp(x)) for x in log_gap])
        spline = CubicSpline(log_gap, np.stack([table[:, 0, 0], table[:, 0, 1], table[:, 1, 1]], axis=-1), axis=0)
        self.gaps = np.exp(log_gap)  # [m], the table's knots
        self._knots = log_gap.tolist()
        self._coefficients = [tuple(tuple(spline.c[p, i, :].tolist()) for p in range(4))
                              for i in range(len(log_gap) - 1)]
        self._lowest = tuple(float(v) for v in spline(log_gap[0]))

    def coefficients(self, h: float) -> tuple[tuple[float, float, float, float], tuple[float, float, float, float]]:
        """((C11, C12, C21, C22), their derivatives d/dh [1/m]) at gap h [m]: plain floats."""
        return self.coefficients_curvature(h)[:2]

    def coefficients_curvature(self, h: float) -> tuple[tuple[float, float, float, float], ...]:
        """`coefficients` and the second derivatives d2C/dh2 [1/m2] (of the splines, P'' - P' over h^2 in ln h;
        of `added_mass_far_field` above the table; 0 below it, where C is held)."""
        if h > self.h_max:
            c, dc = added_mass_far_field(self.a1, self.a2, h)
            return tuple(c.ravel().tolist()), tuple(dc.ravel().tolist()), _far_field_curvature(self.a1, self.a2, h)
        if h <= self.h_min:
            c11, c12, c22 = self._lowest
            return (c11, c12, self._ratio * c12, c22), (0.0, 0.0, 0.0, 0.0), (0.0, 0.0, 0.0, 0.0)
        # C and its derivatives in ln h: d/dh = (d/d ln h) / h, d2/dh2 = (d2/d ln h2 - d/d ln h) / h^2
        (v11, v12, v22), (r11, r12, r22), (q11, q12, q22) = _log_gap_spline(self._knots, self._coefficients, h)
        square, ratio = h * h, self._ratio
        s11, s12, s22 = r11 / h, r12 / h, r22 / h
        k11, k12, k22 = (q11 - r11) / square, (q12 - r12) / square, (q22 - r22) / square
        return (v11, v12, ratio * v12, v22), (s11, s12, ratio * s12, s22), (k11, k12, ratio * k12, k22)

    def __call__(self, h: float) -> tuple[np.ndarray, np.ndarray]:
        """(C, dC/dh) at gap h [m] as 2x2 arrays."""
        c, dc = self.coefficients(h)
        return np.array(c).reshape(2, 2), np.array(dc).reshape(2, 2)
