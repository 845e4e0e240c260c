"""The elastohydrodynamic (EHD) film collision of a sphere with a wall (or a second sphere), resolved.

Davis, Serayssol & Hinch (1986, J. Fluid Mech. 163, 479-497; "DSH"): below a handover gap h0, thin
against the (reduced) radius a, the liquid between the surfaces is a lubrication film.  Its pressure
p(r, t) deforms both solids, and the deformed film decides whether the sphere sticks or rebounds.  With
r the distance from the axis, x(t) the separation of the undeformed surfaces on the axis (x < 0: they
overlap) and w(r, t) the sum of the two surfaces' normal displacements:

  Reynolds' equation (axisymmetric squeeze film, DSH eq. 2.1; e.g. Hamrock, Fundamentals of Fluid Film
  Lubrication, ch. 7):
      dh/dt = 1 / (12 mu r) d/dr (r h^3 dp/dr),      p = 0 at the grid's outer radius R_out,
      h(r, t) = x(t) + r^2 / (2 a) + w(r, t);
  the elastic half-spaces (Johnson 1985, Contact Mechanics, section 3.2: a ring load on a half-space;
  DSH eq. 2.3), theta = (1 - nu1^2) / (pi E1) + (1 - nu2^2) / (pi E2) = 1 / (pi E*):
      w(r) = 4 theta int_0^R_out p(s) s / (r + s) K(k) ds,   k^2 = 4 r s / (r + s)^2,
  K the complete elliptic integral of the first kind;
  the sphere (reduced mass m*):   m dV/dt = F = 2 pi int_0^R_out p r dr,   dx/dt = V.

Scaled with DSH's scales (gap h0, radius sqrt(a h0), time h0 / V0, pressure mu V0 a / h0^2, force
mu V0 a^2 / h0) the problem has two numbers only,
      epsilon = 4 theta mu V0 a^(3/2) / h0^(5/2)   (elasticity parameter),
      St = m V0 / (6 pi mu a^2)                    (Stokes number),
and reads  dH/dT = (1 / 12 R) d/dR (R H^3 dP/dR),  H = X + R^2 / 2 + epsilon int P S K / (R + S) dS,
dV/dT = F / (6 pi St),  F = 2 pi int P R dR.  (For a sphere on a wall St is the package's
rho_p V D / (9 mu), `Scene.stokes`.)  The gap at which epsilon evaluated with the gap itself reaches one
is x_d = (4 theta mu V a^(3/2))^(2/5) (`fem_bounce.materials.elastohydrodynamic_gap`): X_d = epsilon^(2/5).

Numerics (docs/ehd.md):
- a radial grid, uniform over the Hertz contact radius and past it (inner_factor times
  sqrt(max(x_m, x_d) a), x_m Hertz's deepest overlap at V0), then geometric out to R_out (a few
  sqrt(a h0), where the pressure of the undeformed film has fallen by (h0 / h(R_out))^2);
- Reynolds' equation in finite volumes (one control volume per node, the flux through a face with the
  mean of h^3 at its two nodes: conservative, so the film's volume balance holds to round-off);
- the kernel applied to a piecewise-linear pressure, integrated once per grid into a dense matrix
  (Gauss-Legendre on every element; on the two elements that touch the target node, where K has its
  logarithmic singularity, a cubic grading of the points clusters them at the singular end), so the
  deformation is one matrix-vector product;
- the pressures, x and V advanced together by the variable-step BDF2 (Hairer & Wanner, Solving ODEs II,
  section III.5 / VI.1: an index-1 DAE with the kernel as a mass matrix: the rigid limit is the algebraic
  quasi-steady film), Newton's method with the exact Jacobian, factorised once a step and reused
  (simplified Newton); the step is chosen from the difference between the corrector and the quadratic
  predictor on x, V and the gap at every node (relative), the usual local-error control.

Optional, off by default:
- a cavitation limit, p >= p_cav (p_cav gauge, e.g. minus the ambient pressure; Barnocky & Davis 1989
  and Joseph et al. 2001 discuss where the film's tension on rebound is limited): where the pressure
  would fall below p_cav it is held there and the film there no longer obeys Reynolds' equation (the
  Swift-Stieber / Reynolds cavitation condition as a complementarity problem, solved by semi-smooth
  Newton);
- a pressure-dependent viscosity is NOT implemented: the Barus coefficient of glycerol-water mixtures
  could not be taken from a measurement we could read (docs/ehd.md).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.linalg import lu_factor, lu_solve
from scipy.special import ellipkm1

HERTZ_DEPTH_FACTOR = 90.0 * math.pi**2 / 64.0  # (x_m / h0)^(5/2) = this * St * epsilon (module docstring)


class FilmError(ValueError):
    """A film collision's input out of range, or a step the solver could not take."""


