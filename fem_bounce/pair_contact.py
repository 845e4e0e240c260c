"""The contact model of a head-on pair of spheres on the axis (issue 14; docs/physics.md section 6).

The wall's contact model (contact.py, Li, Hunt & Colonius 2011 section 4) with the pair's quantities:
the reduced radius a* = a1 a2 / (a1 + a2), the reduced mass m* = m1 m2 / (m1 + m2) (m* = m1 when the
second sphere is held or prescribed, which no force moves), E* of the two materials, and the gap h
between the two surfaces scaled by the reduced diameter, delta = h / (2 a*) (scene.pair_diameter).  For
a2 -> infinity and m2 -> infinity every formula here becomes the wall's.

- Elastic force: f_ss = e_d W_o F(delta / delta_ss) pushing the spheres apart, with Hertz's peak force
  for two spheres (Johnson 1985, section 11.1: the relative approach x obeys m* x'' = -(4/3) E* a*^(1/2)
  x^(3/2); the kinetic energy of the relative motion, m* V^2 / 2, stored at the deepest approach),
      W_o = (4/3) E* a*^(1/2) x_m^(3/2),   x_m = (15 m* V^2 / (16 E* a*^(1/2)))^(2/5),
  fixed from the relative speed V when the pair gap first falls to delta_ss 2a*.  With a* = a and
  m* = (4/3) pi a^3 rho_p this is the paper's eq. 4.7, W_o = (4/3) a^2 E* (5 pi rho_p V^2 / (4 E*))^(3/5).
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

from .contact import ContactGaps, elastic_shape, reduced_modulus
from .pair_theory import PairResistance, reduced_radius
from .scene import Scene

# Trial states of an implicit step may close the pair gap; real penetration is an event of the integrator.
MIN_PAIR_DELTA = 1e-12


def hertz_depth(radius: float, mass: float, e_star: float, speed: float) -> float:
    """x_m [m]: the deepest approach of a Hertz contact, (15 m* V^2 / (16 E* a*^(1/2)))^(2/5)."""
    return (15.0 * mass * speed**2 / (16.0 * e_star * math.sqrt(radius))) ** 0.4


def hertz_peak_force(radius: float, mass: float, e_star: float, speed: float) -> float:
    """W_o [N]: the largest force of a Hertz contact of (reduced) radius `radius` [m] and (reduced) mass
    `mass` [kg] met at the relative speed `speed` [m/s], 1/E* = sum (1 - nu^2)/E [Pa]."""
    return 4.0 / 3.0 * e_star * math.sqrt(radius) * hertz_depth(radius, mass, e_star, speed)**1.5


def hertz_contact_time(radius: float, mass: float, e_star: float, speed: float) -> float:
    """Hertz's duration of a dry elastic impact, 2.868 (m*^2 / (a* E*^2 V))^(1/5) [s] (Johnson 1985,
    eq. 11.24: 2.94 x_m / V); for comparison only: the paper's contact layer of thickness delta_ss is
    not Hertz's deformation and lasts longer (docs/physics.md section 6)."""
    return 2.94 * hertz_depth(radius, mass, e_star, speed) / speed


class PairContactModel(ContactGaps):
    """One pair scene's contact model: the pair's gap scales, its elastic force, its liquid interaction
    in Stokes flow and a resolved flow's correction (module docstring)."""

    def __init__(self, scene: Scene, resolved: bool = False):
        first, second = scene.sphere, scene.second_sphere
        c = scene.contact
        self.delta_sl, self.delta_ss, self.dry_restitution = c.delta_sl, c.delta_ss, c.dry_restitution
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
        self.stokes_drags = 6.0 * math.pi * scene.liquid.viscosity * self.radii  # 6 pi mu a_i [N s/m]
        self._liquid = scene.liquid
        # the hold and the correction belong to a resolved flow with a free sphere (as at the wall)
        self.correcting = resolved and c.near_wall == "correction" and any(free)
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
    def hertz_force(self, impact_speed: float) -> float:
        """W_o of the pair [N] at the relative speed `impact_speed` [m/s]."""
        return hertz_peak_force(self.reduced_radius, self.reduced_mass, self.e_star, impact_speed)

    def elastic(self, gap: float, hertz_force: float) -> float:
        """f_ss = e_d W_o F(delta / delta_ss) [N], pushing the spheres apart (+ on sphere 2, - on sphere 1)."""
        return self.dry_restitution * hertz_force * elastic_shape(gap / self.contact_gap)

    def resistance(self, gap: float) -> np.ndarray:
        """X(h): F_i = -6 pi mu a_i sum_j X_ij U_j in Stokes flow, at the pair gap h [m]."""
        return self._resistance(max(gap, MIN_PAIR_DELTA * self.diameter))

    def interaction(self, gap: float, velocities: np.ndarray) -> np.ndarray:
        """The pair's Stokes interaction on each sphere, -6 pi mu a_i sum_j (X_ij - delta_ij) U_j [N]."""
        return -self.stokes_drags * ((self.resistance(gap) - np.eye(2)) @ velocities)

    def correction(self, gap: float, velocities: np.ndarray) -> np.ndarray:
        """What a flow holding the pair gap at delta_sl 2a* misses at the gap h < delta_sl 2a* [N]:
        -6 pi mu a_i sum_j [X_ij(h) - X_ij(delta_sl 2a*)] U_j; zero at and above the hold."""
        if not self.correcting or gap >= self.blend_gap:
            return np.zeros(2)
        return -self.stokes_drags * ((self.resistance(gap) - self._resistance_hold) @ velocities)
