"""Finite-volume operators of the axisymmetric MAC grid, built once as sparse matrices.

Every operator is integrated over its control volume with the radial weight r
(the common factor 2 pi is dropped), so that (Li 2010; the paper's section 2.1)

    mass        M      = diag(volume of each velocity control volume)        [m^3]
    divergence  D q    = net volume flux out of each cell                    [m^3/s]
    curl        C psi  = velocities of the Stokes stream function:
                         u = -(1/r) d(psi)/dz,  w = (1/r) d(psi)/dr,  so D C = 0 exactly
    gradient    G      = -D^T  (the integrated pressure gradient)
    Laplacian   L q    = integrated vector Laplacian, with the hoop term -u/r^2 for u
    convection  N(q)   = integrated momentum flux div(q q) (no swirl, so no v^2/r term)

M and L are symmetric (L negative definite), which makes the stream-function
operator C^T (M/dt - nu L/2) C symmetric positive definite.

Velocity arrays come in two forms: "full" arrays u[nr+1, nz], w[nr, nz+1] that
include the axis and boundary normal components, and the vector q of interior
unknowns, q = [u[1:nr, :].ravel(), w[:, 1:nz].ravel()].
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from .grid import INFLOW, OUTFLOW, SLIP, WALL, StaggeredGrid


class AxisymmetricOperators:
    """The sparse operators of one grid and its boundary kinds (no state: pure functions of q)."""

    def __init__(self, grid: StaggeredGrid):
        self.grid = g = grid
        self.nr, self.nz = g.nr, g.nz
        R, rc, dr, drc = g.R, g.rc, g.dr, g.drc
        dz, dzc = g.dz, g.dzc
        # control-volume measures (radially weighted areas times lengths)
        self.vol_u = (R[1:-1] * drc[1:-1])[:, None] * dz[None, :]  # (nr-1, nz)
        self.vol_w = (rc * dr)[:, None] * dzc[None, 1:-1]  # (nr, nz-1)
        self.mass = np.concatenate([self.vol_u.ravel(), self.vol_w.ravel()])
        self.laplacian, self._lap_bottom, self._lap_top = self._build_laplacian()
        self.curl = self._build_curl()
        self.divergence = self._build_divergence()

    # -- packing ------------------------------------------------------------------------
    def pack(self, u: np.ndarray, w: np.ndarray) -> np.ndarray:
        """Full arrays -> interior unknowns q."""
        return np.concatenate([u[1:-1, :].ravel(), w[:, 1:-1].ravel()])

    def unpack(self, q: np.ndarray, w_bottom: np.ndarray | float = 0.0,
               w_top: np.ndarray | float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Interior unknowns (and the normal velocities through bottom and top) -> full arrays."""
        nr, nz, n_u = self.nr, self.nz, self.grid.n_u
        u = np.zeros((nr + 1, nz))
        u[1:-1, :] = q[:n_u].reshape(nr - 1, nz)
        w = np.empty((nr, nz + 1))
        w[:, 1:-1] = q[n_u:].reshape(nr, nz - 1)
        w[:, 0], w[:, -1] = w_bottom, w_top
        return u, w

    # -- linear operators ---------------------------------------------------------------------
    def _build_laplacian(self):
        """L (interior x interior) and the columns that couple w to the bottom and top values."""
        g = self.grid
        nr, nz = self.nr, self.nz
        R, rc, dr, drc, dz, dzc = g.R, g.rc, g.dr, g.drc, g.dz, g.dzc
        bnd = g.boundaries
        rows, cols, vals = [], [], []
        diag = np.zeros(g.n_velocity)

        def couple(p, q, a):
            """Flux a (phi_q - phi_p) between unknowns p and q: symmetric entries."""
            rows.extend([p, q])
            cols.extend([q, p])
            vals.extend([a, a])
            np.subtract.at(diag, p, a)
            np.subtract.at(diag, q, a)

        # radial velocity u[i, j], i = 1..nr-1
        iu = np.arange(g.n_u).reshape(nr - 1, nz)
        a_r = (rc[:, None] * dz[None, :]) / dr[:, None]  # across the cell centre rc_c, c = 0..nr-1
        couple(iu[:-1, :].ravel(), iu[1:, :].ravel(), a_r[1:-1, :].ravel())
        np.subtract.at(diag, iu[0, :], a_r[0, :])  # u = 0 on the axis
        np.subtract.at(diag, iu[-1, :], a_r[-1, :])  # u = 0 on the outer side (no penetration)
        diag[iu.ravel()] -= (drc[1:-1, None] * dz[None, :] / R[1:-1, None]).ravel()  # hoop term -u/r^2
        area_u = (R[1:-1] * drc[1:-1])[:, None]
        a_z = area_u / dzc[None, :]  # across Z_j, j = 0..nz
        couple(iu[:, :-1].ravel(), iu[:, 1:].ravel(), a_z[:, 1:-1].ravel())
        np.subtract.at(diag, iu[:, 0], a_z[:, 0])  # u = 0 at z = 0 (wall or uniform inflow)
        if bnd.top == WALL:
            np.subtract.at(diag, iu[:, -1], a_z[:, -1])
        # axial velocity w[i, j], j = 1..nz-1
        iw = g.n_u + np.arange(g.n_w).reshape(nr, nz - 1)
        b_r = R[:, None] * dzc[None, 1:-1] / drc[:, None]  # across R_i, i = 0..nr (zero on the axis)
        couple(iw[:-1, :].ravel(), iw[1:, :].ravel(), b_r[1:-1, :].ravel())
        if bnd.outer == WALL:
            np.subtract.at(diag, iw[-1, :], b_r[-1, :])
        b_z = (rc * dr)[:, None] / dz[None, :]  # across zc_j, j = 0..nz-1
        couple(iw[:, :-1].ravel(), iw[:, 1:].ravel(), b_z[:, 1:-1].ravel())
        np.subtract.at(diag, iw[:, 0], b_z[:, 0])
        np.subtract.at(diag, iw[:, -1], b_z[:, -1])
        n = g.n_velocity
        rows, cols, vals = (np.concatenate(x) for x in (rows, cols, vals))
        lap = sp.coo_matrix((vals, (rows, cols)), shape=(n, n)).tocsr() + sp.diags(diag)
        return lap.tocsr(), b_z[:, 0], b_z[:, -1]

    def laplacian_boundary(self, w_bottom, w_top) -> np.ndarray:
        """The part of L q that comes from prescribed normal velocities at the bottom and top."""
        out = np.zeros(self.grid.n_velocity)
        iw = self.grid.n_u + np.arange(self.grid.n_w).reshape(self.nr, self.nz - 1)
        out[iw[:, 0]] += self._lap_bottom * w_bottom
        out[iw[:, -1]] += self._lap_top * w_top
        return out

    def _build_curl(self) -> sp.csr_matrix:
        """C: interior stream-function nodes -> interior velocities [1/m^2]."""
        g = self.grid
        nr, nz = self.nr, self.nz
        ip = np.full((nr + 1, nz + 1), -1)
        ip[1:-1, 1:-1] = np.arange(g.n_psi).reshape(nr - 1, nz - 1)
        rows, cols, vals = [], [], []

        def add(row, node, value):
            keep = node >= 0
            rows.append(row[keep])
            cols.append(node[keep])
            vals.append(value[keep])

        iu = np.arange(g.n_u).reshape(nr - 1, nz)
        coef_u = 1.0 / (g.R[1:-1, None] * g.dz[None, :])
        add(iu.ravel(), ip[1:-1, 1:].ravel(), -coef_u.ravel())  # u = -(psi[i, j+1] - psi[i, j]) / (R dz)
        add(iu.ravel(), ip[1:-1, :-1].ravel(), coef_u.ravel())
        iw = g.n_u + np.arange(g.n_w).reshape(nr, nz - 1)
        coef_w = np.broadcast_to(1.0 / (g.rc * g.dr)[:, None], (nr, nz - 1))
        add(iw.ravel(), ip[1:, 1:-1].ravel(), coef_w.ravel())  # w = (psi[i+1, j] - psi[i, j]) / (rc dr)
        add(iw.ravel(), ip[:-1, 1:-1].ravel(), -coef_w.ravel())
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(g.n_velocity, g.n_psi))

    def velocity_from_psi(self, psi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Full velocity arrays from the full stream function psi[nr+1, nz+1] [m^3/s]."""
        g = self.grid
        u = np.zeros((self.nr + 1, self.nz))
        u[1:, :] = -(psi[1:, 1:] - psi[1:, :-1]) / (g.R[1:, None] * g.dz[None, :])
        w = (psi[1:, :] - psi[:-1, :]) / (g.rc * g.dr)[:, None]
        return u, w

    def _build_divergence(self) -> sp.csr_matrix:
        """D: interior velocities -> net outward volume flux per cell [m^2] (times velocity)."""
        g = self.grid
        nr, nz = self.nr, self.nz
        cell = np.arange(g.n_cells).reshape(nr, nz)
        iu = np.arange(g.n_u).reshape(nr - 1, nz)
        iw = g.n_u + np.arange(g.n_w).reshape(nr, nz - 1)
        area_u = g.R[1:-1, None] * g.dz[None, :]
        area_w = np.broadcast_to((g.rc * g.dr)[:, None], (nr, nz - 1))
        rows = [cell[:-1, :].ravel(), cell[1:, :].ravel(), cell[:, :-1].ravel(), cell[:, 1:].ravel()]
        cols = [iu.ravel(), iu.ravel(), iw.ravel(), iw.ravel()]
        vals = [area_u.ravel(), -area_u.ravel(), area_w.ravel(), -area_w.ravel()]
        return sp.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))),
                             shape=(g.n_cells, g.n_velocity))

    def divergence_full(self, u: np.ndarray, w: np.ndarray) -> np.ndarray:
        """Net outward volume flux of each cell from full arrays (boundary fluxes included)."""
        g = self.grid
        flux_r = g.R[:, None] * g.dz[None, :] * u  # (nr+1, nz)
        flux_z = (g.rc * g.dr)[:, None] * w  # (nr, nz+1)
        return (flux_r[1:] - flux_r[:-1]) + (flux_z[:, 1:] - flux_z[:, :-1])

    # -- nonlinear and diagnostic operators ------------------------------------------------------
    def _corner_values(self, u: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """u and w interpolated to the nodes (R_i, Z_j), honouring the boundary kinds."""
        g, bnd = self.grid, self.grid.boundaries
        nr, nz = self.nr, self.nz
        uc = np.zeros((nr + 1, nz + 1))
        t = (g.Z[1:-1] - g.zc[:-1]) / (g.zc[1:] - g.zc[:-1])
        uc[:, 1:-1] = (1.0 - t) * u[:, :-1] + t * u[:, 1:]
        if bnd.top in (SLIP, OUTFLOW):
            uc[:, -1] = u[:, -1]  # zero shear; u = 0 on walls and at the inflow
        wc = np.zeros((nr + 1, nz + 1))
        s = ((g.R[1:-1] - g.rc[:-1]) / (g.rc[1:] - g.rc[:-1]))[:, None]
        wc[1:-1, :] = (1.0 - s) * w[:-1, :] + s * w[1:, :]
        wc[0, :] = w[0, :]
        if bnd.outer == SLIP:
            wc[-1, :] = w[-1, :]
        return uc, wc

    def convection(self, u: np.ndarray, w: np.ndarray) -> np.ndarray:
        """N(q) = integrated div(q q) at the interior unknowns [m^4/s^2], central fluxes."""
        g = self.grid
        uc, wc = self._corner_values(u, w)
        uw = uc * wc  # momentum flux through the faces that meet at the nodes
        u_mid = 0.5 * (u[:-1, :] + u[1:, :])  # at cell centres
        flux_uu = (g.rc[:, None] * g.dz[None, :]) * u_mid**2
        flux_uw = (g.R[1:-1] * g.drc[1:-1])[:, None] * uw[1:-1, :]
        n_u = (flux_uu[1:, :] - flux_uu[:-1, :]) + (flux_uw[:, 1:] - flux_uw[:, :-1])
        w_mid = 0.5 * (w[:, :-1] + w[:, 1:])
        flux_ww = (g.rc * g.dr)[:, None] * w_mid**2
        flux_wu = g.R[:, None] * g.dzc[None, 1:-1] * uw[:, 1:-1]
        n_w = (flux_wu[1:, :] - flux_wu[:-1, :]) + (flux_ww[:, 1:] - flux_ww[:, :-1])
        return np.concatenate([n_u.ravel(), n_w.ravel()])

    def vorticity(self, u: np.ndarray, w: np.ndarray) -> np.ndarray:
        """Azimuthal vorticity du/dz - dw/dr at the nodes [1/s], shape (nr+1, nz+1)."""
        g, bnd = self.grid, self.grid.boundaries
        nr, nz = self.nr, self.nz
        du_dz = np.zeros((nr + 1, nz + 1))
        du_dz[:, 1:-1] = (u[:, 1:] - u[:, :-1]) / g.dzc[None, 1:-1]
        if bnd.bottom in (WALL, INFLOW):
            du_dz[:, 0] = u[:, 0] / g.dzc[0]
        if bnd.top == WALL:
            du_dz[:, -1] = -u[:, -1] / g.dzc[-1]
        dw_dr = np.zeros((nr + 1, nz + 1))
        dw_dr[1:-1, :] = (w[1:, :] - w[:-1, :]) / g.drc[1:-1, None]
        if bnd.outer == WALL:
            dw_dr[-1, :] = -w[-1, :] / g.drc[-1]
        omega = du_dz - dw_dr
        omega[0, :] = 0.0  # the axis
        return omega

    def nodal_velocity(self, u: np.ndarray, w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """u and w at the nodes (for output)."""
        uc, wc = self._corner_values(u, w)
        return uc, wc

    def nodal_from_cells(self, p: np.ndarray) -> np.ndarray:
        """A cell-centred field averaged to the nodes (edge and corner nodes copy their neighbours)."""
        padded = np.pad(p, 1, mode="edge")
        return 0.25 * (padded[:-1, :-1] + padded[1:, :-1] + padded[:-1, 1:] + padded[1:, 1:])
