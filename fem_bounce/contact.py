"""The contact model shared by every solver (docs/physics.md sections 2-4).

Two surfaces on the axis meet: a sphere and the wall (a partner of infinite radius) or two spheres.  Both
are described by the reduced radius a*, the reduced mass m*, the reduced modulus E* and their gap h
between the undeformed surfaces; `ContactLaw` is written once for both.

- `contact.model = "lubricated-hertz"` (the default): the liquid's lubrication, Brenner's additive
  increment, is carried down to a contact gap h_c computed from the scene, not fitted: the larger of
  the surfaces' combined roughness and the elastohydrodynamic gap of Davis, Serayssol & Hinch (1986),
      x_d = (4 theta mu V a*^(3/2))^(2/5),   theta = 1 / (pi E*),
  the gap at which the film's pressure deforms the surfaces by as much as the gap (their elasticity
  parameter 4 theta mu V a*^(3/2) / h^(5/2) reaches one), V the approach speed there.  Below h_c a
  Hertz contact, its overlap x = h_c - h measured from h_c (Johnson 1985, section 4.2),
      f = (4/3) E* a*^(1/2) x^(3/2) + c sqrt(m* (4/3) E* a*^(1/2)) x^(1/4) dx/dt,   f >= 0,
  with the damping of Tsuji, Tanaka & Ishida (1992): its restitution does not depend on the impact
  speed, and c is set once so that a dry impact rebounds with contact.dry_restitution (`tsuji_damping`).
  The film cannot resist the approach once it carries the load: between h_c and h = 0 the lubrication
  (the wall's or the pair's excess over the free drag) is held at its value at h_c and faded out
  linearly in h (as Nijssen, Ottens & Padding 2022 blend lubrication into contact).  h_c is fixed for
  one contact when the gap first falls to it.
- `contact.model = "li2011"`: the paper's model as written (Li, Hunt & Colonius 2011, eq. 4.5-4.9): the
  elastic force f_ss = e_d W_o F(delta / delta_ss), W_o = (4/3) a^2 E* (5 pi rho_p V_I^2 / (4 E*))^(3/5)
  fixed at the speed V_I where the gap first falls to delta_ss D, F(x) = (exp(-x) - exp(-1)) /
  (1 - exp(-1)) on [0, 1]; the paper's blend of f_thr and f_sim, and its f_thr with the drag multiplied
  by the Schiller-Naumann factor (contact.near_wall and contact.inertial_factor "auto").  With W_o fixed
  the force depends on position only: it stores and returns energy; all dissipation is the liquid's.

- `contact.model = "ehd"` (one sphere and a wall): lubricated-hertz's liquid force (Brenner's lubrication)
  down to the handover gap h0 = contact.ehd_handover, where no Hertz contact has begun (h0 is at least
  ten elastohydrodynamic gaps); there the elastohydrodynamic film collision of Davis, Serayssol & Hinch
  (1986) (fem_bounce.ehd) takes the sphere from (h0, V_in) to (h0, e V_in) in the film's collision time,
  or to rest (`ContactLaw.collide`, the jump in integrator.BodyIntegrator).  No contact force acts in the
  integrator: the film is the contact.

Near-wall liquid force of a free sphere in a resolved flow, `contact.near_wall` (`ContactModel`):
"correction" (lubricated-hertz's default): the flow's sphere is held at the gap delta_sl D while the real
sphere goes closer, and what the held flow cannot see is added (Costa et al. 2015, with the resolved
geometry held),
    f_sl = f_sim(held at delta_sl) - 6 pi mu a V [lambda(delta) - lambda(delta_sl)]
           - m_l [C_M(delta) - C_M(delta_sl)] dV/dt - (1/2) m_l V^2 dC_M/dh,   delta < delta_sl;
"blend" (li2011's): the paper's eq. 4.5-4.6, f_sl = H f_thr + (1 - H) f_sim,
H(delta) = 1 / (1 + exp(10 (delta / delta_sl - 1))).  The ODE model uses f_thr everywhere.  Fixed and
prescribed spheres report the resolved force at their true gap (the flow solvers' validation checks).
"""
from __future__ import annotations

import functools
import math

from . import ehd
from .materials import elastohydrodynamic_gap, reduced_modulus
from .motion import is_free
from .scene import Scene
from .theory import TheoryForces

