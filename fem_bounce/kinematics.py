"""The bodies' state as the integrator holds it, and the types that cross the seam between the bodies and a
resolved flow (flow_model.FlowModel): one object owns the layout, so that nothing else re-derives it.

On the axis (AxisKinematics) each body has one degree of freedom, its velocity along the axis (positive
upward), and its place is a gap: sphere 1's lowest point above z = 0 (the wall, when wall.present), each
further sphere's surface gap to the one below.  The integrator's unknowns are

    y = [h_1, V_1, s_1, V_2, s_2, V_3, ..., the history modes of sphere 1, of sphere 2, ...],

the gaps rather than the heights so that the relative tolerance governs them near contact.  Positions are
3-vectors (the centres at x = y = 0 on the axis), so that a model in space reads them as the axis does.
A body's contact with the one below it (the wall's for sphere 1) is the contact whose gap is that body's
entry.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np


@dataclass(frozen=True)
class PlaneForce:
    """A resolved model's force along the wall and torque on sphere 1 in an oblique collision, over one fluid step:
    (F_x [N], T_y [N m]) = explicit - mass[1:] (dV/dt, dU/dt, dOmega/dt), V the normal velocity, U the velocity along
    the wall (x) and Omega the spin about y (oblique.TangentialMotion's signs); `mass` (3, 3) [kg, kg m, kg m^2] is
    the added mass over all three, its first row the normal force's (FluidForce.added_mass[0, 0] its first entry)."""

    explicit: np.ndarray
    mass: np.ndarray


@dataclass(frozen=True)
class FluidForce:
    """A resolved model's forces on the N bodies over one fluid step [N, kg]:
    f_sim,i = explicit_i - sum_j added_mass_ij dV_j/dt, `explicit` of shape (N,), `added_mass` (N, N);
    `plane`: the force along the wall and the torque of an oblique collision (None: head-on, or none resolved).

    `ramp` (t_n, t_n+1, the explicit part at t_n, the plane's at t_n or None): the explicit parts run linearly from
    their values at the step's start (the step before's end) to this step's at its end, the trapezoidal rule of the
    flow's force over the step (second order in the step; held at the end's value, the rectangle rule, it is first
    order: numerics.ode.flow_force).  None: held at the end's value."""

    explicit: np.ndarray
    added_mass: np.ndarray
    plane: PlaneForce | None = None
    ramp: tuple | None = None

    @classmethod
    def none(cls, count: int) -> FluidForce:
        """No force from the flow (before a resolved model's first step)."""
        return cls(np.zeros(count), np.zeros((count, count)))

    def ramped(self, before: FluidForce, start: float, end: float) -> FluidForce:
        """This step's force from t = `start` to `end` [s], its explicit parts running from `before`'s (the step
        before's, at `start`) to its own; unchanged where `before` has none of the same shape."""
        if np.shape(before.explicit) != np.shape(self.explicit) or (before.plane is None) != (self.plane is None):
            return self
        plane = None if self.plane is None else before.plane.explicit
        return replace(self, ramp=(start, end, before.explicit, plane))

    def at(self, t: float) -> FluidForce:
        """The force at time t [s] within its step: the explicit parts interpolated along the ramp (None: itself)."""
        if self.ramp is None:
            return self
        start, end, explicit, plane = self.ramp
        weight = min(max((t - start) / (end - start), 0.0), 1.0) if end > start else 1.0
        along = None if self.plane is None else replace(
            self.plane, explicit=plane + weight * (self.plane.explicit - plane))
        return FluidForce(explicit + weight * (self.explicit - explicit), self.added_mass, along)


@dataclass(frozen=True)
class Prediction:
    """Where the bodies will be at the end of the coming fluid step: from their gaps now, the step and
    their mean velocities over the step, 1.5 V_n - 0.5 V_{n-1} (Adams-Bashforth 2) [SI].

    Every per-body value is an array over the bodies on the axis, sphere 1 (the lowest) first: each
    one's lowest point above z = 0 and its velocity; flow_model.flow_gaps says where a resolved flow places
    them."""

    time: float  # t_n [s]
    gaps_now: np.ndarray  # h_i(t_n) [m]
    velocities_now: np.ndarray  # V_i(t_n) [m/s]
    dt: float  # [s]
    mean_velocities: np.ndarray  # over [t_n, t_n + dt] [m/s]

    @property
    def gaps(self) -> np.ndarray:
        """h_i(t_n + dt) [m]."""
        return self.gaps_now + self.dt * self.mean_velocities

    def centers(self, radii) -> np.ndarray:
        """The sphere centres' heights at t_n + dt [m], for the spheres' `radii` [m]."""
        return np.asarray(radii, dtype=float) + self.gaps_now + self.dt * self.mean_velocities


def pair_name(lower: int, count: int) -> str:
    """The name of the contact between bodies `lower` and `lower` + 1 (from 0) of `count`, in checkpoints,
    collisions and the trajectory's columns: "pair" when there are two, else "pair_12", "pair_23", ..."""
    return "pair" if count == 2 else f"pair_{lower + 1}{lower + 2}"


class AxisKinematics:
    """The layout of N bodies on the axis: per body a gap and a velocity, interleaved (module docstring)."""

    dofs = 1  # velocities per body

    def __init__(self, diameters):
        self.diameters = [float(d) for d in diameters]
        self.count = count = len(self.diameters)
        self.size = 2 * count  # the gaps and velocities, before the history modes
        self.gap_columns = np.arange(0, 2 * count, 2)
        self.velocity_columns = np.arange(1, 2 * count, 2)
        self.gap_slice, self.velocity_slice = slice(0, 2 * count, 2), slice(1, 2 * count, 2)

    def gap_index(self, body: int) -> int:
        """Where the gap below body `body` (from 0; the wall's for body 0) is in y."""
        return 2 * body

    def velocity_index(self, body: int) -> int:
        """Where body `body`'s velocity is in y."""
        return 2 * body + 1

    def gaps_below(self, body: int) -> slice:
        """The entries of y whose sum (with the diameters below) is body `body`'s height: h_1, s_1, ..."""
        return slice(0, 2 * body + 1, 2)

    def state(self, gaps, velocities) -> list[float]:
        """y[:size] from each body's gap below it and its velocity."""
        return [value for pair in zip(gaps, velocities) for value in (float(pair[0]), float(pair[1]))]

    def velocities(self, y) -> np.ndarray:
        """Each body's velocity in y [m/s] (a view)."""
        return y[self.velocity_slice]

    def heights(self, y) -> list[float]:
        """Each sphere's lowest point above z = 0 [m] from the state's gaps, sphere 1 first."""
        heights = [float(y[0])]
        for k in range(1, self.count):
            heights.append(heights[-1] + self.diameters[k - 1] + float(y[2 * k]))
        return heights

    def centers(self, heights) -> np.ndarray:
        """The centres as 3-vectors (N, 3) [m] from the lowest points' heights: on the axis x = y = 0."""
        centers = np.zeros((self.count, 3))
        centers[:, 2] = np.asarray(heights, dtype=float) + 0.5 * np.asarray(self.diameters)
        return centers