# -- the dimensionless groups ---------------------------------------------------------------------------


def elasticity_parameter(radius: float, e_star: float, viscosity: float, speed: float, gap: float) -> float:
    """DSH's epsilon = 4 theta mu V a^(3/2) / h0^(5/2), theta = 1 / (pi E*) (dimensionless)."""
    return 4.0 * viscosity * abs(speed) * radius**1.5 / (math.pi * e_star * gap**2.5)


def film_stokes(mass: float, radius: float, viscosity: float, speed: float) -> float:
    """DSH's St = m V / (6 pi mu a^2): for a sphere on a wall the package's rho_p V D / (9 mu)."""
    return mass * abs(speed) / (6.0 * math.pi * viscosity * radius**2)


def hertz_depth_scaled(stokes: float, epsilon: float) -> float:
    """Hertz's deepest overlap of a dry impact at V0, in units of h0: (90 pi^2 St epsilon / 64)^(2/5)
    (`fem_bounce.contact.hertz_depth` written in DSH's groups)."""
    return (HERTZ_DEPTH_FACTOR * stokes * epsilon) ** 0.4


def hertz_contact_time_scaled(stokes: float, epsilon: float) -> float:
    """Hertz's contact time 2.94 x_m / V0 (Johnson 1985, eq. 11.24) in units of h0 / V0."""
    return 2.94 * hertz_depth_scaled(stokes, epsilon)


# -- the grid and the elastic kernel --------------------------------------------------------------------


@dataclass(frozen=True)
class RadialGrid:
    """Nodes R_0 = 0 < ... < R_N = R_out (units sqrt(a h0)); node N holds p = 0."""

    nodes: np.ndarray

    @property
    def faces(self) -> np.ndarray:
        """R_{i+1/2}, i = 0..N-1: the control volumes' outer faces."""
        return 0.5 * (self.nodes[1:] + self.nodes[:-1])

    @property
    def areas(self) -> np.ndarray:
        """int R dR over the control volume of nodes 0..N-1 (per radian)."""
        outer = self.faces
        inner = np.concatenate([[0.0], outer[:-1]])
        return 0.5 * (outer**2 - inner**2)


def radial_grid(inner_radius: float, outer_radius: float, inner_cells: int, outer_cells: int) -> RadialGrid:
    """Uniform cells on [0, inner_radius], then `outer_cells` cells growing geometrically from the inner
    spacing to outer_radius."""
    if not 0.0 < inner_radius < outer_radius:
        raise FilmError(f"inner_radius = {inner_radius:g} is out of range: allowed in (0, outer_radius = "
                        f"{outer_radius:g})")
    if inner_cells < 4 or outer_cells < 4:
        raise FilmError(f"inner_cells = {inner_cells}, outer_cells = {outer_cells}: allowed >= 4 each")
    inner = np.linspace(0.0, inner_radius, inner_cells + 1)
    spacing = inner_radius / inner_cells
    span = outer_radius - inner_radius
    if span <= spacing * outer_cells:  # no growth needed
        outer = np.linspace(inner_radius, outer_radius, outer_cells + 1)[1:]
    else:
        # spacing (q + q^2 + ... + q^n) = span: bisection on the ratio q > 1
        lo, hi = 1.0, 2.0
        while spacing * sum(hi**k for k in range(1, outer_cells + 1)) < span:
            hi *= 2.0
        for _ in range(200):
            q = 0.5 * (lo + hi)
            if spacing * (q ** (outer_cells + 1) - q) / (q - 1.0) < span:
                lo = q
            else:
                hi = q
        steps = spacing * q ** np.arange(1, outer_cells + 1)
        outer = inner_radius + np.cumsum(steps)
        outer[-1] = outer_radius
    return RadialGrid(np.concatenate([inner, outer]))


