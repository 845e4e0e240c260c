"""The penalty's force on the sphere, affine in its rigid-body amplitudes: the flow's answer to the body integrator.

With the flow u(s) = x_0 + sum_j s_j x_j of one solve (flow.py) and the generalised forces over the rigid modes
m_i (the force components for the translations, the torques about the centre for the rotations),

    F_i(s) = rho c_B (I_i(x_0) + sum_j (I_i(x_j) - G_ij) s_j),   I_i(w) = int phi w . m_i,   G_ij = int phi m_i . m_j.

`resistance` = dF/ds = rho c_B (I(x_j) - G) is, for the steady Stokes solve, the sphere's (penalised) resistance
matrix: symmetric (the Stokes saddle point is), negative definite.  For a time step the body integrator adds the
rate of the held ball's momentum, rho c (ball_mass s - J) (J the BDF history of that momentum), and solves for s
implicitly: the force is then linear in the accelerations c (s - s_ref).  SI units throughout.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class RigidResponse:
    """One solve's penalty force over the modes `names` (fem.geometry's mode_names)."""

    names: tuple[str, ...]
    penalty: float  # rho c_B [kg/(m^3 s)]
    constant: np.ndarray  # I_i(x_0), shape (m,)
    slopes: np.ndarray  # I_i(x_j), shape (m, m)
    mode_mass: np.ndarray  # G_ij, shape (m, m)
    ball_mass: np.ndarray  # int_ball m_i . m_j, the sharp ball the penalty holds, shape (m, m)

    @property
    def resistance(self) -> np.ndarray:
        """dF_i/ds_j [N s/m, N s, N m s]."""
        return self.penalty * (self.slopes - self.mode_mass)

    def penalty_force(self, amplitudes) -> np.ndarray:
        """F_i(s): the generalised forces of the penalty's reaction for the amplitudes s [N, N m] (a solve without
        the responses, NaN slopes, knows only the held sphere's, s = 0)."""
        amplitudes = np.asarray(amplitudes, dtype=float)
        held = self.penalty * self.constant
        moving = amplitudes != 0.0  # a mode the solve left out (NaN slopes) has amplitude 0
        return held if not moving.any() else held + self.resistance[:, moving] @ amplitudes[moving]

    def index(self, name: str) -> int:
        return self.names.index(name)
