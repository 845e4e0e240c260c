"""The sphere in the fixed mesh: a smoothed indicator and the forcing responses of one step.

    phi(x) = S((a_h - |x - X_p|) / w),   S(x) = x^2 (3 - 2 x) on [0, 1], 0 below, 1 above,

is 1 deep inside the sphere, falls smoothly (C^1) across a band of width w inside
the surface and is exactly 0 outside a_h.  The support matters: the immersed force
rho c phi (U - u~) acts, at steady state, like a Brinkman friction of strength about
rho c phi, and c = 3 / (2 dt) is large, so any tail of phi outside the sphere (a
tanh profile has one) drags the fluid there along and inflates the body: with a
tanh half-level at a and a one-cell width, Cd(Re = 100) came out 1.59 instead of
1.09.  With compact support the effective surface sits where rho c phi first beats
the local shear rate, about half a cell inside a_h for a two-cell band; hence the
default a_h = a + h/2 (numerics.FdNumerics.radius_offset, the same in cells at
every resolution).

Only phi, b_phi = assemble(phi e_z . v r dx), V_phi and the forcing vector
assemble(-rho c phi u~ . v r dx) change with the sphere's position.  They are
assembled here by a small vectorised loop over the cells that meet the sphere
(`BandAssembler`), with phi evaluated exactly at the quadrature points; the UFL
forms of the same quantities (`indicator`, `reference_forms`) are the plain
reference the tests compare it with.  I(w) = 2 pi b_phi . w is every weighted
interior integral.
"""
from __future__ import annotations

import math

import basix
import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from .coupling import InteriorIntegrals
from .fluid import FlowSolver

QUADRATURE_DEGREE = 6  # per cell: integrates the C^1 cubic profile across a two-cell band to ~1e-4


def indicator(x, center, radius: float, width: float):
    """The smoothed indicator of a sphere of `radius` centred on the axis at z = center,
    falling from 1 to 0 across the band radius - width < |x - X_p| < radius (a UFL expression)."""
    distance = ufl.sqrt(x[0] ** 2 + (x[1] - center) ** 2)
    depth = ufl.min_value(ufl.max_value((radius - distance) / width, 0.0), 1.0)
    return depth**2 * (3.0 - 2.0 * depth)


def smooth_step(depth: np.ndarray) -> np.ndarray:
    """S of the indicator, vectorised."""
    depth = np.clip(depth, 0.0, 1.0)
    return depth**2 * (3.0 - 2.0 * depth)


def reference_forms(flow: FlowSolver, center, radius: float, width: float) -> dict:
    """UFL forms of b_phi, the forcing vector and V_phi: the plain reference for BandAssembler."""
    mesh = flow.mesh
    phi = indicator(ufl.SpatialCoordinate(mesh), center, radius, width)
    dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": QUADRATURE_DEGREE})
    v, r = flow.test_velocity, flow.r
    predicted = ufl.split(flow.predicted)[0]
    return {"indicator": fem.form(phi * v[1] * r * dx),
            "forcing": fem.form(-flow.density * flow.c * phi * ufl.inner(predicted, v) * r * dx),
            "volume": fem.form(2.0 * math.pi * phi * r * dx)}