def _gauss(points: int) -> tuple[np.ndarray, np.ndarray]:
    t, w = np.polynomial.legendre.leggauss(points)
    return 0.5 * (t + 1.0), 0.5 * w  # on [0, 1]


def _ring_kernel(target: np.ndarray, source: np.ndarray) -> np.ndarray:
    """s / (r + s) K(k), k^2 = 4 r s / (r + s)^2: the displacement at r of a unit ring pressure at s
    (Johnson 1985, section 3.2), divided by 4 theta.  K from its complement 1 - k^2 = ((r - s)/(r + s))^2,
    exact near the logarithmic singularity r = s."""
    total = target + source
    complement = ((target - source) / total) ** 2
    return source / total * ellipkm1(complement)


def elastic_kernel(grid: RadialGrid, points: int = 16, singular_points: int = 24) -> np.ndarray:
    """M[i, j] = int phi_j(S) S / (R_i + S) K(k) dS for every node i (0..N) and the hat functions phi_j of
    the nodes j = 0..N-1 (node N holds p = 0), so that the deformation is w / h0 = epsilon M P."""
    r = grid.nodes
    n = r.size - 1  # elements
    lengths = np.diff(r)
    t, wt = _gauss(points)
    s = r[:-1, None] + lengths[:, None] * t[None, :]  # (element, point)
    kern = _ring_kernel(r[:, None, None], s[None, :, :])  # (target, element, point)
    weights = lengths[:, None] * wt[None, :]
    left = np.einsum("iep,ep->ie", kern, weights * (1.0 - t)[None, :])  # hat of the element's left node
    right = np.einsum("iep,ep->ie", kern, weights * t[None, :])
    # the two elements that touch node i: the log singularity at one end, cubic grading towards it
    ts, ws = _gauss(singular_points)
    grade, dgrade = ts**3, 3.0 * ts**2
    for i in range(r.size):
        for e, at_left in ((i, True), (i - 1, False)):
            if e < 0 or e >= n:
                continue
            u = grade if at_left else 1.0 - grade  # position in the element, clustered at node i
            ss = r[e] + lengths[e] * u
            k = _ring_kernel(np.array(r[i]), ss) * lengths[e] * ws * dgrade
            left[i, e] = np.sum(k * (1.0 - u))
            right[i, e] = np.sum(k * u)
    matrix = np.zeros((r.size, n))
    matrix[:, :n] += left  # node e is the left end of element e
    matrix[:, 1:] += right[:, :-1]  # node e+1 is the right end of element e (node N dropped)
    return matrix


# -- the collision --------------------------------------------------------------------------------------


@dataclass(frozen=True)
class FilmSettings:
    """The numerics of one film collision (dimensionless; module docstring)."""

    inner_cells: int = 120
    outer_cells: int = 60
    inner_factor: float = 2.0  # the uniform region's radius over sqrt(max(x_m, x_d) / h0)
    outer_radius: float = 8.0  # R_out in sqrt(a h0): h(R_out) = h0 + 32 h0 at the start
    tolerance: float = 2.5e-4  # relative local error per step (x, V and the gap at every node)
    first_step: float = 1e-4
    max_steps: int = 200_000
    rebound_speed: float = 1e-3  # V / V0 above which the sphere moves away: below it, the integrator's creep
    stop_speed: float = 1e-6  # |V| / V0 (and |dV/dT|) below which an approaching sphere has stopped
    max_time: float = 1e4  # in h0 / V0


