"""Near-wall theory forces f_thr = f_D + f_H + f_AM (paper eq. 4.1-4.4).

The paper takes the coefficient functions from Yang (2006), which is not
available; docs/physics.md section 3 gives the standard forms used here and why.  Each
choice is named by a scene key of `[contact]` so its effect can be measured:

- `wall_drag`: lambda(delta) = Brenner (1961) exact series ("brenner"), or
  1 + 1/(2 delta) ("simple").
- `inertial_factor`: the Schiller & Naumann (1933) factor phi(Re) = 1 + 0.15 Re^0.687 and Brenner's lambda:
  "screened" (the default) lambda + phi - 1 - Delta, where Delta is the part of the inertial
  excess phi - 1 that the wall takes (`wall_screening`, calibrated on the ALE model's force map);
  "additive" lambda + phi - 1: the wall's excess is lubrication, viscous at gap
  Reynolds numbers rho V h / mu -> 0, which inertia corrects only at O(Re_gap) (Cox & Brenner 1967);
  "schiller-naumann" multiplies them, lambda phi (the paper's); or "none".
- `added_mass`: the wall excess W of C_M = (1 + 3 W) / 2, first image
  W = 1 / (8 (1 + 2 delta)^3), or the exact image sum ("exact").
- `history`: the Mei & Adrian (1992) kernel, or "off";
  `history_wall_factor`: K_H = 1 ("one"), or K_H^(3/2) = lambda_Stokes(delta)
  ("drag-scaled": the wall strengthens the unsteady viscous force as much as the
  quasi-steady one; an upper bound for sensitivity studies).

Sign convention: forces and velocities are positive away from the wall.
All functions take SI units; delta = h / D.
"""
from __future__ import annotations

import bisect
import functools
import math

import numpy as np
from scipy.optimize import nnls

from . import cavitation
from .scene import Scene

# -- quasi-steady drag -------------------------------------------------------------------


def bispherical_drag_factor(alpha: float, reach: float, bracket) -> float:
    """(4/3) sinh(alpha) sum_n n(n+1)/((2n-1)(2n+3)) bracket(2n + 1) over n = 1 ... reach / alpha + 2: the
    drag factor of a sphere at the bispherical pole alpha (Stimson & Jeffery 1926; Brenner 1961)."""
    n = np.arange(1.0, int(reach / alpha) + 3.0)
    terms = n * (n + 1.0) / ((2.0 * n - 1.0) * (2.0 * n + 3.0)) * bracket(2.0 * n + 1.0)
    return float(4.0 / 3.0 * math.sinh(alpha) * np.sum(terms))


def brenner_series(delta: float) -> float:
    """Brenner (1961) exact wall-drag factor for a sphere moving normal to a plane wall.

    lambda = (4/3) sinh(alpha) sum_n n(n+1)/((2n-1)(2n+3)) [ (2 sinh((2n+1) alpha)
             + (2n+1) sinh(2 alpha)) / (4 sinh^2((n+1/2) alpha) - (2n+1)^2 sinh^2(alpha)) - 1 ],
    cosh(alpha) = 1 + 2 delta.  Terms decay like exp(-(2n+1) alpha); the sum stops
    where they fall below 1e-30 of the first.
    """
    alpha = math.acosh(1.0 + 2.0 * delta)
    return bispherical_drag_factor(alpha, 35.0, lambda k: (2.0 * np.sinh(k * alpha) + k * math.sinh(2.0 * alpha)) / (
        4.0 * np.sinh(0.5 * k * alpha) ** 2 - (k * math.sinh(alpha)) ** 2) - 1.0)


MIN_DELTA = 1e-12  # trial states of an implicit step may touch the wall; real penetration is an event

# Each wall-drag factor below comes as `*_slope(delta) -> (lambda, d lambda / d delta)`: the integrator's
# Jacobian is exact (integrator.py), so every force term gives its derivative beside its value.


