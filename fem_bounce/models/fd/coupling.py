"""The fluid-body coupling of one fictitious-domain step, as algebra on a few integrals.

Each sphere i on the axis has its smoothed indicator phi_i and its own amplitude s_i.  Per step the flow
solver gives the predictor u~ (no forcing), the response y0 to the forcing rho c sum_i phi_i (-u~) and,
for each sphere j, the response y1_j to the unit forcing rho c phi_j e_z.  The step's field is

    u = u~ + y0 + sum_j s_j y1_j,   force density f = rho c sum_i phi_i (s_i e_z - u~) on the fluid.

With the interior integral I_i(w) = int phi_i w_z dV, V_i = int phi_i dV (dV the physical volume element,
fem.geometry's weighted measure) and
G_ij = I_i(y1_j) (the interior response of sphere i to a unit amplitude at sphere j; symmetric, as the
step's matrix is), the amplitudes make each interior move with its own sphere on average:

    I_i(u~) + I_i(y0) + sum_j G_ij s_j = U_i V_i.

The force of the fluid on a sphere is minus its immersed force plus the rate of change of the momentum
of the fluid inside it (Uhlmann 2005; docs/physics.md section 5), here the phi-weighted momentum
rho I_i(u) = rho U_i V_i, differentiated by the flow's BDF formula (BDF2: c = 3 / (2 dt),
(3 I_{n+1} - 4 I_n + I_{n-1}) / (2 dt) = c (I_{n+1} - J) with J = (4 I_n - I_{n-1}) / 3, the momentum
history):

    F_i(U) = -rho c [s_i(U) V_i - I_i(u~)] + rho c (U_i V_i - J_i).

F is affine in the velocities: dF_i/dU_j = -c M_ij with the numerical added mass

    M = rho diag(V) (G^-1 diag(V) - 1),

whose off-diagonal entries carry the push of one sphere on another through the liquid inside one step.
For one sphere M = rho V (V / G - 1) > 0: half the displaced mass for a sharp sphere far from walls,
where G = 2 V / 3.  With U_ref the same BDF combination of the past velocities, c (U - U_ref) is the BDF
acceleration and F = F* - M c (U - U_ref), F* = F(U_ref): the body integrator takes f_sim = F* - M dV/dt
and solves for U implicitly, so the effective mass stays positive for any density ratio.  (Weighting
the interior momentum with the sharp ball instead, rho V U, gave m_a = 0.15 m_l for a sphere far from
walls, the phi weighting 0.47 m_l: the fluid in the smoothed band does not move rigidly within one
step.)  Every value is an array over the spheres, sphere 1 first; SI units.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class InteriorIntegrals:
    """The integrals over the physical volume of each sphere's smoothed indicator in one step."""

    volume: np.ndarray  # V_i [m^3], shape (N,)
    predicted: np.ndarray  # I_i(u~) [m^4/s]
    forced: np.ndarray  # I_i(y0) [m^4/s] (y0: the response to every sphere's forcing of -u~)
    unit: np.ndarray  # G_ij = I_i(y1_j) [m^3], shape (N, N)


@dataclass(frozen=True)
class Linearised:
    """F(U) = explicit - added_mass c (U - reference) [N, kg, m/s]: shapes (N,), (N, N), (N,)."""

    explicit: np.ndarray
    added_mass: np.ndarray
    reference: np.ndarray


def rigid_amplitudes(integrals: InteriorIntegrals, velocities) -> np.ndarray:
    """s such that each sphere's interior mean velocity equals its own velocity [m/s]."""
    i = integrals
    return np.linalg.solve(i.unit, np.asarray(velocities) * i.volume - i.predicted - i.forced)


def added_mass(integrals: InteriorIntegrals, density: float) -> np.ndarray:
    """M = rho diag(V) (G^-1 diag(V) - 1) [kg]: F_i = ... - sum_j M_ij c (U_j - U_ref,j)."""
    volume = integrals.volume
    return density * volume[:, None] * (np.linalg.solve(integrals.unit, np.diag(volume)) - np.eye(len(volume)))


def fluid_forces(integrals: InteriorIntegrals, velocities, density: float, c: float,
                 momentum_history: np.ndarray) -> np.ndarray:
    """F_i(U) [N] for the spheres' velocities U [m/s] at the end of the step; momentum_history = J_i [m^4/s]."""
    velocities = np.asarray(velocities, dtype=float)
    s = rigid_amplitudes(integrals, velocities)
    immersed = density * c * (s * integrals.volume - integrals.predicted)
    interior_rate = density * c * (velocities * integrals.volume - momentum_history)
    return -immersed + interior_rate


def linearise(integrals: InteriorIntegrals, density: float, c: float, momentum_history: np.ndarray,
              reference) -> Linearised:
    """F(U) as explicit - M c (U - U_ref), so that c (U - U_ref) is the BDF acceleration."""
    reference = np.asarray(reference, dtype=float)
    return Linearised(explicit=fluid_forces(integrals, reference, density, c, momentum_history),
                      added_mass=added_mass(integrals, density), reference=reference)
