"""One time step of the flow with the immersed-boundary forces: the discrete
stream-function (null-space) projection method of Colonius & Taira (2008),
axisymmetric, with the forces found implicitly (Taira & Colonius 2007).

Per step, with q the interior velocities, f the Lagrangian forces and E the
interpolation to the sphere's points (spreading is E^T):

    M (q' - q)/dt = nu/2 (L q' + L q) - (3/2 N(q) - 1/2 N(q_old)) + E^T f - G p    (CN + AB2)
    D q' = 0,   E q' = u_B                                                    (incompressible, no slip)

Writing q' = C psi + q_b (C the discrete curl, so D q' = 0 identically; q_b the
part set by prescribed boundary fluxes) and multiplying by C^T removes the
pressure (C^T G = 0):

    K psi = C^T (r + E^T f - A q_b),     K = C^T A C,   A = M/dt - nu L/2

K is symmetric positive definite and does not depend on where the sphere is: it
is factorised once per time-step size.  The forces solve the small system

    S f = u_B - E q0,   S = (E C) K^-1 (E C)^T      (symmetric, 2 x points unknowns)

by conjugate gradients, one back-substitution with K per iteration.  There is no
splitting error: q' satisfies the momentum equation, D q' = 0 and E q' = u_B to
the solver tolerances.  The pressure is not needed to advance; `pressure()`
recovers it for output from D^T p = A q' - r - E^T f.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
import scipy.sparse.linalg as spla
from petsc4py import PETSc

from .grid import INFLOW
from .operators import AxisymmetricOperators


class ForceSolveError(RuntimeError):
    """Conjugate gradients on the force system did not converge."""


@dataclass
class Prediction:
    """The step without immersed forces: q0 = C psi0 + q_b satisfies everything but no slip."""

    rhs: np.ndarray  # explicit right-hand side r [m^4/s^2]
    psi: np.ndarray
    q: np.ndarray
    q_boundary: np.ndarray
    w_top: np.ndarray  # normal velocity through the top after the step [m/s]


@dataclass
class ForceSolution:
    forces: np.ndarray  # f [m^4/s^2], [f_u (points), f_w (points)]
    psi: np.ndarray  # K^-1 (E C)^T f
    iterations: int
    slip: float  # rms of E q' - u_B left [m/s]


class FlowSolver:
    """Owns the flow state (q, the previous convection term) and the factorisation of K."""

    def __init__(self, ops: AxisymmetricOperators, viscosity: float, dt: float):
        self.ops = ops
        self.grid = g = ops.grid
        self.nu = viscosity  # kinematic [m^2/s]
        self.curl = ops.curl
        self.curl_t = ops.curl.T.tocsr()
        self.psi = np.zeros(g.n_psi)
        self.inflow = g.boundaries.bottom == INFLOW
        u_in = g.boundaries.inflow_velocity if self.inflow else 0.0
        self.w_bottom = np.full(g.nr, u_in)
        self.w_top = np.full(g.nr, u_in)
        self.q_boundary = self._boundary_velocity(self.w_top)
        if self.inflow:  # start from the uniform stream, psi = U r^2 / 2
            self.psi = np.broadcast_to(0.5 * u_in * g.R[1:-1, None] ** 2, (g.nr - 1, g.nz - 1)).ravel().copy()
        self.q = self.curl @ self.psi + self.q_boundary
        self.forcing = np.zeros(g.n_velocity)  # E^T f of the last step
        self.last_rhs = np.zeros(g.n_velocity)
        self._conv_old: np.ndarray | None = None
        self._dt_old: float | None = None
        self._poisson = None
        self._ksp = self._K = self._b = self._x = None
        self.dt = 0.0
        self.set_time_step(dt)

    # -- operators that depend on dt ---------------------------------------------------------
    def set_time_step(self, dt: float) -> None:
        """(Re)factorise K for a new time step [s]: sparse Cholesky with nested-dissection
        ordering (PETSc options prefix `ib_stream_`), which fills in about half of what SuperLU does."""
        if self.dt and self._dt_old is None:
            self._dt_old = self.dt
        self.dt = dt
        self.A = (sp.diags(self.ops.mass / dt) - 0.5 * self.nu * self.ops.laplacian).tocsr()
        K = (self.curl_t @ self.A @ self.curl).tocsr()
        K.sort_indices()
        self.destroy()
        self._K = PETSc.Mat().createAIJ(size=K.shape, csr=(K.indptr, K.indices, K.data), comm=PETSc.COMM_SELF)
        self._K.setOption(PETSc.Mat.Option.SYMMETRIC, True)
        self._K.setOption(PETSc.Mat.Option.SPD, True)
        ksp = PETSc.KSP().create(PETSc.COMM_SELF)
        ksp.setOptionsPrefix("ib_stream_")
        ksp.setOperators(self._K)
        ksp.setType("preonly")
        pc = ksp.getPC()
        pc.setType("cholesky")
        pc.setFactorOrdering("nd")
        ksp.setFromOptions()
        ksp.setUp()
        self._ksp = ksp
        self._b, self._x = self._K.createVecs()
        self.K_nnz = K.nnz

    def solve_K(self, rhs: np.ndarray) -> np.ndarray:
        """psi = K^-1 rhs (one forward and one backward substitution)."""
        self._b.setArray(rhs)
        self._ksp.solve(self._b, self._x)
        return self._x.getArray().copy()

    def destroy(self) -> None:
        """Free the PETSc objects (also called before refactorising)."""
        for name in ("_ksp", "_K", "_b", "_x"):
            obj = getattr(self, name, None)
            if obj is not None:
                obj.destroy()
                setattr(self, name, None)

    # -- boundary data ---------------------------------------------------------------------------
    def _boundary_psi(self, w_top: np.ndarray) -> np.ndarray:
        """Full psi with only its boundary values set, from the in- and outflow [m^3/s]."""
        g = self.grid
        psi = np.zeros((g.nr + 1, g.nz + 1))
        if self.inflow:
            u_in = g.boundaries.inflow_velocity
            psi[:, 0] = 0.5 * u_in * g.R**2
            psi[-1, :] = psi[-1, 0]
            psi[1:, -1] = np.cumsum(w_top * g.rc * g.dr)
        return psi

    def _boundary_velocity(self, w_top: np.ndarray) -> np.ndarray:
        u, w = self.ops.velocity_from_psi(self._boundary_psi(w_top))
        return self.ops.pack(u, w)

    def _outflow(self, u: np.ndarray, w: np.ndarray) -> np.ndarray:
        """Convective outflow dw/dt + U dw/dz = 0 at the top (explicit upwind), rescaled so the
        outflow equals the inflow."""
        if not self.inflow:
            return self.w_top
        g = self.grid
        u_in = g.boundaries.inflow_velocity
        top = w[:, -1] - u_in * self.dt / g.dzc[-1] * (w[:, -1] - w[:, -2])
        flux = np.sum(top * g.rc * g.dr)
        return top * (0.5 * u_in * g.R[-1] ** 2 / flux)

    # -- the step ------------------------------------------------------------------------------
    def full_velocity(self, q: np.ndarray | None = None, w_top: np.ndarray | None = None):
        return self.ops.unpack(self.q if q is None else q, self.w_bottom, self.w_top if w_top is None else w_top)

    def predict(self) -> Prediction:
        """The explicit right-hand side and the step's flow without immersed forces."""
        ops, dt = self.ops, self.dt
        u, w = self.full_velocity()
        conv = ops.convection(u, w)
        if self._conv_old is None:
            explicit = conv  # first step: forward Euler for the convection
        else:
            ratio = dt / self._dt_old
            explicit = (1.0 + 0.5 * ratio) * conv - 0.5 * ratio * self._conv_old
        w_top_new = self._outflow(u, w)
        lap_bc = ops.laplacian_boundary(self.w_bottom, self.w_top) + ops.laplacian_boundary(self.w_bottom, w_top_new)
        rhs = ops.mass * self.q / dt + 0.5 * self.nu * (ops.laplacian @ self.q + lap_bc) - explicit
        q_b = self._boundary_velocity(w_top_new)
        psi0 = self.solve_K(self.curl_t @ (rhs - self.A @ q_b))
        self._conv_now = conv
        return Prediction(rhs=rhs, psi=psi0, q=self.curl @ psi0 + q_b, q_boundary=q_b, w_top=w_top_new)

    def force_matrix(self, EC: sp.csr_matrix) -> np.ndarray:
        """S = EC K^-1 EC^T assembled column by column (2 x points back-substitutions)."""
        ECt = EC.T.tocsc()
        columns = [self.solve_K(ECt[:, k].toarray().ravel()) for k in range(EC.shape[0])]
        S = EC @ np.column_stack(columns)
        return 0.5 * (S + S.T)

    def solve_forces(self, EC: sp.csr_matrix, target: np.ndarray, guess: np.ndarray | None,
                     tol: float, preconditioner=None, max_iterations: int = 2000) -> ForceSolution:
        """Preconditioned CG on S f = target, S = EC K^-1 EC^T; stops when the rms slip left is
        below tol [m/s].  `preconditioner(residual)` approximates S^-1 residual."""
        ECt = EC.T.tocsr()
        n = len(target)
        precondition = preconditioner or (lambda v: v)

        def apply(p):
            psi_p = self.solve_K(ECt @ p)
            return EC @ psi_p, psi_p

        if guess is None or not np.any(guess):
            x = np.zeros(n)
            psi = np.zeros(self.grid.n_psi)
            res = target.copy()
        else:
            x = guess.copy()
            s_x, psi = apply(x)
            res = target - s_x
        limit = tol**2 * n
        z = precondition(res)
        rz = res @ z
        p = z.copy()
        it = 0
        while res @ res > limit:
            if it >= max_iterations:
                raise ForceSolveError(f"force system: no convergence in {max_iterations} CG iterations "
                                      f"(rms slip {np.sqrt(res @ res / n):.3g} m/s)")
            s_p, psi_p = apply(p)
            alpha = rz / (p @ s_p)
            x += alpha * p
            psi += alpha * psi_p
            res -= alpha * s_p
            z = precondition(res)
            rz_new = res @ z
            p = z + (rz_new / rz) * p
            rz = rz_new
            it += 1
        return ForceSolution(forces=x, psi=psi, iterations=it, slip=float(np.sqrt(res @ res / max(n, 1))))


    def accept(self, prediction: Prediction, psi_force: np.ndarray, spread_force: np.ndarray) -> None:
        """Make the step final: psi = psi0 + psi_force; spread_force = E^T f [m^4/s^2]."""
        self.psi = prediction.psi + psi_force
        self.q = self.curl @ self.psi + prediction.q_boundary
        self.w_top = prediction.w_top
        self.q_boundary = prediction.q_boundary
        self.forcing = spread_force
        self.last_rhs = prediction.rhs
        self._conv_old, self._dt_old = self._conv_now, self.dt

    # -- diagnostics -----------------------------------------------------------------------------
    def pressure(self) -> np.ndarray:
        """Kinematic pressure p / rho at the cell centres [m^2/s^2], zero in the far corner cell,
        from D^T p = A q - r - E^T f of the last step (exact: that residual lies in range(D^T))."""
        D = self.ops.divergence
        minv = sp.diags(1.0 / self.ops.mass)
        if self._poisson is None:
            P = (D @ minv @ D.T).tocsc()[:-1, :-1]  # pin the far corner cell: the system is singular
            self._poisson = spla.splu(P.tocsc(), permc_spec="MMD_AT_PLUS_A")
        residual = self.A @ self.q - self.last_rhs - self.forcing
        rhs = (D @ (residual / self.ops.mass))[:-1]
        p = np.zeros(self.grid.n_cells)
        p[:-1] = self._poisson.solve(rhs)
        return p.reshape(self.grid.nr, self.grid.nz)

    def cfl(self) -> float:
        """dt (max |u| / dr + max |w| / dz): an upper bound of the convective CFL number."""
        g = self.grid
        u, w = self.full_velocity()
        radial = np.max(np.abs(u[1:-1]) / g.drc[1:-1, None]) if g.nr > 1 else 0.0
        return float(self.dt * (radial + np.max(np.abs(w) / g.dzc[None, :])))

    def divergence(self) -> np.ndarray:
        u, w = self.full_velocity()
        return self.ops.divergence_full(u, w)