def lubrication_lambda_slope(delta: float) -> tuple[float, float]:
    """Cox & Brenner (1967): 1/(2 delta) + ln(1/(2 delta))/5 + 0.971 and its derivative (0 below MIN_DELTA,
    where it is held)."""
    if delta <= MIN_DELTA:
        delta = MIN_DELTA
        return 0.5 / delta + 0.2 * math.log(0.5 / delta) + 0.971, 0.0
    return 0.5 / delta + 0.2 * math.log(0.5 / delta) + 0.971, -0.5 / delta**2 - 0.2 / delta


def lubrication_lambda(delta: float) -> float:
    """Cox & Brenner (1967): 1/(2 delta) + ln(1/(2 delta))/5 + 0.971; within 1e-4 of the series for h/a < 1e-3."""
    return lubrication_lambda_slope(delta)[0]


_TABLE_MIN, _TABLE_MAX = 1e-4, 1e3


@functools.cache
def _brenner_table() -> tuple[list[float], list[float], list[float]]:
    """log(delta) -> log(lambda), tabulated once (about 0.2 s): the series is too slow per step.  Plain
    floats (knots, values, each segment's slope) for a scalar lookup without numpy overhead."""
    log_delta = np.linspace(math.log(_TABLE_MIN), math.log(_TABLE_MAX), 1200)
    log_lambda = np.log([brenner_series(math.exp(x)) for x in log_delta])
    return log_delta.tolist(), log_lambda.tolist(), (np.diff(log_lambda) / np.diff(log_delta)).tolist()


def brenner_lambda_slope(delta: float) -> tuple[float, float]:
    """Brenner's lambda from the table (relative error below 1e-5; linear in log-log between its knots, as
    numpy.interp of log lambda), asymptotes outside it, and d lambda / d delta of that interpolant."""
    if delta < _TABLE_MIN:
        return lubrication_lambda_slope(delta)
    if delta > _TABLE_MAX:
        ratio = 1.0 / (1.0 + 2.0 * delta)  # a / d, first reflections
        return 1.0 + 1.125 * ratio + 1.265625 * ratio**2, -2.0 * ratio**2 * (1.125 + 2.53125 * ratio)
    knots, values, slopes = _brenner_table()
    x = math.log(delta)
    k = min(bisect.bisect_right(knots, x) - 1, len(slopes) - 1)
    value = math.exp(values[k] if x == knots[k] else slopes[k] * (x - knots[k]) + values[k])
    return value, value * slopes[k] / delta


def brenner_lambda(delta: float) -> float:
    """Brenner's lambda from the table (relative error below 1e-5), asymptotes outside it."""
    return brenner_lambda_slope(delta)[0]


def simple_lambda_slope(delta: float) -> tuple[float, float]:
    """1 + 1/(2 delta) and its derivative (held below MIN_DELTA)."""
    if delta <= MIN_DELTA:
        return 1.0 + 0.5 / MIN_DELTA, 0.0
    return 1.0 + 0.5 / delta, -0.5 / delta**2


def simple_lambda(delta: float) -> float:
    return simple_lambda_slope(delta)[0]


def schiller_naumann(reynolds: float) -> float:
    return 1.0 + 0.15 * reynolds**0.687


def schiller_naumann_slope(reynolds: float) -> tuple[float, float]:
    """(phi, Re dphi/dRe): V dphi/dV = Re dphi/dRe for Re proportional to |V|, which stays finite at V = 0."""
    growth = 0.15 * reynolds**0.687
    return 1.0 + growth, 0.687 * growth


def no_inertia_slope(reynolds: float) -> tuple[float, float]:
    return 1.0, 0.0


# the wall's share of the free sphere's inertial drag (contact.inertial_factor = "screened"): Delta_0 and delta_0 of
# wall_screening, calibrated against the package's ALE model (never against an experiment):
# `PYTHONPATH=. python benchmarks/near_wall_map.py --fit` (docs/physics.md 3.7)
SCREENED_DRAG, SCREENED_GAP = 0.44, 1.25