@dataclass
class FilmResult:
    """One film collision (dimensionless, units h0, sqrt(a h0), h0 / V0, mu V0 a / h0^2)."""

    epsilon: float
    stokes: float
    restitution: float  # V_out / V0 at X = 1 (0 when the sphere stopped or was held)
    outcome: str  # "rebound", "stopped" (no rebound), "held" (turned back and recaptured), "time"
    steps: int
    min_gap: float  # the smallest film thickness anywhere, over the collision
    max_pressure: float
    min_pressure: float  # the lowest (most negative) film pressure, over the collision
    contact_time: float | None  # how long the undeformed surfaces overlap (X < 0)
    time: np.ndarray = field(repr=False)
    separation: np.ndarray = field(repr=False)  # X
    velocity: np.ndarray = field(repr=False)  # V (negative towards the wall)
    force: np.ndarray = field(repr=False)
    central_gap: np.ndarray = field(repr=False)  # H(0)
    smallest_gap: np.ndarray = field(repr=False)  # min_R H
    radius: np.ndarray = field(repr=False)
    snapshots: list = field(default_factory=list, repr=False)  # (T, P, H) at snapshot_times
    end_time: float = 0.0  # when the outcome was reached: the return to X = 1 (interpolated) for a rebound


class FilmCollision:
    """The film collision in DSH's groups `epsilon` and `stokes` (module docstring).

    `prescribed_speed`: instead of a free sphere, the surfaces approach at the constant speed V0 (the
    rigid-limit check of Reynolds' force); `external_force`: a constant force on the sphere besides the
    film's, in mu V0 a^2 / h0, positive away from the wall (a net weight inside a run: negative);
    `cavitation_pressure`: the lowest pressure the film holds,
    in mu V0 a / h0^2 (None: no limit)."""

    def __init__(self, epsilon: float, stokes: float, settings: FilmSettings = FilmSettings(),
                 cavitation_pressure: float | None = None, prescribed_speed: bool = False,
                 external_force: float = 0.0):
        if not (epsilon >= 0.0 and math.isfinite(epsilon)):
            raise FilmError(f"epsilon = {epsilon!r} is out of range: allowed >= 0 and finite")
        if not (stokes > 0.0 and math.isfinite(stokes)):
            raise FilmError(f"stokes = {stokes!r} is out of range: allowed > 0 and finite")
        if cavitation_pressure is not None and not cavitation_pressure <= 0.0:
            raise FilmError(f"cavitation_pressure = {cavitation_pressure!r} is out of range: allowed <= 0 "
                            "(gauge) or None")
        self.epsilon, self.stokes, self.settings = epsilon, stokes, settings
        self.cavitation = cavitation_pressure
        self.prescribed = prescribed_speed
        if not math.isfinite(external_force):
            raise FilmError(f"external_force = {external_force!r} is out of range: allowed finite")
        self.external = external_force
        s = settings
        scale = max(hertz_depth_scaled(stokes, epsilon), epsilon**0.4, 2e-3)
        inner = min(s.inner_factor * math.sqrt(scale), 0.5 * s.outer_radius)
        self.grid = radial_grid(inner, s.outer_radius, s.inner_cells, s.outer_cells)
        r = self.grid.nodes
        self.n = r.size - 1  # pressure unknowns: nodes 0..N-1
        self.areas = self.grid.areas
        faces = self.grid.faces
        self.conductance = faces / np.diff(r)  # R_{i+1/2} / (R_{i+1} - R_i)
        self.shape = 0.5 * r**2
        self.kernel = epsilon * elastic_kernel(self.grid) if epsilon > 0 else np.zeros((r.size, self.n))

    # the state: P (nodes 0..N-1), X, V
    def gap(self, pressure: np.ndarray, separation: float) -> np.ndarray:
        """H at nodes 0..N."""
        return separation + self.shape + self.kernel @ pressure

    def force(self, pressure: np.ndarray) -> float:
        """F = 2 pi int P R dR (units mu V0 a^2 / h0)."""
        return 2.0 * math.pi * float(self.areas @ pressure)

    def _flux_divergence(self, pressure: np.ndarray, gap: np.ndarray):
        """(1/12) [R H^3 dP/dR] across each control volume, and its derivatives: with respect to P
        (tridiagonal: lower, diag, upper) and to H (nodes i-1, i, i+1 of row i)."""
        p = np.concatenate([pressure, [0.0]])
        cube = gap**3
        mean = 0.5 * (cube[:-1] + cube[1:])  # at faces i+1/2, i = 0..N-1
        dp = p[1:] - p[:-1]
        flux = self.conductance * mean * dp / 12.0  # through face i+1/2
        div = flux.copy()
        div[1:] -= flux[:-1]
        c = self.conductance / 12.0
        # d flux_{i+1/2} / d P_i = -c mean, / d P_{i+1} = +c mean
        diag = -c * mean
        diag[1:] -= c[:-1] * mean[:-1]
        upper = c[:-1] * mean[:-1]  # row i, column i+1
        lower = c[:-1] * mean[:-1]  # row i+1, column i
        # d flux_{i+1/2} / d H_i = c dp 1.5 H_i^2 and the same for H_{i+1}
        dflux_left = c * dp * 1.5 * gap[:-1] ** 2
        dflux_right = c * dp * 1.5 * gap[1:] ** 2
        dh_self = dflux_left.copy()
        dh_self[1:] -= dflux_right[:-1]
        dh_next = dflux_right  # row i, H_{i+1}
        dh_prev = np.zeros(self.n)
        dh_prev[1:] = -dflux_left[:-1]  # row i, H_{i-1}
        return div, (lower, diag, upper), (dh_prev, dh_self, dh_next)

    def _residual_and_jacobian(self, z, history, coefficients, dt, jacobian=True):
        n = self.n
        pressure, separation, velocity = z[:n], z[n], z[n + 1]
        a0, a1, a2 = coefficients
        gap = self.gap(pressure, separation)
        if np.any(gap <= 0.0):
            raise FilmError("the film closed (h <= 0): the step was too long")
        (h1, x1, v1), (h2, x2, v2) = history
        rate = (a0 * gap[:n] + a1 * h1[:n] + a2 * h2[:n]) / dt
        div, (lower, diag, upper), (dprev, dself, dnext) = self._flux_divergence(pressure, gap)
        film = self.areas * rate - div
        res = np.empty(n + 2)
        res[:n] = film
        res[n] = (a0 * separation + a1 * x1 + a2 * x2) / dt - velocity
        if self.prescribed:
            res[n + 1] = velocity + 1.0
        else:
            res[n + 1] = ((a0 * velocity + a1 * v1 + a2 * v2) / dt
                          - (self.force(pressure) + self.external) / (6.0 * math.pi * self.stokes))
        if not jacobian:
            return res, gap, film
        jac = np.zeros((n + 2, n + 2))
        k = self.kernel
        # d film / d H (through H = X + shape + K P): areas a0/dt - d div / d H, a band on H's nodes
        band_self = self.areas * a0 / dt - dself
        jp = band_self[:, None] * k[:n]
        jp[1:] -= dprev[1:, None] * k[:n - 1]
        jp -= dnext[:, None] * k[1:n + 1]
        idx = np.arange(n)
        jp[idx, idx] -= diag
        jp[idx[:-1], idx[:-1] + 1] -= upper
        jp[idx[:-1] + 1, idx[:-1]] -= lower
        jac[:n, :n] = jp
        jac[:n, n] = band_self - dprev - dnext  # d/dX, H_k all move with X
        jac[n, n], jac[n, n + 1] = a0 / dt, -1.0
        if self.prescribed:
            jac[n + 1, n + 1] = 1.0
        else:
            jac[n + 1, :n] = -2.0 * math.pi * self.areas / (6.0 * math.pi * self.stokes)
            jac[n + 1, n + 1] = a0 / dt
        return res, gap, film, jac

    def _cavitate(self, res, jac, z, film):
        """Reynolds' cavitation condition as min(P - P_cav, film / area) = 0 (complementarity)."""
        n = self.n
        slack = z[:n] - self.cavitation
        scaled = film / self.areas
        held = slack < scaled
        res = res.copy()
        res[:n][held] = slack[held]
        if jac is not None:
            jac = jac.copy()
            rows = np.flatnonzero(held)
            jac[rows, :] = 0.0
            jac[rows, rows] = 1.0
        return res, jac, held

    def rigid_film(self, separation: float, velocity: float, iterations: int = 100) -> np.ndarray:
        """The pressure (nodes 0..N-1) of the quasi-steady film between rigid surfaces (the kernel left out)
        at the separation X, the gap changing at the rate V (units h0, h0 / V0; V > 0: opening): the film's
        volume balance div = area V, with the cavitation limit as in a collision (semi-smooth Newton on the
        complementarity of `_cavitate`; the set of held nodes settles in a few steps).  The closed form
        it checks: fem_bounce.cavitation (tests/test_cavitation.py)."""
        n = self.n
        gap = separation + self.shape
        pressure = np.zeros(n)
        for _ in range(iterations):
            div, (lower, diag, upper), _ = self._flux_divergence(pressure, gap)
            film = self.areas * velocity - div
            jac = -(np.diag(diag) + np.diag(upper, 1) + np.diag(lower, -1))
            res = film
            if self.cavitation is not None:
                z = np.concatenate([pressure, [separation, velocity]])
                full = np.zeros((n + 2, n + 2))
                full[:n, :n] = jac
                res, full, _ = self._cavitate(np.concatenate([film, [0.0, 0.0]]), full, z, film)
                res, jac = res[:n], full[:n, :n]
            step = np.linalg.solve(jac, -res)
            pressure = pressure + step
            if np.max(np.abs(step)) <= 1e-12 * max(np.max(np.abs(pressure)), 1.0):
                return pressure
        raise FilmError(f"the rigid film at X = {separation:g}, V = {velocity:g} did not settle in {iterations} "
                        "Newton steps")

    def initial_pressure(self) -> np.ndarray:
        """The quasi-steady film of the undeformed surfaces at X = 1 approaching at V0: div = -area."""
        gap0 = 1.0 + self.shape
        _, (lower, diag, upper), _ = self._flux_divergence(np.zeros(self.n), gap0)
        a = np.diag(diag) + np.diag(upper, 1) + np.diag(lower, -1)
        return np.linalg.solve(a, -self.areas)

    def run(self, snapshot_times=(), end_separation: float | None = None) -> FilmResult:
        """From X = 1, V = -1 through the collision until the sphere is back at X = 1 (e = V there), stops,
        or (prescribed speed) X reaches `end_separation`.  At the first accepted step at or after each of
        `snapshot_times` (T) the film is kept in result.snapshots as (T, P at nodes 0..N-1, H at nodes 0..N);
        X at that T is result.separation where result.time equals it, the deformation H - X - R^2 / 2."""
        s, n = self.settings, self.n
        z = np.concatenate([self.initial_pressure(), [1.0, -1.0]])
        gap = self.gap(z[:n], 1.0)
        past = [(0.0, z.copy(), gap)]  # (T, z, H)
        t, dt, steps = 0.0, s.first_step, 0
        record = {k: [] for k in ("t", "x", "v", "f", "h0", "hmin")}
        min_gap, max_pressure, min_pressure = float(gap.min()), float(z[:n].max()), float(z[:n].min())
        overlap_start = overlap_end = None
        rebounded, outcome, restitution, end_time = False, "time", 0.0, None
        snapshots, pending = [], sorted(snapshot_times)

        def keep(tt, zz, hh):
            record["t"].append(tt), record["x"].append(zz[n]), record["v"].append(zz[n + 1])
            record["f"].append(self.force(zz[:n])), record["h0"].append(hh[0]), record["hmin"].append(hh.min())
        keep(0.0, z, gap)
        while steps < s.max_steps:
            steps += 1
            if len(past) == 1:
                coefficients = (1.0, -1.0, 0.0)
                history = ((past[-1][2], past[-1][1][n], past[-1][1][n + 1]),) * 2
                predicted = past[-1][1].copy()
            else:
                (t1, z1, h1), (t2, z2, h2) = past[-1], past[-2]
                w = dt / (t1 - t2)
                coefficients = ((1 + 2 * w) / (1 + w), -(1 + w), w * w / (1 + w))
                history = ((h1, z1[n], z1[n + 1]), (h2, z2[n], z2[n + 1]))
                predicted = z1 + w * (z1 - z2)
                if len(past) >= 3:  # quadratic extrapolation through the last three
                    t3, z3, _ = past[-3]
                    tn = t1 + dt
                    l1 = (tn - t2) * (tn - t3) / ((t1 - t2) * (t1 - t3))
                    l2 = (tn - t1) * (tn - t3) / ((t2 - t1) * (t2 - t3))
                    l3 = (tn - t1) * (tn - t2) / ((t3 - t1) * (t3 - t2))
                    predicted = l1 * z1 + l2 * z2 + l3 * z3
            guess = predicted if np.all(self.gap(predicted[:n], predicted[n]) > 0.0) else past[-1][1]
            try:
                znew, gnew = self._newton(guess, history, coefficients, dt)
            except FilmError as err:
                dt *= 0.25
                if dt < 1e-12 * max(t, 1.0):
                    raise FilmError(f"the film collision (epsilon = {self.epsilon:g}, St = {self.stokes:g}) "
                                    f"could not step on at T = {t:g}") from err
                continue
            # local error: corrector against predictor, on X, V and the gap at every node
            if len(past) >= 3:
                hpred = self.gap(predicted[:n], predicted[n])
                scale_x = max(abs(znew[n]), gnew.min(), 1e-12)
                errs = [abs(znew[n] - predicted[n]) / scale_x, abs(znew[n + 1] - predicted[n + 1]),
                        float(np.max(np.abs(gnew - hpred) / gnew))]
                err = 0.2 * max(errs) / s.tolerance
            else:
                err = 0.5
            if err > 1.0:
                dt *= max(0.2, 0.9 * err ** (-1.0 / 3.0))
                if dt < 1e-12 * max(t, 1.0):
                    raise FilmError(f"the film collision (epsilon = {self.epsilon:g}, St = {self.stokes:g}) "
                                    f"needs steps below 1e-12 at T = {t:g}: the grid does not resolve the film")
                continue
            t += dt
            past.append((t, znew, gnew))
            past = past[-3:]
            z, gap = znew, gnew
            keep(t, z, gap)
            min_gap, max_pressure = min(min_gap, float(gap.min())), max(max_pressure, float(z[:n].max()))
            min_pressure = min(min_pressure, float(z[:n].min()))
            while pending and pending[0] <= t:
                snapshots.append((t, z[:n].copy(), gap.copy()))
                pending.pop(0)
            x, v = z[n], z[n + 1]
            xs = record["x"]
            if overlap_start is None and x < 0.0:
                overlap_start = _cross(record["t"][-2], xs[-2], t, x)
            if overlap_start is not None and overlap_end is None and x >= 0.0 and xs[-2] < 0.0:
                overlap_end = _cross(record["t"][-2], xs[-2], t, x)
            if self.prescribed:
                if end_separation is not None and x <= end_separation:
                    outcome = "reached"
                    break
            else:
                accel = (v - record["v"][-2]) / dt
                if not rebounded and abs(v) < s.stop_speed and abs(accel) < s.stop_speed:
                    outcome = "stopped"  # at rest in the film, nothing left to push it back
                    break
                if v > s.rebound_speed:
                    rebounded = True
                if rebounded and x >= 1.0:
                    frac = (1.0 - xs[-2]) / (x - xs[-2])
                    restitution = record["v"][-2] + frac * (v - record["v"][-2])
                    end_time = record["t"][-2] + frac * (t - record["t"][-2])
                    outcome = "rebound"
                    break
                if rebounded and v <= 0.0:
                    outcome = "held"
                    break
            if t > s.max_time:
                break
            dt *= min(2.0, max(0.2, 0.9 * max(err, 1e-6) ** (-1.0 / 3.0)))
        contact = (overlap_end - overlap_start) if overlap_start is not None and overlap_end is not None else None
        arrays = {k: np.array(v) for k, v in record.items()}
        return FilmResult(self.epsilon, self.stokes, restitution, outcome, steps, min_gap, max_pressure, min_pressure,
                          contact,
                          arrays["t"], arrays["x"], arrays["v"], arrays["f"], arrays["h0"], arrays["hmin"],
                          self.grid.nodes, snapshots, t if end_time is None else end_time)

    def _newton(self, guess, history, coefficients, dt, iterations: int = 12):
        """Simplified Newton: the Jacobian factorised at the first iterate (and again if it stalls, or, with
        the cavitation limit, when the set of held nodes changes: the factors of another active set are
        the Jacobian of another equation, and reusing them cycled: 7579 failed solves and 218 s for one
        case-7 collision at 0.2983 m/s with p_cav = -1 atm, against 1378 steps and 8 s at 0.298267 m/s)."""
        z = guess.copy()
        n = self.n
        lu, last, factored = None, math.inf, None
        for it in range(iterations):
            if lu is not None:
                res, gap, film = self._residual_and_jacobian(z, history, coefficients, dt, jacobian=False)
                if self.cavitation is not None:
                    res, _, held = self._cavitate(res, None, z, film)
                    if not np.array_equal(held, factored):
                        lu = None
            if lu is None:
                res, gap, film, jac = self._residual_and_jacobian(z, history, coefficients, dt)
                if self.cavitation is not None:
                    res, jac, factored = self._cavitate(res, jac, z, film)
                lu = lu_factor(jac)
            step = lu_solve(lu, -res)
            # keep the film open: shorten a step that would close it
            new = z + step
            for _ in range(30):
                if np.all(self.gap(new[:n], new[n]) > 0.0):
                    break
                step *= 0.5
                new = z + step
            else:
                raise FilmError("Newton's step closes the film")
            z = new
            size = max(float(np.max(np.abs(step[:n]))) / (1.0 + float(np.max(np.abs(z[:n])))),
                       abs(step[n]) / max(abs(z[n]), 1e-3 * self.settings.tolerance),
                       abs(step[n + 1]))
            if size < 1e-9 or (it > 0 and size < 1e-3 * self.settings.tolerance):
                return z, self.gap(z[:n], z[n])
            if it > 0 and size > 0.5 * last:  # slow: a fresh Jacobian
                lu = None
            last = size
        raise FilmError("Newton did not converge")


