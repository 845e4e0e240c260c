"""The contact model of a head-on pair of spheres on the axis (docs/physics.md section 6).

The wall's contact law (contact.ContactLaw, written once) with the pair's quantities: the reduced
radius a* = a1 a2 / (a1 + a2), the reduced mass m* = m1 m2 / (m1 + m2) (m* = m1 when the second sphere
is held or prescribed, which no force moves), E* of the two materials, the two surfaces' combined
roughness, and the gap h between the two surfaces scaled by the reduced diameter, delta = h / (2 a*)
(scene.pair_diameter).  For a2 -> infinity and m2 -> infinity every formula here becomes the wall's.

- Contact force: the damped Hertz contact below the pair's contact gap h_c (lubricated-hertz), or the
  paper's spring e_d W_o F(delta / delta_ss) with Hertz's peak force for two spheres (li2011; Johnson
  1985, section 11.1), pushing the spheres apart.
- Liquid force of the pair in Stokes flow: F_i = -6 pi mu a_i sum_j X_ij(h) U_j, with the exact two-sphere
  resistance X (fem_bounce.pair_theory: Stimson & Jeffery 1926, Cooley & O'Neill 1969, Jeffrey 1982;
  docs/pair_theory.md).  Its excess over each sphere's isolated Stokes drag, -6 pi mu a_i sum_j
  (X_ij - delta_ij) U_j, is the pair interaction, added to each sphere's own drag as the wall's excess
  is (`contact.inertial_factor = "additive"`, docs/physics.md 3.2): the interaction is viscous at the gap
  Reynolds numbers where it is large.
- A resolved flow's correction (contact.near_wall = "correction"): the flow holds the pair gap at
  delta_sl 2a* and the increment the held flow misses, -6 pi mu a_i sum_j [X_ij(h) - X_ij(delta_sl 2a*)] U_j,
  is added below it; exact in steady Stokes flow, as at the wall.  The pair's added-mass increment is not
  added to a resolved flow (its flow carries the pair's added mass down to the hold).
- The pair's added mass in potential flow (ODE model): the kinetic energy T = (1/2) V^T M(h) V of the
  liquid, M_ij = m_l,i C_ij(h) (pair_theory.added_mass_series: the image series of Hicks 1880 and Lamb 1932,
  section 98), gives by Lagrange's equations F_i = -d/dt(sum_j M_ij V_j) + dT/dz_i; the isolated
  spheres' m_l,i / 2 stay in each sphere's own C_M (theory.py), this model gives the rest.
"""
from __future__ import annotations

import math

import numpy as np

from . import cavitation
from .bodies import scene_bodies
from .contact import ContactGaps, ContactLaw
from .materials import reduced_modulus
from .pair_theory import PairAddedMass, PairResistance
from .scene import Scene, reduced_radius

# Trial states of an implicit step may close the pair gap; real penetration is an event of the integrator.
MIN_PAIR_DELTA = 1e-12