def wall_screening(inertia: float, inertia_growth: float, delta: float) -> tuple[float, float, float]:
    """(Delta, dDelta/d delta, V dDelta/dV): the part of the free sphere's inertial drag excess phi - 1, in units of
    6 pi mu a V, that a wall delta = h / D ahead of it takes away (contact.inertial_factor = "screened"):

        Delta = min(phi - 1, Delta_0 / (1 + (delta / delta_0)^2)),   Delta_0 = 0.44, delta_0 = 1.25.

    Near a wall the flow ahead of the sphere is the squeeze flow that Brenner's lambda already counts, not the free
    sphere's: the wall's excess and the inertial excess overlap instead of adding (Cox & Brenner 1967: inertia
    corrects the film only at the gap's Reynolds number).  Below Re ~ 5 the whole inertial excess goes (Stokes and
    Brenner are recovered, Delta <= phi - 1); above it the part taken saturates, the wake behind the sphere staying.
    The form and its two constants are the ALE model's force map at Re 5-50, h/D 0.02-2 (a calibration against
    the package's resolved model, docs/physics.md 3.7)."""
    share = 1.0 / (1.0 + (max(delta, 0.0) / SCREENED_GAP) ** 2)
    taken = SCREENED_DRAG * share
    if inertia - 1.0 <= taken:
        return inertia - 1.0, 0.0, inertia_growth
    return taken, -2.0 * max(delta, 0.0) / SCREENED_GAP**2 * SCREENED_DRAG * share**2, 0.0


# -- added mass --------------------------------------------------------------------------


def first_image_w(delta: float, curvature: bool = False) -> tuple[float, ...]:
    """W = 1/(8 (1 + 2 delta)^3) and dW/d(delta); with curvature=True also d2W/d(delta)2."""
    s = 1.0 + 2.0 * delta
    if curvature:
        return 0.125 / s**3, -0.75 / s**4, 6.0 / s**5
    return 0.125 / s**3, -0.75 / s**4


def exact_w(delta: float, curvature: bool = False) -> tuple[float, ...]:
    """Exact potential-flow wall excess and its derivative: the image sum
    W = sum_{n>=2} (sinh(alpha) / sinh(n alpha))^3, cosh(alpha) = 1 + 2 delta,
    so C_M = 1/2 + (3/2) W, which gives 1/2 + (3/2)(zeta(3) - 1) = 0.803 at contact
    (Milne-Thomson 1968, section 16.51; matches the tabulated C_M to 4 digits, tests/test_theory.py).
    With curvature=True also d2W/d(delta)2, differentiated term by term as the first derivative is."""
    if delta < 1e-9:  # touching (or a trial state past the wall)
        return (0.20205690315959429, 0.0, 0.0) if curvature else (0.20205690315959429, 0.0)  # zeta(3) - 1
    alpha = math.acosh(1.0 + 2.0 * delta)
    n = np.arange(2, int(40.0 / alpha) + 3, dtype=float)
    sinh_n, coth_n = np.sinh(n * alpha), 1.0 / np.tanh(n * alpha)
    ratio = math.sinh(alpha) / sinh_n
    # d(ratio)/d(alpha) = u / sinh(n alpha), u = cosh(alpha) - n sinh(alpha) coth(n alpha)
    u = math.cosh(alpha) - n * math.sinh(alpha) * coth_n
    d_ratio = u / sinh_n
    d_alpha = 2.0 / math.sinh(alpha)  # d(alpha)/d(delta)
    w, dw_dalpha = float(np.sum(ratio**3)), float(np.sum(3.0 * ratio**2 * d_ratio))
    if not curvature:
        return w, dw_dalpha * d_alpha
    du = math.sinh(alpha) - n * math.cosh(alpha) * coth_n + n**2 * math.sinh(alpha) / sinh_n**2
    dd_ratio = (du - n * u * coth_n) / sinh_n
    d2w_dalpha2 = float(np.sum(6.0 * ratio * d_ratio**2 + 3.0 * ratio**2 * dd_ratio))
    dd_alpha = -d_alpha**2 * math.cosh(alpha) / math.sinh(alpha)  # d2(alpha)/d(delta)2
    return w, dw_dalpha * d_alpha, d2w_dalpha2 * d_alpha**2 + dw_dalpha * dd_alpha