def _cross(t0, x0, t1, x1):
    """The time at which a linear x(t) between (t0, x0) and (t1, x1) is zero."""
    return t0 + (t1 - t0) * x0 / (x0 - x1) if x1 != x0 else t1


# -- a collision in SI units ----------------------------------------------------------------------------


def collide(radius: float, mass: float, e_star: float, viscosity: float, speed: float, handover_gap: float,
            settings: FilmSettings = FilmSettings(), cavitation_pressure: float | None = None,
            external_force: float = 0.0, snapshot_times=()) -> FilmResult:
    """The film collision of a sphere of reduced `radius` [m] and `mass` [kg] arriving at `speed` [m/s]
    (> 0, towards the wall) at the gap `handover_gap` h0 [m] through a liquid of `viscosity` [Pa s] with
    the solids' reduced modulus `e_star` [Pa]; `cavitation_pressure` [Pa, gauge, <= 0] or None;
    `external_force` [N] a constant force on the sphere besides the film's, positive away from the wall
    (the net weight inside a run, negative); `snapshot_times` (in h0 / speed) the instants at which the film
    is kept in result.snapshots (the first accepted step at or after each; FilmCollision.run), which changes
    no number.  The result is dimensionless (units in FilmResult); e = result.restitution."""
    for name, value in (("radius", radius), ("mass", mass), ("e_star", e_star), ("viscosity", viscosity),
                        ("speed", speed), ("handover_gap", handover_gap)):
        if not (value > 0.0 and math.isfinite(value)):
            raise FilmError(f"{name} = {value!r} is out of range: allowed > 0 and finite")
    if handover_gap >= 0.1 * radius:
        raise FilmError(f"handover_gap = {handover_gap:g} m is out of range: allowed < 0.1 * radius = "
                        f"{0.1 * radius:g} m (the film must be thin for Reynolds' equation)")
    epsilon = elasticity_parameter(radius, e_star, viscosity, speed, handover_gap)
    stokes = film_stokes(mass, radius, viscosity, speed)
    pressure_scale = viscosity * speed * radius / handover_gap**2
    cavitation = None if cavitation_pressure is None else cavitation_pressure / pressure_scale
    force_scale = viscosity * speed * radius**2 / handover_gap
    collision = FilmCollision(epsilon, stokes, settings, cavitation, external_force=external_force / force_scale)
    return collision.run(snapshot_times)
