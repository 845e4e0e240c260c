"""The fluid-sphere coupling of one fictitious-domain step, as algebra on a few integrals.

Per step the flow solver gives three fields: the predictor u~ (no forcing), the
response y0 to the forcing rho c phi (-u~), and the response y1 to the unit
forcing rho c phi e_z.  The step's field is u = u~ + y0 + s y1 with force
density f = rho c phi (s e_z - u~) on the fluid.  With the weighted interior
integral I(w) = 2 pi int phi w_z r dx and V_phi = 2 pi int phi r dx, s is chosen
so that the fluid inside the sphere moves with the sphere on average:

    I(u~) + I(y0) + s I(y1) = U V_phi.

The force of the fluid on the sphere is minus the immersed force plus the rate
of change of the momentum of the fluid inside it (Uhlmann 2005; docs/physics.md section 5),
here the phi-weighted momentum rho I(u) = rho U V_phi, differentiated by the
flow's BDF formula (BDF2: c = 3 / (2 dt), (3 I_{n+1} - 4 I_n + I_{n-1}) / (2 dt)
= c (I_{n+1} - J) with J = (4 I_n - I_{n-1}) / 3, the momentum history):

    F(U) = -rho c [s(U) V_phi - I(u~)] + rho c (U V_phi - J).

F is affine in U with slope -c m_a, m_a = rho V_phi (V_phi / I(y1) - 1) > 0, the
numerical added mass (half the displaced mass for a sharp sphere far from walls,
where I(y1) = 2 V / 3).  With U_ref the same BDF combination of the past
velocities, c (U - U_ref) is the BDF acceleration and F = F* - m_a c (U - U_ref),
F* = F(U_ref): the sphere integrator takes f_sim = F* - m_a dV/dt and solves for
U implicitly, so the effective mass m_p + m_a stays positive for any density
ratio.  (Weighting the interior momentum with the sharp ball instead, rho V U,
gave m_a = 0.15 m_l for a sphere far from walls, the phi weighting 0.47 m_l: the
fluid in the smoothed band does not move rigidly within one step.)  SI units.

A pair (two spheres on the axis, models/fd/pair.py) has one amplitude per sphere and
the interior integrals I_i of each sphere's indicator phi_i.  With G_ij = I_i(y1_j),
the interior response of sphere i to a unit amplitude at sphere j (symmetric: the
step's matrix is), the amplitudes solve G s = U V_phi - I(u~) - I(y0) and

    F_i(U) = -rho c [s_i V_i - I_i(u~)] + rho c (U_i V_i - J_i),

affine in both velocities: dF_i/dU_j = -c M_ij with the 2 x 2 numerical added mass
M = rho (diag(V) G^-1 diag(V) - diag(V)), whose off-diagonal entries carry the push
of one sphere on the other through the liquid inside one step.  For one sphere these
are the formulas above (the single-sphere path keeps its scalar arithmetic).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class InteriorIntegrals:
    """2 pi-weighted integrals over the smoothed sphere of one step."""

    volume: float  # V_phi [m^3]
    predicted: float  # I(u~) [m^4/s]
    forced: float  # I(y0) [m^4/s]
    unit: float  # I(y1) [m^3]: the interior response to unit s


@dataclass(frozen=True)
class Linearised:
    """F(U) = explicit - added_mass * c (U - reference) [N, kg, m/s]; for a pair: arrays (2,), (2, 2), (2,)."""

    explicit: float
    added_mass: float
    reference: float


def rigid_amplitude(integrals: InteriorIntegrals, velocity: float) -> float:
    """s such that the step's interior mean velocity equals the sphere's [m/s]."""
    i = integrals
    return (velocity * i.volume - i.predicted - i.forced) / i.unit


def added_mass(integrals: InteriorIntegrals, density: float) -> float:
    """m_a = rho V_phi (V_phi / I(y1) - 1) [kg]."""
    return density * integrals.volume * (integrals.volume / integrals.unit - 1.0)


def fluid_force(integrals: InteriorIntegrals, velocity: float, density: float, c: float,
                momentum_history: float) -> float:
    """F(U) [N] for the sphere velocity U [m/s] at the end of the step; momentum_history = J [m^4/s]."""
    s = rigid_amplitude(integrals, velocity)
    immersed = density * c * (s * integrals.volume - integrals.predicted)
    interior_rate = density * c * (velocity * integrals.volume - momentum_history)
    return -immersed + interior_rate


def linearise(integrals: InteriorIntegrals, density: float, c: float, momentum_history: float,
              reference: float) -> Linearised:
    """F(U) as explicit - m_a c (U - U_ref), so that c (U - U_ref) is the BDF acceleration."""
    explicit = fluid_force(integrals, reference, density, c, momentum_history)
    return Linearised(explicit=explicit, added_mass=added_mass(integrals, density), reference=reference)


# -- a pair of spheres (arrays: one entry per sphere, sphere 1 first) -------------------------------
@dataclass(frozen=True)
class PairIntegrals:
    """The 2 pi-weighted integrals of each sphere's smoothed indicator in one step."""

    volume: np.ndarray  # V_i [m^3], shape (2,)
    predicted: np.ndarray  # I_i(u~) [m^4/s]
    forced: np.ndarray  # I_i(y0) [m^4/s] (y0: the response to both spheres' forcing of -u~)
    unit: np.ndarray  # G_ij = I_i(y1_j) [m^3], shape (2, 2)


def rigid_amplitudes(integrals: PairIntegrals, velocities: np.ndarray) -> np.ndarray:
    """s such that each sphere's interior mean velocity equals its own velocity [m/s]."""
    i = integrals
    return np.linalg.solve(i.unit, np.asarray(velocities) * i.volume - i.predicted - i.forced)


def added_mass_matrix(integrals: PairIntegrals, density: float) -> np.ndarray:
    """M = rho (diag(V) G^-1 diag(V) - diag(V)) [kg]: f_i = ... - sum_j M_ij c (U_j - U_ref_j)."""
    volume = integrals.volume
    return density * (volume[:, None] * np.linalg.inv(integrals.unit) * volume[None, :] - np.diag(volume))


def pair_forces(integrals: PairIntegrals, velocities: np.ndarray, density: float, c: float,
                momentum_history: np.ndarray) -> np.ndarray:
    """F_i(U_1, U_2) [N] for the spheres' velocities at the end of the step; momentum_history = J_i [m^4/s]."""
    velocities = np.asarray(velocities, dtype=float)
    s = rigid_amplitudes(integrals, velocities)
    immersed = density * c * (s * integrals.volume - integrals.predicted)
    interior_rate = density * c * (velocities * integrals.volume - momentum_history)
    return -immersed + interior_rate


def linearise_pair(integrals: PairIntegrals, density: float, c: float, momentum_history: np.ndarray,
                   reference: np.ndarray) -> Linearised:
    """F(U) as explicit - M c (U - U_ref), arrays: explicit (2,), added_mass (2, 2), reference (2,)."""
    explicit = pair_forces(integrals, reference, density, c, momentum_history)
    return Linearised(explicit=explicit, added_mass=added_mass_matrix(integrals, density),
                      reference=np.asarray(reference, dtype=float))