# -- history kernel ----------------------------------------------------------------------


def mei_adrian_kernel(sigma: np.ndarray, reynolds: float, c1: float = 2.0, c2: float = 0.105) -> np.ndarray:
    """K(s) with sigma = s / tau_d, tau_d = D^2 / nu (docs/physics.md section 3.2):
    K = {(4 pi sigma)^(1/(2 c1)) + (pi Re^3 sigma^2 / f_H^3)^(1/c1)}^(-c1), f_H = 0.75 + c2 Re.
    Short times give Basset's a / sqrt(pi nu s); long times decay as s^-2."""
    f_h = 0.75 + c2 * reynolds
    return ((4.0 * np.pi * sigma) ** (0.5 / c1) + (np.pi * reynolds**3 * sigma**2 / f_h**3) ** (1.0 / c1)) ** (-c1)


HISTORY_SPAN = (1e-8, 1e2)  # modes' time constants, in units of tau_d
_RE_GRID = np.concatenate([[0.0, 0.25, 0.5, 1.0, 2.0, 3.0, 5.0, 7.5], np.geomspace(10.0, 2000.0, 40)])


@functools.cache
def history_modes(modes_per_decade: int = 3, c1: float = 2.0, c2: float = 0.105) -> tuple[np.ndarray, np.ndarray]:
    """Exponential sum fitted to the kernel: K(sigma; Re) ~ sum_i w_i(Re) exp(-sigma / theta_i).

    Returns theta [n] and weights [len(_RE_GRID), n], non-negative, fitted in
    relative error on sigma in HISTORY_SPAN.  With these modes the history integral
    becomes ODE states z_i' = V' - z_i / (theta_i tau_d), so each step costs O(1)
    and an adaptive implicit integrator handles the 1/sqrt(s) singularity's stiffness.
    (van Hinsberg et al. 2011 use a window plus an exponential tail; a pure
    exponential sum fits the same kernel, to under 1 % here, and needs no fixed step.)
    """
    lo, hi = (math.log10(x) for x in HISTORY_SPAN)
    decades = hi - lo
    theta = np.logspace(lo - 0.5, hi + 0.5, int(round((decades + 1) * modes_per_decade)) + 1)
    sigma = np.logspace(lo, hi, 30 * int(decades))
    basis = np.exp(-sigma[:, None] / theta[None, :])
    weights = np.empty((len(_RE_GRID), len(theta)))
    for row, reynolds in enumerate(_RE_GRID):
        target = mei_adrian_kernel(sigma, reynolds, c1, c2)
        weights[row], _ = nnls(basis / target[:, None], np.ones_like(sigma), maxiter=50 * len(theta))
    return theta, weights


_RE_LIST = _RE_GRID.tolist()


