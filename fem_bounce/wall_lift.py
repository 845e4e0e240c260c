"""The lift of a sphere sliding along a wall at finite Reynolds number (the reduced model of an oblique collision).

A sphere translating at U parallel to a plane wall through liquid at rest is pushed away from the wall by the
liquid's inertia (zero in Stokes flow, by reversibility):

    F_L = C_L(Re, delta / a) rho_l U^2 pi a^2 / 2,   Re = rho_l |U| D / mu,

delta the gap, a the radius.  C_L is the 3-D fictitious-domain model's steady lift on a sphere held at the gap and
seen in its own frame (the wall and the far field moving at -U; `python benchmarks/fd3d_stokes.py lift`, the
table fem_bounce/data/wall_lift_fd3d.csv with its command): 0.30-0.64 at delta = 0.1 a, falling to 0.01-0.15 at
2 a, smaller at higher Re (Re 150 to 10; docs/physics.md section 7).  Between the table's points it is interpolated
linearly in ln Re and in delta / a; it is held at the table's ends in Re (below the lowest Re the force, ~U^2, is
small against the drag, ~U) and at its smallest gap below it, and falls linearly to zero from the largest gap to
twice it.
The quasi-steady lift assumes the sphere's wake along the wall is established, as it is for a sphere that slides
through a bounce at nearly constant speed; the lift of the spin and of the normal motion is left out.

The torque of the same sliding sphere (`WallTorque`, contact.wall_torque).  In Stokes flow the liquid between the
sphere and the wall turns a sliding sphere toward rolling, T = 8 pi mu a^2 c_yx U (fem_bounce.wall_tangential); at
finite Re the outer flow's shear on the far side of the sphere, thinned by inertia, turns it the other way.  The
3-D model's torque on the held sphere, C_T = T / (rho_l U^2 pi a^3 / 2) (the same benchmark at 24 cells/D, the
table fem_bounce/data/wall_torque_fd3d.csv), has the opposite sign to Stokes flow's near the wall at Re 10-150
(docs/physics.md section 7 gives its values and checks).
The reduced model keeps its Stokes coupling and adds the excess

    T_excess = [C_T(Re, delta / a) - 32 c_yx(delta / a) / Re] rho_l U |U| pi a^3 / 2,

interpolated and held as the lift is; below the table's lowest Re (10) the held excess, ~U^2, falls away against
the Stokes torque, ~U.
"""
from __future__ import annotations

import math

import numpy as np

from . import reference
from .wall_tangential import wall_tangential_resistance

TABLE = "wall_lift_fd3d"
TORQUE_TABLE = "wall_torque_fd3d"


