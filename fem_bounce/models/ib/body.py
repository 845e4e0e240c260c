"""The sphere as Lagrangian points on its meridian half-circle (paper section 2.1).

Points sit at polar angles theta_k = (k + 1/2) pi / N from the bottom pole, so none
lies on the axis (where a radial force has no meaning) and their spacing
pi a / N is about `spacing` cells, as Taira & Colonius (2007) recommend (~1 cell).
"""
from __future__ import annotations

import math

import numpy as np


def meridian_points(radius: float, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """(r, z - z_centre) of the points on a meridian of a sphere of `radius`, `spacing` apart [m]."""
    n = max(4, math.ceil(math.pi * radius / spacing))
    theta = (np.arange(n) + 0.5) * math.pi / n
    return radius * np.sin(theta), -radius * np.cos(theta)


class SphereSurface:
    """Where the points are for a given gap, and which of them the wall already holds."""

    def __init__(self, radius: float, spacing: float, retraction: float = 0.0, wall_exclusion: float = 0.0):
        """retraction: points on radius a - retraction (Breugem 2012's thickness correction) [m];
        wall_exclusion: points closer to a no-slip wall than this carry no constraint [m]."""
        self.radius = radius
        self.r, self.z_offset = meridian_points(radius - retraction, spacing)
        self.wall_exclusion = wall_exclusion

    @property
    def n_points(self) -> int:
        return len(self.r)

    def positions(self, gap: float) -> tuple[np.ndarray, np.ndarray]:
        """(r, z) of all points for a sphere whose lowest point is `gap` above z = 0."""
        return self.r, gap + self.radius + self.z_offset

    def active(self, gap: float) -> np.ndarray:
        """Mask of the points that carry a no-slip constraint at this gap."""
        return self.positions(gap)[1] >= self.wall_exclusion