def rotation_kernel(x: np.ndarray) -> np.ndarray:
    """K_R(x) = 1 / sqrt(pi x) - e^x erfc(sqrt x), x = s / tau_r, tau_r = a^2 / nu: the kernel of the history torque
    on a sphere spinning up or down about a diameter in unsteady Stokes flow,

        T_H(t) = -(8/3) pi mu a^3 int_0^t K_R((t - t') / tau_r) dOmega/dt' dt'.

    From the unsteady Stokes solution of a rotating sphere, u_phi = Omega a sin(theta) (a / r)^2 (1 + lambda r)
    e^(-lambda (r - a)) / (1 + lambda a), lambda = sqrt(s / nu) in Laplace space, whose torque is
    -8 pi mu a^3 Omega (1 + lambda a + lambda^2 a^2 / 3) / (1 + lambda a) (Landau & Lifshitz, Fluid Mechanics,
    section 24's problem of rotary oscillations): the part beyond the steady -8 pi mu a^3 Omega, inverted
    (L^-1 {1 / (sqrt(s) + b)} = 1 / sqrt(pi t) - b e^(b^2 t) erfc(b sqrt t)).  Short times give the boundary layer's
    (a / 3) / sqrt(pi nu s) per unit of 8 pi mu a^3, long ones decay as s^(-3/2).  The kernel of Feuillebois & Lasek
    (1978, Q. J. Mech. Appl. Math. 31, 435) by its description (its text not read here)."""
    from scipy.special import erfcx

    x = np.asarray(x, dtype=float)
    return 1.0 / np.sqrt(np.pi * x) - erfcx(np.sqrt(x))


@functools.cache
def rotation_history_modes(modes_per_decade: int = 3) -> tuple[np.ndarray, np.ndarray]:
    """Exponential sum fitted to rotation_kernel: K_R(x) ~ sum_i w_i exp(-x / theta_i) on x in HISTORY_SPAN (units of
    tau_r = a^2 / nu), in relative error, as history_modes fits the translation's; (theta, w), non-negative (K_R is
    completely monotone: int_0^inf e^(-x t) sqrt(t) / (pi (1 + t)) dt)."""
    lo, hi = (math.log10(x) for x in HISTORY_SPAN)
    decades = hi - lo
    theta = np.logspace(lo - 0.5, hi + 0.5, int(round((decades + 1) * modes_per_decade)) + 1)
    x = np.logspace(lo, hi, 30 * int(decades))
    target = rotation_kernel(x)
    weights, _ = nnls(np.exp(-x[:, None] / theta[None, :]) / target[:, None], np.ones_like(x), maxiter=50 * len(theta))
    return theta, weights


def history_weights(weights: np.ndarray, reynolds: float) -> np.ndarray:
    """Weights at this Re, interpolated linearly between the fitted rows."""
    row, share, _ = history_row(reynolds)
    return weights[row] if share is None else (1.0 - share) * weights[row] + share * weights[row + 1]


def history_row(reynolds: float) -> tuple[int, float | None, float]:
    """Where Re falls among the fitted rows: (row k, its share t toward row k + 1, d t / dRe); t is None
    beyond the last row, whose weights hold there."""
    k = bisect.bisect_right(_RE_LIST, reynolds) - 1
    if k >= len(_RE_LIST) - 1:
        return len(_RE_LIST) - 1, None, 0.0
    span = _RE_LIST[k + 1] - _RE_LIST[k]
    return k, (reynolds - _RE_LIST[k]) / span, 1.0 / span


# -- the force model used by every solver --------------------------------------------------