class ForcePreconditioner:
    """S^-1 approximated from force matrices assembled earlier at nearby sub-cell offsets.

    S depends on where the points sit relative to the grid, and, away from the wall
    and the far field, only on that: shifting the sphere by whole cells leaves S
    nearly unchanged (CG then converges in ~2 iterations).  So S is assembled (once,
    lazily) at `offsets` sub-cell positions of the sphere's centre; a step uses the
    linear interpolation of the two neighbouring tables, Cholesky-factorised, as
    its preconditioner (~5 iterations).  A table that needed more than
    `stale_after` iterations is assembled again where the sphere is now.  Tables
    depend on dt: call `clear()` after refactorising K.
    """

    def __init__(self, h: float, offsets: int = 8, stale_after: int = 12):
        self.h, self.offsets, self.stale_after = h, offsets, stale_after
        self.tables: dict[int, np.ndarray] = {}
        self.assembled = 0

    def clear(self) -> None:
        self.tables.clear()

    def build(self, solver: FlowSolver, z_centre: float, EC_at) -> tuple[np.ndarray, list[int]]:
        """(S, keys): S interpolated for a sphere centred at z_centre [m]; EC_at(z) gives the
        interpolation-times-curl matrix (all points) for a centre at z."""
        position = z_centre / self.h * self.offsets
        k0 = int(np.floor(position))
        frac = position - k0
        keys = [k0 % self.offsets, (k0 + 1) % self.offsets]
        for k, shift in zip(keys, (k0, k0 + 1)):
            if k not in self.tables:
                self.tables[k] = solver.force_matrix(EC_at(shift * self.h / self.offsets))
                self.assembled += 1
        S = (1.0 - frac) * self.tables[keys[0]] + frac * self.tables[keys[1]]
        return S, keys

    def mark_stale(self, keys) -> None:
        for k in keys:
            self.tables.pop(k, None)