class BandAssembler:
    """Assembles the indicator integrals over the owned cells that meet a ball centred on the axis.

    P2 velocity on affine triangles: per cell the quadrature points and r-weighted
    Jacobian weights are computed once; a placement selects the cells within reach of
    the ball and evaluates phi there."""

    def __init__(self, flow: FlowSolver, radius: float, width: float):
        mesh = flow.mesh
        self.radius, self.width = radius, width
        owned = mesh.topology.index_map(2).size_local
        nodes = mesh.geometry.dofmap.array.reshape(-1, 3)[:owned]
        corners = mesh.geometry.x[nodes][:, :, :2]  # (cells, 3, 2)
        points, weights = basix.make_quadrature(basix.CellType.triangle, QUADRATURE_DEGREE)
        element = basix.create_element(basix.ElementFamily.P, basix.CellType.triangle, 2,
                                       basix.LagrangeVariant.equispaced)
        self.basis = element.tabulate(0, points)[0, :, :, 0]  # (q, 6)
        jacobian = np.stack([corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]], axis=2)  # (c, 2, 2)
        self.points = corners[:, None, 0, :] + np.einsum("cij,qj->cqi", jacobian, points)  # (c, q, 2)
        det = np.abs(np.linalg.det(jacobian))
        self.weights = det[:, None] * weights[None, :] * self.points[:, :, 0]  # r dx per point
        centroid = corners.mean(axis=1)
        self.centroid_r, self.centroid_z = centroid[:, 0], centroid[:, 1]
        self.reach = np.linalg.norm(corners - centroid[:, None, :], axis=2).max(axis=1)
        self.dofs_r = flow.W.sub(0).sub(0).dofmap.list.array.reshape(-1, 6)[:owned]
        self.dofs_z = flow.W.sub(0).sub(1).dofmap.list.array.reshape(-1, 6)[:owned]
        self.cells = np.zeros(0, dtype=np.int64)
        self.phi_weights = np.zeros((0, len(weights)))

    def place(self, center: float) -> None:
        """Select the cells that meet the ball and tabulate phi * r * dx at their quadrature points."""
        distance = np.hypot(self.centroid_r, self.centroid_z - center)
        self.cells = np.flatnonzero(distance - self.reach < self.radius)
        p = self.points[self.cells]
        depth = (self.radius - np.hypot(p[:, :, 0], p[:, :, 1] - center)) / self.width
        self.phi_weights = smooth_step(depth) * self.weights[self.cells]  # (c, q)

    def indicator(self, local: np.ndarray) -> float:
        """Add the cells' part of b_phi into a W-vector's local array; return their part of V_phi / (2 pi)."""
        np.add.at(local, self.dofs_z[self.cells], self.phi_weights @ self.basis)
        return float(self.phi_weights.sum())

    def forcing(self, local: np.ndarray, velocity: np.ndarray, scale: float) -> None:
        """Add scale * int phi u . v r dx (u: a W-function's local array) into a W-vector's local array."""
        for dofs in (self.dofs_r[self.cells], self.dofs_z[self.cells]):
            at_points = velocity[dofs] @ self.basis.T  # (c, q)
            np.add.at(local, dofs, scale * (self.phi_weights * at_points) @ self.basis)


class ImmersedSphere:
    """Forcing responses of one sphere in `flow`; radius (outer edge of phi), width [m] of the
    indicator's band, center [m] of its first placement."""

    def __init__(self, flow: FlowSolver, radius: float, width: float, center: float):
        self.flow = flow
        self.band = BandAssembler(flow, radius, width)
        self.center = math.nan
        self.b_phi = flow.rhs.duplicate()
        self.force = flow.rhs.duplicate()
        self.forced = fem.Function(flow.W)  # y0
        self.unit = fem.Function(flow.W)  # y1
        self._unit_at: float | None = None  # where y1 was computed
        self.volume = 0.0
        self.place(center)

    def place(self, center: float) -> None:
        """Put the indicator's centre at z = center [m] and assemble b_phi and V_phi."""
        self.center = center
        self.band.place(center)
        with self.b_phi.localForm() as local:
            local.set(0.0)
            part = self.band.indicator(local.array)
        self.b_phi.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.volume = 2.0 * math.pi * self.flow.mesh.comm.allreduce(part, op=MPI.SUM)

    def interior(self, vector: PETSc.Vec) -> float:
        """I(w) = 2 pi int phi w_z r dx of a mixed-space vector [m^4/s for a velocity]."""
        return 2.0 * math.pi * self.b_phi.dot(vector)

    @property
    def unit_stale(self) -> bool:
        """True when the sphere moved since y1 was computed."""
        return self._unit_at != self.center

    def unit_forcing(self) -> PETSc.Vec:
        """rho c b_phi, ready for the flow solver; y1 = A^-1 of it must then go to `self.unit`."""
        flow, out = self.flow, self.force
        self.b_phi.copy(out)
        out.scale(flow.density * flow.c)
        with out.localForm() as local:  # b_phi is accumulated; force_rhs() accumulates ghosts again
            local.array[out.getLocalSize():] = 0.0
        self._unit_at = self.center
        return flow.force_rhs(out)

    def forcing(self, predicted: fem.Function) -> PETSc.Vec:
        """-rho c phi u~, ready for the flow solver; its response y0 goes to `self.forced`."""
        flow = self.flow
        with self.force.localForm() as local:
            local.set(0.0)
            self.band.forcing(local.array, predicted.x.array, -flow.density * flow.c)
        return flow.force_rhs(self.force)

    def integrals(self, predicted: fem.Function) -> InteriorIntegrals:
        return InteriorIntegrals(volume=self.volume, predicted=self.interior(predicted.vector),
                                 forced=self.interior(self.forced.vector), unit=self.interior(self.unit.vector))

    def destroy(self) -> None:
        self.b_phi.destroy()
        self.force.destroy()
