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
  added (the pair's added mass is each sphere's m_l / 2: section 6 of docs/physics.md).
"""
from __future__ import annotations

import math

import numpy as np

from .contact import ContactGaps, ContactLaw, reduced_modulus
from .pair_theory import PairResistance, reduced_radius
from .scene import Scene

# Trial states of an implicit step may close the pair gap; real penetration is an event of the integrator.
MIN_PAIR_DELTA = 1e-12


class PairContactModel(ContactGaps):
    """One pair scene's contact model: the pair's gap scales, its elastic force, its liquid interaction
    in Stokes flow and a resolved flow's correction (module docstring)."""

    def __init__(self, scene: Scene, resolved: bool = False):
        first, second = scene.sphere, scene.second_sphere
        c = scene.contact
        self.delta_sl = c.delta_sl
        self.radii = np.array([first.radius, second.radius])
        self.diameter = 2.0 * reduced_radius(first.radius, second.radius)  # 2 a*: the pair's gap scale [m]
        self.reduced_radius = 0.5 * self.diameter
        free = (scene.motion.mode == "free", second.mode == "free")
        if all(free) or not any(free):
            self.reduced_mass = first.mass * second.mass / (first.mass + second.mass)
        else:  # a held or prescribed sphere is infinitely heavy to the collision
            self.reduced_mass = first.mass if free[0] else second.mass
        self.e_star = reduced_modulus(first.youngs_modulus, first.poisson_ratio, second.youngs_modulus,
                                      second.poisson_ratio)
        self.law = ContactLaw(c, self.reduced_radius, self.reduced_mass, self.e_star, scene.liquid.viscosity,
                              first.roughness + second.roughness, self.diameter)
        self.stokes_drags = 6.0 * math.pi * scene.liquid.viscosity * self.radii  # 6 pi mu a_i [N s/m]
        self._liquid = scene.liquid
        # the hold and the correction belong to a resolved flow with a free sphere (as at the wall)
        self.correcting = resolved and scene.near_wall_law == "correction" and any(free)
        self._resistance = PairResistance(first.radius, second.radius)  # tabulated once, ~3 us a call
        self._resistance_hold = self.resistance(self.blend_gap)

    # -- the collision's numbers ---------------------------------------------------------------------
    def stokes(self, speed: float) -> float:
        """The binary Stokes number St = m* V / (6 pi mu a*^2) of the relative speed V [m/s]: Yang & Hunt's
        (2006) name; their exact definition could not be read (docs/physics.md section 6 gives the
        conversions); a2 -> infinity gives the wall's (1/9) (rho_p / rho_l) Re."""
        return self.reduced_mass * abs(speed) / (6.0 * math.pi * self._liquid.viscosity * self.reduced_radius**2)

    def reynolds(self, speed: float) -> float:
        """rho_l V 2a* / mu of the relative speed (a2 -> infinity gives the wall's Re on D)."""
        return self._liquid.density * self.diameter * abs(speed) / self._liquid.viscosity

    def numbers(self, speed: float) -> tuple[float, float]:
        return self.reynolds(speed), self.stokes(speed)

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