class SlidingCoefficient:
    """A coefficient C(Re, gap / a) of a sphere sliding along a wall, from the `column` of a packaged table over Re
    and gap_over_a (module docstring: interpolated linearly in ln Re and gap / a, held at the ends but the largest
    gap, past which it falls to zero at twice it)."""

    def __init__(self, table: str, column: str, diameter: float, density: float, viscosity: float):
        rows = reference.table(table)
        self.gaps = np.array(sorted({row["gap_over_a"] for row in rows}))  # delta / a
        self.reynolds = np.array(sorted({row["Re"] for row in rows}))
        self.log_reynolds = np.log(self.reynolds)
        values = {(row["Re"], row["gap_over_a"]): row[column] for row in rows}
        self.coefficients = np.array([[values[re, gap] for gap in self.gaps] for re in self.reynolds])
        self.radius = 0.5 * diameter
        self._re_per_speed = density * diameter / viscosity

    def coefficient(self, reynolds: float, gap: float) -> float:
        """C at Re and the gap [m] (module docstring)."""
        return self.coefficient_slopes(reynolds, gap)[0]

    def coefficient_slopes(self, reynolds: float, gap: float) -> tuple[float, float, float]:
        """(C, dC/d ln Re, dC/d gap [1/m]) at Re and the gap [m]: the interpolation's own slopes (those of the
        segment a point lies in; zero where C is held)."""
        ratio = gap / self.radius
        last = self.gaps[-1]
        if ratio >= 2.0 * last:
            return 0.0, 0.0, 0.0
        taper, taper_slope = (1.0, 0.0) if ratio <= last else (2.0 - ratio / last, -1.0 / last)
        held_gap = not self.gaps[0] < ratio < last
        ratio = min(max(ratio, self.gaps[0]), last)
        log_re = math.log(max(reynolds, 1e-300))
        held_re = not self.log_reynolds[0] < log_re < self.log_reynolds[-1]
        log_re = min(max(log_re, self.log_reynolds[0]), self.log_reynolds[-1])
        i = min(max(int(np.searchsorted(self.gaps, ratio)) - 1, 0), len(self.gaps) - 2)
        j = min(max(int(np.searchsorted(self.log_reynolds, log_re)) - 1, 0), len(self.log_reynolds) - 2)
        s = (ratio - self.gaps[i]) / (self.gaps[i + 1] - self.gaps[i])
        r = (log_re - self.log_reynolds[j]) / (self.log_reynolds[j + 1] - self.log_reynolds[j])
        c = self.coefficients
        low, high = (1.0 - s) * c[j, i] + s * c[j, i + 1], (1.0 - s) * c[j + 1, i] + s * c[j + 1, i + 1]
        value = (1.0 - r) * low + r * high
        d_log_re = 0.0 if held_re else (high - low) / (self.log_reynolds[j + 1] - self.log_reynolds[j])
        d_ratio = 0.0 if held_gap else ((1.0 - r) * (c[j, i + 1] - c[j, i]) + r * (c[j + 1, i + 1] - c[j + 1, i])) / (
            self.gaps[i + 1] - self.gaps[i])
        return taper * value, taper * d_log_re, (taper * d_ratio + taper_slope * value) / self.radius


class WallLift(SlidingCoefficient):
    """F_L(gap, U) of one sphere in one liquid (module docstring)."""

    def __init__(self, diameter: float, density: float, viscosity: float):
        super().__init__(TABLE, "C_L", diameter, density, viscosity)
        self._pressure_area = 0.5 * density * math.pi * self.radius**2  # F_L = this C_L U^2

    def force(self, gap: float, velocity: float) -> float:
        """F_L [N] away from the wall of a sphere sliding at `velocity` [m/s] at the gap [m]."""
        return self.force_slopes(gap, velocity)[0]

    def force_slopes(self, gap: float, velocity: float) -> tuple[float, float, float]:
        """(F_L [N], dF_L/d gap [N/m], dF_L/d velocity [N s/m])."""
        if velocity == 0.0:
            return 0.0, 0.0, 0.0
        value, d_log_re, d_gap = self.coefficient_slopes(self._re_per_speed * abs(velocity), gap)
        scale = self._pressure_area * velocity**2
        return scale * value, scale * d_gap, self._pressure_area * velocity * (2.0 * value + d_log_re)


class WallTorque(SlidingCoefficient):
    """T_excess(gap, U) of one sphere in one liquid: the sliding sphere's torque at finite Re beyond the Stokes
    coupling (module docstring); positive in the rolling sense of +U."""

    def __init__(self, diameter: float, density: float, viscosity: float):
        super().__init__(TORQUE_TABLE, "C_T", diameter, density, viscosity)
        couplings = [-wall_tangential_resistance(1.0, 1.0, gap)[0][1, 0] / (8.0 * math.pi) for gap in self.gaps]
        self.coefficients = self.coefficients - 32.0 * np.outer(1.0 / self.reynolds, couplings)  # less Stokes's
        self._pressure_volume = 0.5 * density * math.pi * self.radius**3  # T = this C U |U|

    def torque_slopes(self, gap: float, velocity: float) -> tuple[float, float, float]:
        """(T_excess [N m], dT/d gap [N], dT/d velocity [N s])."""
        if velocity == 0.0:
            return 0.0, 0.0, 0.0
        value, d_log_re, d_gap = self.coefficient_slopes(self._re_per_speed * abs(velocity), gap)
        scale = self._pressure_volume * velocity * abs(velocity)
        return scale * value, scale * d_gap, self._pressure_volume * abs(velocity) * (2.0 * value + d_log_re)