class TheoryForces:
    """f_thr for one scene: drag, added mass and history as functions of (gap, velocity, history states).

    Each force comes with its derivatives in its arguments (`*_slopes`: the gap, the share `film` of the
    wall's excess left inside a Hertz contact, the velocity), from which the integrator builds its exact
    Jacobian by the chain rule; tests/test_jacobian.py checks them against differences."""

    def __init__(self, scene: Scene):
        c = scene.contact
        sphere, liquid = scene.sphere, scene.liquid
        self.diameter = sphere.diameter
        self.stokes_drag = 6.0 * math.pi * liquid.viscosity * sphere.radius  # 6 pi mu a [N s/m]
        self.displaced_mass = scene.displaced_mass
        self._re_per_speed = scene.reynolds(1.0)
        self._lambda = {"brenner": brenner_lambda_slope, "simple": simple_lambda_slope}[c.wall_drag]
        self._inertia = {"schiller-naumann": schiller_naumann_slope, "additive": schiller_naumann_slope,
                         "screened": schiller_naumann_slope, "none": no_inertia_slope}[c.inertial_law]
        self._additive = c.inertial_law in ("additive", "screened")
        self._screened = c.inertial_law == "screened" and scene.wall.present
        self._w = {"first-image": first_image_w, "exact": exact_w}[c.added_mass]
        self.wall_present = scene.wall.present  # without the wall: lambda = 1 and W = 0 at every gap
        # the most tension the film under the sphere holds as it leaves the wall [Pa] (fem_bounce.cavitation)
        floor = scene.cavitation_pressure
        self.tension = math.inf if floor is None or not self.wall_present else -floor
        self._film = (sphere.radius, liquid.viscosity)
        theta, self._weights = history_modes(scene.numerics.ode.history_modes_per_decade, c.history_c1, c.history_c2)
        diffusion_time = sphere.diameter**2 / liquid.kinematic_viscosity
        self.history_times = theta * diffusion_time  # T_i [s]
        self.n_history = len(theta) if c.history == "mei-adrian" else 0  # the history modes carried

    def reynolds(self, velocity: float) -> float:
        return self._re_per_speed * abs(velocity)

    def wall_factor(self, gap: float, film: float = 1.0) -> float:
        """lambda(delta): the quasi-steady Stokes drag near the wall over 6 pi mu a V (wall_drag), with only
        the share `film` of its wall excess lambda - 1 left inside a Hertz contact (contact.ContactLaw.film)."""
        return self.wall_factor_slopes(gap, film)[0]

    def wall_factor_slopes(self, gap: float, film: float = 1.0) -> tuple[float, float, float]:
        """(wall_factor, its derivatives d/d gap [1/m] and d/d film)."""
        if not self.wall_present:
            return 1.0, 0.0, 0.0
        excess, slope = self._lambda(gap / self.diameter)
        excess -= 1.0
        return 1.0 + film * excess, film * slope / self.diameter, excess

    def drag(self, gap: float, velocity: float, film: float = 1.0, across: float = 0.0) -> float:
        """f_D = -6 pi mu a V (lambda(delta) + phi(Re) - 1) when additive, lambda(delta) phi(Re) when
        multiplicative ("schiller-naumann") [N]; only the share `film` of the wall's excess lambda - 1 is
        left inside a Hertz contact (contact.ContactLaw.film); the excess includes the liquid's tension
        limit on a sphere leaving the wall (tension_relief, drag_slopes).  Re is that of the whole speed
        |(V, across)|, `across` the velocity along the wall of an oblique collision (drag_slopes)."""
        return self.drag_slopes(gap, velocity, film, across)[0]

    def drag_slopes(self, gap: float, velocity: float, film: float = 1.0,
                    across: float = 0.0) -> tuple[float, float, float, float, float]:
        """(f_D [N], its derivatives d/d gap [N/m], d/d film [N], d/dV [N s/m] and d/d across [N s/m]).  The
        wall's excess includes the liquid's tension limit on a sphere leaving the wall (`tension_relief`), weighed
        as the lubrication is (by the share `film`, and by phi in the multiplied law).  The inertial factor phi is
        the whole speed's, Re = rho_l |u| D / mu with |u| = |(V, across)| (the free sphere's drag is
        -3 pi mu D phi(Re_|u|) u, along u: Clift, Grace & Weber 1978, ch. 5), as oblique.TangentialMotion's along
        the wall; head-on (across = 0) it is V's."""
        wall, wall_gap, wall_film = self.wall_factor_slopes(gap, film)
        speed = math.hypot(velocity, across) if across else velocity
        inertia, speed_growth = self._inertia(self.reynolds(speed))  # phi, |u| dphi/d|u|
        # V dphi/dV and dphi/d across: |u| dphi/d|u| times V^2 / |u|^2 and across / |u|^2
        inertia_growth, cross_growth = ((speed_growth * velocity**2 / speed**2, speed_growth * across / speed**2)
                                        if across else (speed_growth, 0.0))
        scale = -self.stokes_drag * velocity
        if self._additive:
            taken, taken_gap, taken_growth = (wall_screening(inertia, inertia_growth, gap / self.diameter)
                                              if self._screened else (0.0, 0.0, 0.0))
            taken_across = (wall_screening(inertia, cross_growth, gap / self.diameter)[2] if self._screened
                            and across else 0.0)  # d Delta / d across (linear in the growth)
            # the wall's take fades with its excess inside a Hertz contact (the share `film`)
            factor = wall + inertia - 1.0 - film * taken
            force, d_film = scale * factor, scale * (wall_film - taken)
            d_gap = scale * (wall_gap - film * taken_gap / self.diameter)
            d_velocity = -self.stokes_drag * (factor + inertia_growth - film * taken_growth)
            d_across = scale * (cross_growth - film * taken_across)
            weight, weight_slope, weight_across = 1.0, 0.0, 0.0
        else:
            force, d_gap, d_film = scale * (wall * inertia), scale * inertia * wall_gap, scale * inertia * wall_film
            d_velocity = -self.stokes_drag * wall * (inertia + inertia_growth)
            d_across = scale * wall * cross_growth
            weight, weight_slope, weight_across = inertia, inertia_growth / velocity if velocity else 0.0, cross_growth
        relief, relief_gap, relief_velocity = self.tension_relief(gap, velocity)
        if relief:
            force += film * weight * relief
            d_gap += film * weight * relief_gap
            d_film += weight * relief
            d_velocity += film * (weight * relief_velocity + weight_slope * relief)
            d_across += film * weight_across * relief
        return force, d_gap, d_film, d_velocity, d_across

    def free_drag(self, velocity: float, across: float = 0.0) -> float:
        """The free sphere's quasi-steady drag -6 pi mu a V phi(Re_|u|) [N] (`across`: drag_slopes); f_D less it is
        what the wall adds, the lubrication (the loss audit's term, fem_bounce.losses)."""
        speed = math.hypot(velocity, across) if across else velocity
        return -self.stokes_drag * velocity * self._inertia(self.reynolds(speed))[0]

    def tension_relief(self, gap: float, velocity: float) -> tuple[float, float, float]:
        """What the liquid's tension limit takes off the film's suction on a sphere leaving the wall at the gap
        (fem_bounce.cavitation.tension_relief: the force [N] >= 0 and its d/d gap, d/dV)."""
        if self.tension == math.inf:
            return 0.0, 0.0, 0.0
        return cavitation.tension_relief(gap, velocity, *self._film, self.tension)

    def added_mass(self, gap: float) -> tuple[float, float]:
        """(C_M m_l [kg], dC_M/dh m_l [kg/m]), C_M = (1 + 3 W) / 2.

        f_AM = -C_M m_l dV/dt - (1/2) m_l V^2 dC_M/dh: the second term is the paper's
        -(3/4) m_l V dW/dt with dW/dt = W'(delta) V / D."""
        return self.added_mass_slopes(gap)[:2]

    def added_mass_slopes(self, gap: float) -> tuple[float, float, float]:
        """(C_M m_l [kg], dC_M/dh m_l [kg/m], d2C_M/dh2 m_l [kg/m2])."""
        w, dw, d2w = self._w(gap / self.diameter, curvature=True) if self.wall_present else (0.0, 0.0, 0.0)
        m_l, length = self.displaced_mass, self.diameter
        return 0.5 * (1.0 + 3.0 * w) * m_l, 1.5 * dw / length * m_l, 1.5 * d2w / length**2 * m_l

    def added_mass_velocity_term_slopes(self, gap: float, velocity: float,
                                        added_mass: tuple | None = None) -> tuple[float, float, float]:
        """(-(1/2) m_l V^2 dC_M/dh [N], the paper's -(3/4) m_l V dW/dt; its derivatives d/d gap [N/m] and d/dV
        [N s/m]).  `added_mass`: `added_mass_slopes(gap)` when the caller has it already."""
        _, slope, curvature = added_mass or self.added_mass_slopes(gap)
        return -0.5 * velocity**2 * slope, -0.5 * velocity**2 * curvature, -velocity * slope

    def history_sensitivity(self, inertia: float, duration: float) -> np.ndarray:
        """How far an error in each history mode z_i moves the velocity, per unit of z_i [-]: its force
        c_i dz_i (c_i at the Re where the fit weighs mode i most) acting for min(T_i, duration) [s] on the
        `inertia` [kg], the sphere's mass and added mass.  Positive (a mode no Re weighs counts as 1e-30)."""
        largest = self.stokes_drag * self._weights.max(axis=0)[:self.n_history]
        return np.maximum(largest * np.minimum(self.history_times[:self.n_history], duration) / inertia, 1e-30)

    def history_coefficients(self, velocity: float) -> np.ndarray:
        """c_i = 6 pi mu a w_i(Re) [N s/m]: f_H = -K_H^(3/2) sum_i c_i z_i, z_i from the history ODEs; the wall
        factor K_H^(3/2) (contact.history_wall_factor) is the integrator's."""
        return self.stokes_drag * history_weights(self._weights, self.reynolds(velocity))

    def history_memory(self, velocity: float, modes: np.ndarray) -> tuple[float, float]:
        """(sum_i c_i z_i [N] for the history modes z, its derivative d/dV [N s/m] through w_i(Re)): two dot
        products with the fitted rows on either side of Re, no weights built."""
        row, share, rate = history_row(self.reynolds(velocity))
        if share is None:
            return self.stokes_drag * float(self._weights[row] @ modes), 0.0
        below, above = (self._weights[row:row + 2] @ modes).tolist()
        sign = 1.0 if velocity > 0.0 else -1.0 if velocity < 0.0 else 0.0
        return (self.stokes_drag * ((1.0 - share) * below + share * above),
                self.stokes_drag * (above - below) * rate * self._re_per_speed * sign)