_E_INV = math.exp(-1.0)
# Beyond an overlap of a tenth of the reduced radius Hertz's small-strain contact no longer holds: a
# sphere pushed deeper has gone through the wall (or the other sphere) as far as the model can tell.
MAX_OVERLAP = 0.1
# A rebound whose apex stays below this fraction of the gap scale (D, or 2a* for a pair) never left the
# lubrication film, as a camera sees it (the paper's three contact layers, 3 delta_ss = 0.051): e = 0.
REBOUND_MIN_APEX = 0.05


BLEND_SHARPNESS = 10.0  # the paper's H = 1 / (1 + e^x), x = 10 (delta / delta_sl - 1)


def blend(delta: float, delta_sl: float) -> float:
    """H(delta / delta_sl): 1 at contact, 1/2 at delta_sl, 0 far away."""
    x = BLEND_SHARPNESS * (delta / delta_sl - 1.0)
    return 0.0 if x > 700.0 else 1.0 / (1.0 + math.exp(x))


def elastic_shape(x: float) -> float:
    """F(x) of eq. 4.9; continued past x < 0 (penetration) by the same exponential."""
    return 0.0 if x >= 1.0 else (math.exp(-x) - _E_INV) / (1.0 - _E_INV)


# -- Hertz's contact (Johnson 1985, sections 4.2 and 11.1) ----------------------------------------------


def hertz_stiffness(radius: float, e_star: float) -> float:
    """k = (4/3) E* a*^(1/2) [N/m^1.5]: f = k x^(3/2) at the overlap x."""
    return 4.0 / 3.0 * e_star * math.sqrt(radius)


def hertz_depth(radius: float, mass: float, e_star: float, speed: float) -> float:
    """x_m [m]: the deepest overlap of an elastic impact at `speed`, (15 m* V^2 / (16 E* a*^(1/2)))^(2/5)
    (the kinetic energy m* V^2 / 2 stored as (2/5) k x_m^(5/2))."""
    return (15.0 * mass * speed**2 / (16.0 * e_star * math.sqrt(radius))) ** 0.4


def hertz_peak_force(radius: float, mass: float, e_star: float, speed: float) -> float:
    """W_o [N]: the largest force of a Hertz contact of (reduced) radius `radius` [m] and (reduced) mass
    `mass` [kg] met at the relative speed `speed` [m/s].  With a* = a and m* = (4/3) pi a^3 rho_p this is
    the paper's eq. 4.7, W_o = (4/3) a^2 E* (5 pi rho_p V^2 / (4 E*))^(3/5)."""
    return hertz_stiffness(radius, e_star) * hertz_depth(radius, mass, e_star, speed)**1.5


def hertz_contact_time(radius: float, mass: float, e_star: float, speed: float) -> float:
    """Hertz's duration of a dry elastic impact, 2.94 x_m / V [s] (Johnson 1985, eq. 11.24)."""
    return 2.94 * hertz_depth(radius, mass, e_star, speed) / speed


def _damped_restitution(damping: float) -> float:
    """The restitution of x'' = -max(x^(3/2) + c x^(1/4) x', 0), x(0) = 0, x'(0) = 1: Tsuji's law in units
    where k = m = 1 and the impact speed is 1 (any other speed and stiffness scale out of it)."""
    from scipy.integrate import solve_ivp

    def rhs(t, y):
        x = max(y[0], 0.0)
        return [y[1], -max(x**1.5 + damping * x**0.25 * y[1], 0.0)]

    def separates(t, y):
        return y[0] if t > 1e-9 else 1.0
    separates.terminal, separates.direction = True, -1
    solution = solve_ivp(rhs, (0.0, 100.0), [0.0, 1.0], events=separates, rtol=1e-10, atol=1e-12, method="DOP853")
    return float(-solution.y_events[0][0][1]) if solution.t_events[0].size else 0.0


@functools.cache
def tsuji_damping(dry_restitution: float) -> float:
    """c of `_damped_restitution` that gives the dry restitution e_d (0.0218 for 0.97); e_d = 0 takes
    c = 100, a damping past which no impact rebounds (the contact then holds the sphere)."""
    from scipy.optimize import brentq

    if dry_restitution >= 1.0:
        return 0.0
    if dry_restitution <= 0.0:
        return 100.0
    return float(brentq(lambda c: _damped_restitution(c) - dry_restitution, 0.0, 100.0, xtol=1e-10))


