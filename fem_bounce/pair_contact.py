"""The contact model of a head-on pair of spheres on the axis (issue 14; docs/physics.md section 6).

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
        self.stokes_drags = 6.0 * math.pi * scene.liquid.viscosity * self.radii  # 6 pi mu a_i [N s/m]
        self._liquid = scene.liquid
        # the hold and the correction belong to a resolved flow with a free sphere (as at the wall)
        self.correcting = resolved and scene.near_wall_law == "correction" and any(free)
        self._resistance = PairResistance(first.radius, second.radius)  # tabulated once, ~3 us a call
        self._resistance_hold = self.resistance(self.blend_gap)
        self._added_mass = PairAddedMass(first.radius, second.radius)  # tabulated once, microseconds a call
        self.displaced_masses = np.array([body.displaced_mass for body in bodies])  # m_l,i [kg]

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
    def resistance(self, gap: float) -> np.ndarray:
        """X(h): F_i = -6 pi mu a_i sum_j X_ij U_j in Stokes flow, at the pair gap h [m]."""
        return self._resistance(max(gap, MIN_PAIR_DELTA * self.diameter))

    def interaction(self, gap: float, velocities: np.ndarray, film: float = 1.0) -> np.ndarray:
        """The pair's Stokes interaction on each sphere, -6 pi mu a_i sum_j (X_ij - delta_ij) U_j [N], at the
        lubrication's gap with the share `film` of it left (ContactLaw.film)."""
        return -film * self.stokes_drags * ((self.resistance(gap) - np.eye(2)) @ velocities)

    def correction(self, gap: float, velocities: np.ndarray, film: float = 1.0) -> np.ndarray:
        """What a flow holding the pair gap at delta_sl 2a* misses at the gap h < delta_sl 2a* [N]:
        -6 pi mu a_i sum_j [X_ij(h) - X_ij(delta_sl 2a*)] U_j; zero at and above the hold."""
        if not self.correcting or gap >= self.blend_gap:
            return np.zeros(2)
        return -film * self.stokes_drags * ((self.resistance(gap) - self._resistance_hold) @ velocities)

    def added_mass(self, gap: float) -> tuple[np.ndarray, np.ndarray]:
        """(M - diag(m_l,i / 2) [kg], dM/dh [kg/m]) at the pair gap h [m]: the pair's potential-flow added-mass
        matrix M_ij = m_l,i C_ij(h) (symmetric) less each isolated sphere's own m_l,i / 2, which the
        sphere's C_M already holds (module docstring)."""
        (c11, c12, c21, c22), (d11, d12, d21, d22) = self._added_mass.coefficients(
            max(gap, MIN_PAIR_DELTA * self.diameter))
        m1, m2 = self.displaced_masses
        excess = np.array([[m1 * (c11 - 0.5), m1 * c12], [m2 * c21, m2 * (c22 - 0.5)]])
        return excess, np.array([[m1 * d11, m1 * d12], [m2 * d21, m2 * d22]])

    def added_mass_velocity_term(self, gap: float, velocities: np.ndarray, rate: float) -> np.ndarray:
        """The added mass's forces that do not multiply an acceleration [N], from Lagrange's equations with
        T = (1/2) V^T M(h) V and h = z2 - z1 - a1 - a2 (dh/dz1 = -1, dh/dz2 = +1):

            F_i = -sum_j (dM_ij/dh) hdot V_j + (1/2) (dh/dz_i) V^T (dM/dh) V,     hdot = `rate` [m/s].

        With sphere 2 held and infinitely large (hdot = -V1) it is the wall's -(1/2) m_l V1^2 dC_M/dh_wall
        (theory.TheoryForces.added_mass_velocity_term).  The sum over the spheres is -(dM/dt) V: what the
        pair hands the liquid's impulse, so that sum_i m_i V_i + sum_ij M_ij V_j is conserved."""
        _, slope = self.added_mass(gap)
        quadratic = 0.5 * float(velocities @ slope @ velocities)
        return -rate * (slope @ velocities) + quadratic * np.array([-1.0, 1.0])