def forces_along(scene: Scene, t: np.ndarray, gap: np.ndarray, velocity: np.ndarray,
                 acceleration: np.ndarray) -> dict[str, np.ndarray]:
    """The reduced model's liquid force terms along a given path (t [s], gap [m], V [m/s], dV/dt [m/s2]) [N]:
    `drag` (f_D, the wall's excess included), `free_drag`, `added_mass` (both its terms), `history` (K_H = 1,
    the modes integrated along the path, exact for dV/dt piecewise constant between rows) and `theory`, their
    sum.  What f_thr would be on a sphere that moved so: the force map's reduced side (benchmarks/near_wall_map.py)."""
    forces = TheoryForces(scene)
    drag = np.array([forces.drag(h, v) for h, v in zip(gap, velocity)])
    free = np.array([forces.free_drag(v) for v in velocity])
    masses = np.array([forces.added_mass_slopes(h) for h in gap])
    added = -masses[:, 0] * acceleration - 0.5 * velocity**2 * masses[:, 1]
    times = forces.history_times[:forces.n_history]
    modes, history = np.zeros_like(times), np.zeros_like(t)
    for k in range(1, len(t)):
        step = t[k] - t[k - 1]
        decay = np.exp(-step / times)
        modes = modes * decay + (velocity[k] - velocity[k - 1]) / step * times * (1.0 - decay) if step > 0 else modes
        history[k] = -forces.history_memory(velocity[k], modes)[0] if len(times) else 0.0
    return {"drag": drag, "free_drag": free, "added_mass": added, "history": history,
            "theory": drag + added + history}