class ContactLaw:
    """The solid contact of two surfaces on the axis (module docstring), for a reduced radius `radius`
    [m] (a for the wall), reduced mass `mass` [kg], E* `e_star` [Pa], the liquid's `viscosity` [Pa s],
    the surfaces' combined `roughness` [m], the gap scale `length` (D, or 2a* for a pair) [m] and the
    lowest gauge pressure a film holds, `cavitation_pressure` [Pa] (None: any; Scene.cavitation_pressure).

    One contact: `boundary(speed)` is the gap where it begins at the approach speed, `engage(speed)`
    the number it fixes there (W_o for li2011, h_c for lubricated-hertz), `force(gap, rate, engaged)` its
    force pushing the surfaces apart, `film(gap, engaged)` where the lubrication is evaluated and how
    much of it is left, `boundary(speed, engaged)` where it ends."""

    def __init__(self, contact, radius: float, mass: float, e_star: float, viscosity: float, roughness: float,
                 length: float, cavitation_pressure: float | None):
        self.radius, self.mass, self.e_star, self.length = radius, mass, e_star, length
        self.viscosity, self.roughness = viscosity, roughness
        self.gap_factor = contact.contact_gap_factor
        self.dry_restitution = contact.dry_restitution
        self.delta_ss = contact.delta_ss
        self.hertz = contact.model == "lubricated-hertz"
        self.ehd = contact.model == "ehd"  # the film collision at the handover gap (module docstring)
        self.handover = contact.ehd_handover
        self.cavitation = cavitation_pressure
        self.stiffness = hertz_stiffness(radius, e_star)
        self.damping = tsuji_damping(self.dry_restitution) * math.sqrt(mass * self.stiffness) if self.hertz else 0.0
        # the smallest admissible gap: the spring's own position for li2011, Hertz's small strain here
        self.floor = -MAX_OVERLAP * radius if self.hertz else 0.0
        self.rebound_apex = REBOUND_MIN_APEX * length

    def boundary(self, speed: float, engaged: float | None = None) -> float:
        """The gap [m] where a contact begins approaching at `speed` >= 0 [m/s]: h_c = max(roughness, x_d)
        (lubricated-hertz), delta_ss D (li2011) or the handover gap h0 (ehd); or where it ends (`engaged`
        given: the h_c it began at)."""
        if engaged is not None and self.hertz:
            return engaged
        if self.ehd:
            return self.handover
        if not self.hertz:
            return self.delta_ss * self.length
        return self.gap_factor * max(self.roughness,
                                     elastohydrodynamic_gap(self.radius, self.e_star, self.viscosity, speed))

    def engage(self, speed: float) -> float:
        """What one contact keeps from the speed where it began: W_o [N] (li2011) or h_c [m]."""
        if self.hertz or self.ehd:
            return self.boundary(speed)
        return hertz_peak_force(self.radius, self.mass, self.e_star, speed)

    def force(self, gap: float, rate: float, engaged: float) -> float:
        """The contact force pushing the surfaces apart [N] at the gap `gap` [m] closing at -`rate` [m/s]."""
        return self.force_slopes(gap, rate, engaged)[0]

    def force_slopes(self, gap: float, rate: float, engaged: float) -> tuple[float, float, float]:
        """(force [N], its derivatives d/d gap [N/m] and d/d rate [N s/m])."""
        if self.ehd:
            return 0.0, 0.0, 0.0  # the film collision is a jump of the state (integrator.py), not a force
        if not self.hertz:
            scale = self.delta_ss * self.length
            x = gap / scale
            if x >= 1.0:
                return 0.0, 0.0, 0.0
            push = self.dry_restitution * engaged
            return push * elastic_shape(x), -push * math.exp(-x) / ((1.0 - _E_INV) * scale), 0.0
        overlap = engaged - gap
        if overlap <= 0.0:
            return 0.0, 0.0, 0.0
        force = self.stiffness * overlap**1.5 - self.damping * overlap**0.25 * rate
        if force <= 0.0:  # held >= 0: no adhesion
            return 0.0, 0.0, 0.0
        stiffening = 1.5 * self.stiffness * overlap**0.5 - 0.25 * self.damping * overlap**-0.75 * rate
        return force, -stiffening, -self.damping * overlap**0.25

    def film(self, gap: float, engaged: float | None) -> tuple[float, float]:
        """(gap [m] at which the lubrication is evaluated, the share of it left): (gap, 1) outside a
        Hertz contact; inside, (h_c, h / h_c) down to 0 at h = 0 (module docstring)."""
        return self.film_slopes(gap, engaged)[:2]

    def film_slopes(self, gap: float, engaged: float | None) -> tuple[float, float, float, float]:
        """`film` and the derivatives of its two numbers in the gap: (gap, share, d gap, d share [1/m])."""
        if engaged is None or not self.hertz or gap >= engaged:
            return gap, 1.0, 1.0, 0.0
        if gap <= 0.0:
            return engaged, 0.0, 0.0, 0.0
        return engaged, gap / engaged, 0.0, 1.0 / engaged

    def collide(self, speed: float, mass: float, force: float = 0.0) -> "ehd.FilmResult":
        """The film collision (contact.model = "ehd") of a sphere arriving at the handover gap h0 at `speed`
        [m/s] (> 0, towards the wall) with the inertia `mass` [kg] (the sphere's mass and its added mass at
        h0), the constant `force` [N] besides the film's (positive away from the wall: minus the net
        weight), the liquid's viscosity, E* and the cavitation pressure (fem_bounce.ehd.collide;
        dimensionless result, lengths in h0, times in h0 / speed)."""
        return ehd.collide(self.radius, mass, self.e_star, self.viscosity, speed, self.handover,
                           cavitation_pressure=self.cavitation, external_force=force)

    def resting(self, gap: float, rate: float, engaged: float, mass: float, weight: float) -> bool:
        """Whether a sphere of `mass` [kg] pressed by the net `weight` [N] into this contact can no longer
        leave it: its energy measured from the static overlap x_s = (W / k)^(2/3), kinetic plus Hertz
        (2/5) k x^(5/2) less the weight's work W x, is below the 0.6 W x_s that lifting it to x = 0 costs
        (no liquid force lifts it: near the wall the liquid only resists)."""
        if not self.hertz or weight <= 0.0:
            return False
        overlap = engaged - gap
        static = (weight / self.stiffness) ** (2.0 / 3.0)

        def potential(x: float) -> float:
            return 0.4 * self.stiffness * max(x, 0.0) ** 2.5 - weight * x
        energy = 0.5 * mass * rate**2 + potential(overlap) - potential(static)
        return energy < 0.6 * weight * static

    def landing(self, speed: float, mass: float, weight: float) -> bool:
        """Whether a contact entered at `speed` [m/s] by a sphere of `mass` [kg] pressed by the net `weight`
        [N] is the sphere settling onto the wall, not an impact: its kinetic energy 1/2 m V^2 below the
        elastic energy (2/5) k x_s^(5/2) = 0.4 W x_s its weight alone stores in the static overlap
        x_s = (W / k)^(2/3), so that the contact's compression is the weight's, not the approach's.  The
        creep scale is V = (0.8 W x_s / m)^(1/2): 0.43 mm/s for Li et al.'s case 3, where a sphere settling
        through its own film under its weight reaches the contact gap at W h_c / (6 pi mu a^2) = 0.05 mm/s
        (Reynolds' film force balancing the weight) and the slowest impact before it came at 21 mm/s.
        Without weight (a pendulum's collision) every approach is an impact."""
        if not self.hertz or weight <= 0.0:
            return False
        static = (weight / self.stiffness) ** (2.0 / 3.0)
        return 0.5 * mass * speed**2 < 0.4 * weight * static


