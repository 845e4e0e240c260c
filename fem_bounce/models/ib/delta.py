"""The regularised delta function and the interpolation / spreading operators.

Kernel: Roma, Peskin & Berger (1999), J. Comput. Phys. 153, 509, the three-cell
kernel Taira & Colonius (2007) use:

    phi(x) = (1 + sqrt(1 - 3 x^2)) / 3                         |x| <= 1/2
           = (5 - 3|x| - sqrt(1 - 3 (1 - |x|)^2)) / 6          1/2 <= |x| <= 3/2
           = 0                                                 otherwise

On a uniform grid it sums to one, has zero first moment, and sum phi^2 = 1/2
for every shift.  The 2-D kernel is phi(dr / h) phi(dz / h).

Interpolation E maps the interior velocities q to the velocities (U_k, W_k) at
Lagrangian points on the sphere's meridian.  Spreading is its transpose E^T: a
force f_k (the ring's force / 2 pi, kinematic: [m^4/s^2]) adds f_k phi phi to the
integrated momentum of each control volume, so sum_cells E^T f = sum_k f_k and
the force system E C K^-1 C^T E^T is symmetric.  Near the axis and the wall the
kernel is completed with mirror images: u is odd and w even in r; both vanish on
a no-slip wall, so both are odd in z there (ghost-cell convention).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .grid import WALL, StaggeredGrid

SUPPORT = 1.5  # kernel half-width in cells


def roma_kernel(x: np.ndarray) -> np.ndarray:
    """phi(x) of Roma, Peskin & Berger (1999), x in cells."""
    a = np.abs(np.asarray(x, dtype=float))
    out = np.zeros_like(a)
    inner = a <= 0.5
    outer = (a > 0.5) & (a <= SUPPORT)
    out[inner] = (1.0 + np.sqrt(1.0 - 3.0 * a[inner] ** 2)) / 3.0
    out[outer] = (5.0 - 3.0 * a[outer] - np.sqrt(np.maximum(1.0 - 3.0 * (1.0 - a[outer]) ** 2, 0.0))) / 6.0
    return out


def _weights_1d(coords: np.ndarray, points: np.ndarray, h: float, mirror: float) -> tuple[np.ndarray, np.ndarray]:
    """Indices (n_points, 4) of the grid coordinates within the kernel's reach and their
    weights phi((x - X)/h) + mirror * phi((x + X)/h) (mirror image about 0: +1 even, -1 odd, 0 none)."""
    first = np.searchsorted(coords, points - SUPPORT * h)
    idx = first[:, None] + np.arange(4)[None, :]
    valid = idx < len(coords)
    idx = np.minimum(idx, len(coords) - 1)
    x = coords[idx]
    weight = roma_kernel((x - points[:, None]) / h)
    if mirror:
        weight = weight + mirror * roma_kernel((x + points[:, None]) / h)
    return idx, np.where(valid, weight, 0.0)


def interpolation_matrix(grid: StaggeredGrid, r: np.ndarray, z: np.ndarray) -> sp.csr_matrix:
    """E (2 n_points x n_velocity): rows 0..n-1 give U at the points, rows n..2n-1 give W.

    The points must lie where the whole kernel sees the uniform spacing h."""
    h = grid.h
    r, z = np.asarray(r, dtype=float), np.asarray(z, dtype=float)
    n = len(r)
    wall = -1.0 if grid.boundaries.bottom == WALL else 0.0
    rows, cols, vals = [], [], []
    # u at (R_i, zc_j), interior i = 1..nr-1: odd about the axis
    iu_r, wu_r = _weights_1d(grid.R, r, h, -1.0)
    iu_z, wu_z = _weights_1d(grid.zc, z, h, wall)
    # w at (rc_i, Z_j), interior j = 1..nz-1: even about the axis
    iw_r, ww_r = _weights_1d(grid.rc, r, h, +1.0)
    iw_z, ww_z = _weights_1d(grid.Z, z, h, wall)
    point = np.repeat(np.arange(n), 16)
    for comp, (ir, wr, iz, wz) in enumerate([(iu_r, wu_r, iu_z, wu_z), (iw_r, ww_r, iw_z, ww_z)]):
        i = np.repeat(ir, 4, axis=1).ravel()
        j = np.tile(iz, (1, 4)).ravel()
        weight = (wr[:, :, None] * wz[:, None, :]).ravel()
        if comp == 0:
            keep = (i >= 1) & (i <= grid.nr - 1) & (weight != 0.0)
            col = (i - 1) * grid.nz + j
        else:
            keep = (j >= 1) & (j <= grid.nz - 1) & (weight != 0.0)
            col = grid.n_u + i * (grid.nz - 1) + (j - 1)
        rows.append(point[keep] + comp * n)
        cols.append(col[keep])
        vals.append(weight[keep])
    return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                         shape=(2 * n, grid.n_velocity))


def interpolate_reference(grid: StaggeredGrid, u: np.ndarray, w: np.ndarray, r: float, z: float) -> tuple[float, float]:
    """Plain double loop over the full arrays (with explicit images): the reference for E's fast path."""
    h = grid.h
    wall = grid.boundaries.bottom == WALL

    def phi2(x, y, x0, y0, odd_r):
        value_r = roma_kernel((x - x0) / h) + (-1.0 if odd_r else 1.0) * roma_kernel((x + x0) / h)
        value_z = roma_kernel((y - y0) / h) - (roma_kernel((y + y0) / h) if wall else 0.0)
        return value_r * value_z

    big_u = sum(u[i, j] * phi2(grid.R[i], grid.zc[j], r, z, True)
                for i in range(grid.nr + 1) for j in range(grid.nz))
    big_w = sum(w[i, j] * phi2(grid.rc[i], grid.Z[j], r, z, False)
                for i in range(grid.nr) for j in range(grid.nz + 1))
    return float(big_u), float(big_w)
