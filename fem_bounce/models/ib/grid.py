"""The staggered axisymmetric (r, z) grid: uniform near the sphere's path, graded outside.

Nodes R_0 = 0 < R_1 < ... < R_Nr and Z_0 = 0 < ... < Z_Nz bound the cells.
Unknowns sit as in a MAC grid (Harlow & Welch 1965), in (r, z):

    u (radial velocity)   at (R_i, zc_j)     i = 0..Nr, j = 0..Nz-1
    w (axial velocity)    at (rc_i, Z_j)     i = 0..Nr-1, j = 0..Nz
    p (pressure)          at (rc_i, zc_j)    cell centres
    psi (Stokes stream function), vorticity at the nodes (R_i, Z_j)

The paper (section 2.1) nests three uniform grids, each twice as coarse, to
push the slip far field away.  Here one tensor grid does the same job: cells of
size h = D / cells_per_diameter cover the region the sphere and its near wake
visit, then grow geometrically (ratio `growth`) to the far boundary.  The
regularised delta function only ever touches the uniform part.

All lengths in metres.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# boundary kinds of the four sides
WALL = "wall"  # no slip, no penetration
SLIP = "slip"  # no penetration, no shear stress
INFLOW = "inflow"  # uniform axial stream enters (z = 0 only)
OUTFLOW = "outflow"  # convective outflow (top only)
BOUNDARY_KINDS = (WALL, SLIP, INFLOW, OUTFLOW)


def graded_axis(fine_lo: float, fine_hi: float, h: float, lo: float, hi: float, growth: float) -> np.ndarray:
    """Nodes on [lo, hi]: spacing h on [fine_lo, fine_hi], growing by `growth` per cell
    outside it.  fine_lo - lo and hi - fine_hi are covered by whole graded cells, scaled
    so the last node lands on the boundary."""
    if not lo <= fine_lo < fine_hi <= hi:
        raise ValueError(f"fine range [{fine_lo}, {fine_hi}] is not inside [{lo}, {hi}]")
    n_fine = max(1, int(round((fine_hi - fine_lo) / h)))
    fine = fine_lo + h * np.arange(n_fine + 1)
    upper = fine_lo + n_fine * h

    def stretch(length: float) -> np.ndarray:
        if length <= 0.5 * h:
            return np.zeros(0)
        if growth == 1.0:
            n = max(1, int(round(length / h)))
            sizes = np.full(n, length / n)
        else:
            n = 1
            while h * sum(growth ** k for k in range(1, n + 1)) < length:
                n += 1
            sizes = h * growth ** np.arange(1, n + 1)
            sizes *= length / sizes.sum()
        return np.cumsum(sizes)

    above = upper + stretch(hi - upper)
    below = fine_lo - stretch(fine_lo - lo)[::-1]
    nodes = np.concatenate([below, fine, above])
    # a remainder below half a cell is absorbed into the first or last cell
    nodes[0], nodes[-1] = lo, hi
    return nodes


@dataclass(frozen=True)
class Boundaries:
    """Kinds of the bottom (z = 0), top and outer (r = R) sides; the axis is always symmetric."""

    bottom: str = WALL
    top: str = SLIP
    outer: str = SLIP
    inflow_velocity: float = 0.0  # [m/s] axial, when bottom is INFLOW

    def __post_init__(self):
        for side in ("bottom", "top", "outer"):
            if getattr(self, side) not in BOUNDARY_KINDS:
                raise ValueError(f"boundary {side} = {getattr(self, side)!r}")
        if self.bottom == OUTFLOW or self.top == INFLOW or self.outer in (INFLOW, OUTFLOW):
            raise ValueError("inflow only at the bottom, outflow only at the top")
        if (self.bottom == INFLOW) != (self.top == OUTFLOW):
            raise ValueError("an inflow at the bottom needs an outflow at the top, and back")


class StaggeredGrid:
    """Node coordinates and the derived widths, centres and index maps of the MAC grid.

    `h` is the uniform spacing of the fine region [0, r_fine] x [z_fine_lo, z_fine_hi]."""

    def __init__(self, r_nodes: np.ndarray, z_nodes: np.ndarray, h: float, fine_r: float,
                 fine_z: tuple[float, float], boundaries: Boundaries = Boundaries()):
        self.R = np.asarray(r_nodes, dtype=float)
        self.Z = np.asarray(z_nodes, dtype=float)
        if self.R[0] != 0.0 or self.Z[0] != 0.0 or np.any(np.diff(self.R) <= 0) or np.any(np.diff(self.Z) <= 0):
            raise ValueError("grid nodes must start at 0 and increase")
        self.h = h
        self.fine_r = fine_r
        self.fine_z = fine_z
        self.boundaries = boundaries
        self.nr, self.nz = len(self.R) - 1, len(self.Z) - 1
        self.dr, self.dz = np.diff(self.R), np.diff(self.Z)
        self.rc, self.zc = 0.5 * (self.R[1:] + self.R[:-1]), 0.5 * (self.Z[1:] + self.Z[:-1])
        # distances between neighbouring centres; the end ones reach the boundary (half a cell)
        self.drc = np.diff(np.concatenate([[0.0], self.rc, [self.R[-1]]]))  # len nr + 1, at R_i
        self.dzc = np.diff(np.concatenate([[0.0], self.zc, [self.Z[-1]]]))  # len nz + 1, at Z_j

    # -- sizes and index maps ------------------------------------------------------------
    @property
    def n_u(self) -> int:
        """Interior radial-velocity unknowns: i = 1..Nr-1 (axis and outer side excluded), every j."""
        return (self.nr - 1) * self.nz

    @property
    def n_w(self) -> int:
        """Interior axial-velocity unknowns: j = 1..Nz-1 (bottom and top excluded), every i."""
        return self.nr * (self.nz - 1)

    @property
    def n_velocity(self) -> int:
        return self.n_u + self.n_w

    @property
    def n_cells(self) -> int:
        return self.nr * self.nz

    @property
    def n_psi(self) -> int:
        """Interior stream-function nodes: the dimension of the divergence-free space."""
        return (self.nr - 1) * (self.nz - 1)

    def in_fine_region(self, r_lo: float, r_hi: float, z_lo: float, z_hi: float) -> bool:
        """Is the box inside the uniform region (where the delta kernel may act)?"""
        eps = 1e-9 * self.h
        return r_hi <= self.fine_r + eps and self.fine_z[0] - eps <= z_lo and z_hi <= self.fine_z[1] + eps

    def describe(self) -> dict:
        return {"cells": self.n_cells, "nr": self.nr, "nz": self.nz, "h": self.h,
                "fine_cells": int(round(self.fine_r / self.h)) * int(round((self.fine_z[1] - self.fine_z[0]) / self.h)),
                "radius": float(self.R[-1]), "height": float(self.Z[-1]),
                "max_cell": float(max(self.dr.max(), self.dz.max())),
                "unknowns": self.n_psi}


def make_grid(h: float, fine_r: float, fine_z: tuple[float, float], radius: float, height: float,
              growth: float, boundaries: Boundaries) -> StaggeredGrid:
    """A graded grid with uniform spacing h on [0, fine_r] x fine_z inside [0, radius] x [0, height]."""
    fine_r = min(h * math.ceil(fine_r / h - 1e-9), radius)
    lo = max(0.0, h * math.floor(fine_z[0] / h + 1e-9))
    hi = min(lo + h * math.ceil((fine_z[1] - lo) / h - 1e-9), height)
    r_nodes = graded_axis(0.0, fine_r, h, 0.0, radius, growth)
    z_nodes = graded_axis(lo, hi, h, 0.0, height, growth)
    return StaggeredGrid(r_nodes, z_nodes, h, fine_r, (lo, hi), boundaries)