class ContactGaps:
    """The resolved flow's gaps for a length `diameter` (D at the wall, 2a* for a pair) [m]; the class
    using it sets delta_sl, diameter and `correcting` (the near-wall correction is on)."""

    @property
    def blend_gap(self) -> float:
        """delta_sl D: where the resolved flow is held (correction) or f_thr and f_sim carry equal
        weight (blend) [m]."""
        return self.delta_sl * self.diameter

    @property
    def hold_gap(self) -> float:
        """The smallest gap at which a resolved model places its flow's sphere [m]: delta_sl D under
        the correction, 0 otherwise (the ALE mesh then keeps its own numerics.ale.hold_delta)."""
        return self.blend_gap if self.correcting else 0.0


class ContactModel(ContactGaps):
    """One scene's contact with the wall: its law, the blend, the correction and the theory forces."""

    def __init__(self, scene: Scene):
        sphere, wall = scene.sphere, scene.wall
        self.delta_sl = scene.contact.delta_sl
        self.diameter = sphere.diameter
        self.e_star = reduced_modulus(sphere.youngs_modulus, sphere.poisson_ratio, wall.youngs_modulus,
                                      wall.poisson_ratio)
        self.law = ContactLaw(scene.contact, sphere.radius, sphere.mass, self.e_star, scene.liquid.viscosity,
                              sphere.roughness + wall.roughness, self.diameter, scene.cavitation_pressure)
        self.theory = TheoryForces(scene)
        # the hold and the correction belong to a free sphere's dynamics (see the module docstring)
        self.correcting = scene.near_wall_law == "correction" and is_free(scene)
        self._lambda_hold = self.theory.wall_factor(self.blend_gap)
        self._added_mass_hold = self.theory.added_mass(self.blend_gap)[0]

    def blend(self, gap: float) -> float:
        return blend(gap / self.diameter, self.delta_sl)

    def blend_slope(self, gap: float) -> tuple[float, float]:
        """(H, dH/d gap [1/m]) of the paper's blend: dH/dx = -H (1 - H) for H = 1 / (1 + e^x)."""
        weight = self.blend(gap)
        return weight, -weight * (1.0 - weight) * BLEND_SHARPNESS / self.blend_gap

    def correction(self, gap: float, velocity: float, film: float = 1.0) -> tuple[float, float]:
        """(force [N], added mass [kg]) that a flow held at delta_sl misses when the sphere is at `gap`
        (the lubrication's gap, ContactLaw.film, with the share `film` of it left): the correction is
        force - added_mass * dV/dt, zero at and above delta_sl.

        - lubrication: -6 pi mu a V [lambda(delta) - lambda(delta_sl)] (lambda by contact.wall_drag), less
          the suction the liquid cannot hold as the sphere leaves the wall (TheoryForces.tension_relief);
        - the wall's added mass grows: -[C_M(delta) - C_M(delta_sl)] m_l dV/dt;
        - the held geometry does not approach, so the force of the changing added mass,
          -(1/2) m_l V^2 dC_M/dh (the f_AM term of eq. 4.3 in V dW/dt), is absent from it."""
        return self.correction_slopes(gap, velocity, film)[:2]

    def correction_slopes(self, gap: float, velocity: float, film: float = 1.0) -> tuple[float, ...]:
        """`correction` (force [N], added mass [kg]) and its derivatives: the force's d/d gap [N/m],
        d/d film [N] and d/dV [N s/m], the added mass's d/d gap [kg/m]."""
        if not self.correcting or gap >= self.blend_gap:
            return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        theory = self.theory
        wall, wall_gap, _ = theory.wall_factor_slopes(gap)
        missed = wall - self._lambda_hold
        relief, relief_gap, relief_velocity = theory.tension_relief(gap, velocity)  # the held flow has no cavity
        lubrication = -theory.stokes_drag * velocity * film * missed + film * relief
        d_gap, d_film, d_velocity = (-theory.stokes_drag * velocity * film * wall_gap + film * relief_gap,
                                     -theory.stokes_drag * velocity * missed + relief,
                                     -theory.stokes_drag * film * missed + film * relief_velocity)
        added_mass = theory.added_mass_slopes(gap)
        c_m, c_m_slope, _ = added_mass
        if film == 1.0:  # inside a Hertz contact C_M is held at h_c: its velocity term vanishes
            term, term_gap, term_velocity = theory.added_mass_velocity_term_slopes(gap, velocity, added_mass)
            lubrication, d_gap, d_velocity = lubrication + term, d_gap + term_gap, d_velocity + term_velocity
        return lubrication, c_m - self._added_mass_hold, d_gap, d_film, d_velocity, c_m_slope
