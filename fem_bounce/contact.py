"""The contact model shared by every solver (Li, Hunt & Colonius 2011, section 4; docs/physics.md).

- Near-wall liquid force of a free sphere in a resolved flow, `contact.near_wall`:
  "correction" (default): the flow's sphere is held at the gap delta_sl D while the real sphere goes
  closer, and what the held flow cannot see is added (`ContactModel.correction`),
      f_sl = f_sim(held at delta_sl) - 6 pi mu a V [lambda(delta) - lambda(delta_sl)]
             - m_l [C_M(delta) - C_M(delta_sl)] dV/dt - (1/2) m_l V^2 dC_M/dh,   delta < delta_sl,
  and f_sl = f_sim above (the correction of Costa et al. 2015, with the resolved geometry held so that
  the resolved part stops growing where the correction starts);
  "blend": the paper's eq. 4.5-4.6, f_sl = H f_thr + (1 - H) f_sim,
  H(delta) = 1 / (1 + exp(10 (delta / delta_sl - 1))).
  The ODE model has no resolved flow and uses f_thr everywhere.  Fixed and prescribed spheres report
  the resolved force at their true gap (the validation checks of the flow solvers).
- Elastic force (eq. 4.7-4.9): f_ss = e_d W_o F(delta / delta_ss), with the Hertz
  peak force W_o = (4/3) a^2 E* (5 pi rho_p V_I^2 / (4 E*))^(3/5) fixed at the
  impact speed V_I recorded when the gap first falls to delta_ss, and
  F(x) = (exp(-x) - exp(-1)) / (1 - exp(-1)) on [0, 1], zero beyond.

With W_o fixed during one contact, f_ss depends on position only: it stores and
returns energy, and all dissipation comes from the liquid (docs/physics.md section 2).
"""
from __future__ import annotations

import math

from .scene import Scene
from .theory import TheoryForces

_E_INV = math.exp(-1.0)


def blend(delta: float, delta_sl: float) -> float:
    """H(delta / delta_sl): 1 at contact, 1/2 at delta_sl, 0 far away."""
    x = 10.0 * (delta / delta_sl - 1.0)
    return 0.0 if x > 700.0 else 1.0 / (1.0 + math.exp(x))


def elastic_shape(x: float) -> float:
    """F(x) of eq. 4.9; continued past x < 0 (penetration) by the same exponential."""
    return 0.0 if x >= 1.0 else (math.exp(-x) - _E_INV) / (1.0 - _E_INV)


def reduced_modulus(e1: float, nu1: float, e2: float, nu2: float) -> float:
    """E* = [(1 - nu1^2)/E1 + (1 - nu2^2)/E2]^-1 [Pa]."""
    return 1.0 / ((1.0 - nu1**2) / e1 + (1.0 - nu2**2) / e2)


class ContactGaps:
    """The contact model's gaps for a length `diameter` (D at the wall, 2a* for a pair) [m]; the class
    using it sets delta_ss, delta_sl, diameter and `correcting` (the near-wall correction is on)."""

    @property
    def contact_gap(self) -> float:
        """delta_ss D: where the elastic force starts [m]."""
        return self.delta_ss * self.diameter

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
    """One scene's contact model: the blend, the elastic force and the theory forces."""

    def __init__(self, scene: Scene):
        c = scene.contact
        self.delta_sl = c.delta_sl
        self.delta_ss = c.delta_ss
        self.dry_restitution = c.dry_restitution
        self.diameter = scene.sphere.diameter
        self.sphere_density = scene.sphere.density
        self.radius = scene.sphere.radius
        self.e_star = reduced_modulus(
            scene.sphere.youngs_modulus, scene.sphere.poisson_ratio, scene.wall.youngs_modulus, scene.wall.poisson_ratio
        )
        self.theory = TheoryForces(scene)
        # the hold and the correction belong to a free sphere's dynamics (see the module docstring)
        self.correcting = c.near_wall == "correction" and scene.motion.mode == "free"
        self._lambda_hold = self.theory.wall_factor(self.blend_gap)
        self._added_mass_hold = self.theory.added_mass(self.blend_gap)[0]

    def blend(self, gap: float) -> float:
        return blend(gap / self.diameter, self.delta_sl)

    def correction(self, gap: float, velocity: float) -> tuple[float, float]:
        """(force [N], added mass [kg]) that a flow held at delta_sl misses when the sphere is at `gap`:
        the correction is force - added_mass * dV/dt, zero at and above delta_sl.

        - lubrication: -6 pi mu a V [lambda(delta) - lambda(delta_sl)] (lambda by contact.wall_drag);
        - the wall's added mass grows: -[C_M(delta) - C_M(delta_sl)] m_l dV/dt;
        - the held geometry does not approach, so the force of the changing added mass,
          -(1/2) m_l V^2 dC_M/dh (the f_AM term of eq. 4.3 in V dW/dt), is absent from it."""
        if not self.correcting or gap >= self.blend_gap:
            return 0.0, 0.0
        theory = self.theory
        lubrication = -theory.stokes_drag * velocity * (theory.wall_factor(gap) - self._lambda_hold)
        added_mass = theory.added_mass(gap)[0] - self._added_mass_hold
        return lubrication + theory.added_mass_velocity_term(gap, velocity), added_mass

    def hertz_force(self, impact_speed: float) -> float:
        """W_o (eq. 4.7) [N]."""
        strain = 5.0 * math.pi * self.sphere_density * impact_speed**2 / (4.0 * self.e_star)
        return 4.0 / 3.0 * self.radius**2 * self.e_star * strain**0.6

    def elastic(self, gap: float, hertz_force: float) -> float:
        """f_ss = e_d W_o F(delta / delta_ss), pushing away from the wall [N]."""
        return self.dry_restitution * hertz_force * elastic_shape(gap / self.contact_gap)