class PairContactModel(ContactGaps):
    """One pair scene's contact model: the pair's gap scales, its elastic force, its liquid interaction
    in Stokes flow and a resolved flow's correction (module docstring)."""

    def __init__(self, scene: Scene, resolved: bool = False, lower: int = 0):
        """The contact between the scene's bodies `lower` and `lower + 1` (0: sphere 1 and the second
        sphere; fem_bounce.bodies)."""
        bodies = scene_bodies(scene)[lower:lower + 2]
        first, second = (body.sphere for body in bodies)
        c = scene.contact
        self.delta_sl = c.delta_sl
        self.radii = np.array([first.radius, second.radius])
        self.diameter = 2.0 * reduced_radius(first.radius, second.radius)  # 2 a*: the pair's gap scale [m]
        self.reduced_radius = 0.5 * self.diameter
        free = tuple(body.free for body in bodies)
        if all(free) or not any(free):
            self.reduced_mass = first.mass * second.mass / (first.mass + second.mass)
        else:  # a held or prescribed sphere is infinitely heavy to the collision
            self.reduced_mass = first.mass if free[0] else second.mass
        self.e_star = reduced_modulus(first.youngs_modulus, first.poisson_ratio, second.youngs_modulus,
                                      second.poisson_ratio)
        self.law = ContactLaw(c, self.reduced_radius, self.reduced_mass, self.e_star, scene.liquid.viscosity,
                              first.roughness + second.roughness, self.diameter, scene.cavitation_pressure)
        mu = scene.liquid.viscosity
        self._stokes_drags = (6.0 * math.pi * mu * first.radius, 6.0 * math.pi * mu * second.radius)  # [N s/m]
        self._liquid = scene.liquid
        floor = scene.cavitation_pressure  # the most tension the film between the two holds [Pa]
        self.tension = math.inf if floor is None else -floor
        # the hold and the correction belong to a resolved flow with a free sphere (as at the wall)
        self.correcting = resolved and scene.near_wall_law == "correction" and any(free)
        self._resistance = PairResistance(first.radius, second.radius)  # tabulated once, ~3 us a call
        self._resistance_hold = self.resistance(self.blend_gap).ravel().tolist()  # X_ij at the hold: 11, 12, 21, 22
        self._added_mass = PairAddedMass(first.radius, second.radius)  # tabulated once, microseconds a call
        self.displaced_masses = np.array([body.displaced_mass for body in bodies])  # m_l,i [kg]
        self._displaced_masses = tuple(self.displaced_masses.tolist())

    # -- the collision's numbers ---------------------------------------------------------------------
    def numbers(self, speed: float) -> tuple[float, float]:
        """(Re, St) of the relative speed V [m/s]: Re = rho_l V 2a* / mu (a2 -> infinity gives the wall's Re on
        D) and the binary Stokes number St = m* V / (6 pi mu a*^2), Yang & Hunt's (2006) name; their exact
        definition could not be read (docs/physics.md section 6 gives the conversions); a2 -> infinity gives
        the wall's (1/9) (rho_p / rho_l) Re."""
        speed, liquid = abs(speed), self._liquid
        return (liquid.density * self.diameter * speed / liquid.viscosity,
                self.reduced_mass * speed / (6.0 * math.pi * liquid.viscosity * self.reduced_radius**2))

    # -- forces ----------------------------------------------------------------------------------------
    # Each force on the (lower, upper) sphere comes as `*_slopes` with its derivatives in the pair gap, the
    # share `film` of it left inside a Hertz contact and the two velocities (V1, V2), plain floats: the
    # integrator's exact Jacobian is built from them (tests/test_jacobian.py).

    def resistance(self, gap: float) -> np.ndarray:
        """X(h): F_i = -6 pi mu a_i sum_j X_ij U_j in Stokes flow, at the pair gap h [m]."""
        return self._resistance(max(gap, MIN_PAIR_DELTA * self.diameter))

    def resistance_slopes(self, gap: float) -> tuple[tuple[float, ...], tuple[float, ...]]:
        """((X11, X12, X21, X22), d/dh [1/m]) at the pair gap h [m], held below MIN_PAIR_DELTA 2a*."""
        floor = MIN_PAIR_DELTA * self.diameter
        if gap <= floor:
            return self._resistance.coefficients(floor), (0.0, 0.0, 0.0, 0.0)
        return self._resistance.coefficients_slopes(gap)

    def interaction(self, gap: float, velocities: np.ndarray, film: float = 1.0) -> np.ndarray:
        """The pair's Stokes interaction on each sphere, -6 pi mu a_i sum_j (X_ij - delta_ij) U_j [N], at the
        lubrication's gap with the share `film` of it left (ContactLaw.film)."""
        return np.array(self.interaction_slopes(gap, *velocities, film)[0])

    def interaction_slopes(self, gap: float, v1: float, v2: float, film: float = 1.0) -> tuple:
        """`interaction` and its derivatives: ((f1, f2), d/d gap, d/d film, ((df1/dV1, df1/dV2), (df2/dV1,
        df2/dV2)))."""
        return self._relieved(self._stokes_excess(self.resistance_slopes(gap), (1.0, 0.0, 0.0, 1.0), v1, v2, film),
                              gap, v1, v2, film)

    def correction(self, gap: float, velocities: np.ndarray, film: float = 1.0) -> np.ndarray:
        """What a flow holding the pair gap at delta_sl 2a* misses at the gap h < delta_sl 2a* [N]:
        -6 pi mu a_i sum_j [X_ij(h) - X_ij(delta_sl 2a*)] U_j; zero at and above the hold."""
        return np.array(self.correction_slopes(gap, *velocities, film)[0])

    def correction_slopes(self, gap: float, v1: float, v2: float, film: float = 1.0) -> tuple:
        """`correction` and its derivatives, as `interaction_slopes`."""
        if not self.correcting or gap >= self.blend_gap:
            return (0.0, 0.0), (0.0, 0.0), (0.0, 0.0), ((0.0, 0.0), (0.0, 0.0))
        excess = self._stokes_excess(self.resistance_slopes(gap), self._resistance_hold, v1, v2, film)
        return self._relieved(excess, gap, v1, v2, film)  # the held flow has no cavity

    def _relieved(self, forces: tuple, gap: float, v1: float, v2: float, film: float) -> tuple:
        """`forces` (as interaction_slopes) with the liquid's tension limit on the film between the two
        surfaces as they separate (fem_bounce.cavitation, the reduced radius a* and the opening rate
        V2 - V1): the relief R >= 0 pushes sphere 2 up and sphere 1 down, weighed by the share `film`."""
        if self.tension == math.inf:
            return forces
        relief, d_gap, d_rate = cavitation.tension_relief(gap, v2 - v1, self.reduced_radius, self._liquid.viscosity,
                                                          self.tension)
        if not relief:
            return forces
        (f1, f2), (g1, g2), (s1, s2), ((a11, a12), (a21, a22)) = forces
        return ((f1 - film * relief, f2 + film * relief), (g1 - film * d_gap, g2 + film * d_gap),
                (s1 - relief, s2 + relief),
                ((a11 + film * d_rate, a12 - film * d_rate), (a21 - film * d_rate, a22 + film * d_rate)))

    def _stokes_excess(self, resistance, base, v1: float, v2: float, film: float) -> tuple:
        """-film 6 pi mu a_i sum_j (X_ij - base_ij) U_j and its derivatives (`interaction_slopes`), X and dX/dh
        given as `resistance`, `base` as (base11, base12, base21, base22)."""
        (x11, x12, x21, x22), (d11, d12, d21, d22) = resistance
        s1, s2 = self._stokes_drags
        e11, e12, e21, e22 = x11 - base[0], x12 - base[1], x21 - base[2], x22 - base[3]
        excess1, excess2 = e11 * v1 + e12 * v2, e21 * v1 + e22 * v2
        return ((-film * s1 * excess1, -film * s2 * excess2),
                (-film * s1 * (d11 * v1 + d12 * v2), -film * s2 * (d21 * v1 + d22 * v2)),
                (-s1 * excess1, -s2 * excess2),
                ((-film * s1 * e11, -film * s1 * e12), (-film * s2 * e21, -film * s2 * e22)))

    def added_mass(self, gap: float) -> tuple[np.ndarray, np.ndarray]:
        """(M - diag(m_l,i / 2) [kg], dM/dh [kg/m]) at the pair gap h [m]: the pair's potential-flow added-mass
        matrix M_ij = m_l,i C_ij(h) (symmetric) less each isolated sphere's own m_l,i / 2, which the
        sphere's C_M already holds (module docstring)."""
        excess, slope, _ = self.added_mass_slopes(gap)
        return np.array(excess).reshape(2, 2), np.array(slope).reshape(2, 2)

    def added_mass_slopes(self, gap: float) -> tuple[tuple[float, ...], ...]:
        """`added_mass` and d2M/dh2 [kg/m2] as plain floats, each (11, 12, 21, 22)."""
        (c11, c12, c21, c22), (d11, d12, d21, d22), (k11, k12, k21, k22) = self._added_mass.coefficients_curvature(
            max(gap, MIN_PAIR_DELTA * self.diameter))
        m1, m2 = self._displaced_masses
        return ((m1 * (c11 - 0.5), m1 * c12, m2 * c21, m2 * (c22 - 0.5)),
                (m1 * d11, m1 * d12, m2 * d21, m2 * d22),
                (m1 * k11, m1 * k12, m2 * k21, m2 * k22))

    def added_mass_velocity_term(self, gap: float, velocities: np.ndarray, rate: float) -> np.ndarray:
        """The added mass's forces that do not multiply an acceleration [N], from Lagrange's equations with
        T = (1/2) V^T M(h) V and h = z2 - z1 - a1 - a2 (dh/dz1 = -1, dh/dz2 = +1):

            F_i = -sum_j (dM_ij/dh) hdot V_j + (1/2) (dh/dz_i) V^T (dM/dh) V,     hdot = `rate` [m/s].

        With sphere 2 held and infinitely large (hdot = -V1) it is the wall's -(1/2) m_l V1^2 dC_M/dh_wall
        (theory.TheoryForces.added_mass_velocity_term_slopes).  The sum over the spheres is -(dM/dt) V: what the
        pair hands the liquid's impulse, so that sum_i m_i V_i + sum_ij M_ij V_j is conserved."""
        return np.array(self.added_mass_velocity_term_slopes(gap, *velocities, rate)[0])

    def added_mass_velocity_term_slopes(self, gap: float, v1: float, v2: float, rate: float,
                                        added_mass: tuple | None = None) -> tuple:
        """`added_mass_velocity_term` and its derivatives: ((f1, f2), d/d gap, ((df1/dV1, df1/dV2), (df2/dV1,
        df2/dV2)) at a fixed rate, d/d rate).  dM/dh is symmetric (reciprocity), so d(V^T M' V / 2)/dV_j =
        (M' V)_j.  `added_mass`: `added_mass_slopes(gap)` when the caller has it already."""
        _, (s11, s12, s21, s22), (k11, k12, k21, k22) = added_mass or self.added_mass_slopes(gap)
        slope_v1, slope_v2 = s11 * v1 + s12 * v2, s21 * v1 + s22 * v2  # (M' V)_i
        quadratic = 0.5 * (v1 * slope_v1 + v2 * slope_v2)
        curved_v1, curved_v2 = k11 * v1 + k12 * v2, k21 * v1 + k22 * v2  # (M'' V)_i
        curved_quadratic = 0.5 * (v1 * curved_v1 + v2 * curved_v2)
        return ((-rate * slope_v1 - quadratic, -rate * slope_v2 + quadratic),
                (-rate * curved_v1 - curved_quadratic, -rate * curved_v2 + curved_quadratic),
                ((-rate * s11 - slope_v1, -rate * s12 - slope_v2), (-rate * s21 + slope_v1, -rate * s22 + slope_v2)),
                (-slope_v1, -slope_v2))
