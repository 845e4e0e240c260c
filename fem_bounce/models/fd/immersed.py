"""The spheres in the fixed mesh: each a smoothed indicator, and the forcing responses of one step.

    phi(x) = S((a_h - |x - X_p|) / w),   S(x) = x^2 (3 - 2 x) on [0, 1], 0 below, 1 above,

is 1 deep inside the sphere, falls smoothly (C^1) across a band of width w inside
the surface and is exactly 0 outside a_h.  The support matters: the immersed force
rho c phi (U - u~) acts, at steady state, like a Brinkman friction of strength about
rho c phi, and c = 3 / (2 dt) is large, so any tail of phi outside the sphere (a
tanh profile has one) drags the fluid there along and inflates the body: with a
tanh half-level at a and a one-cell width, Cd(Re = 100) came out 1.59 instead of
1.09.  With compact support the effective surface sits where rho c phi first beats
the local shear rate, about half a cell inside a_h for a two-cell band at its default
step (and further out as dt falls: docs/validation.md section 12); hence the one-shot
penalty's a_h = a + h/2 (numerics.FdNumerics.radius_offset, the same in cells at every
resolution).  The implicit penalisation (penalised.py) holds the whole band: a_h = a.

Only phi, b_phi = assemble(phi e_z . v dV), V_phi and the forcing vector
assemble(-rho c phi u~ . v dV) change with the sphere's position (dV: the flow's weighted measure,
fem.geometry, the physical volume's as in every form of the step).  They are
assembled here by a small vectorised loop over the cells that meet the sphere
(`BandAssembler`, weighted by the geometry's `weight_at`), with phi evaluated exactly at the quadrature
points; the UFL forms of the same quantities (`indicator`, `reference_forms`) are the plain
reference the tests compare it with.  I(w) = b_phi . w is every weighted interior integral.

Every sphere on the axis has its own indicator phi_i (ImmersedSphere) and unit response y1_i; the
forcing of -u~ is one vector over all of them, with one response y0 (ImmersedBodies; the algebra is
coupling.py's).  The indicators' supports |x - X_i| < a_h,i must not overlap (the forcing would count
the liquid between them twice and tie two interiors together): neighbouring surfaces must stay at least
(a_h,i - a_i) + (a_h,i+1 - a_i+1) apart: one fine cell with the penalty's radius_offset, none with the
implicit constraint's.  A pair's hold
gap (flow_model.flow_gaps) keeps the flow's spheres that far apart; `check_hold` refuses a scene whose
hold does not.
"""
from __future__ import annotations

import math

import basix
import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from ...fem.compat import collapse, geometry_cells
from ...scene import SceneError
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
    mesh, geometry = flow.mesh, flow.geometry
    phi = indicator(ufl.SpatialCoordinate(mesh), center, radius, width)
    dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": QUADRATURE_DEGREE})
    v = flow.test_velocity
    predicted = ufl.split(flow.predicted)[0]
    return {"indicator": fem.form(geometry.weighted(phi * v[1], dx)),
            "forcing": fem.form(geometry.weighted(-flow.density * flow.c * phi * ufl.inner(predicted, v), dx)),
            "volume": fem.form(geometry.weighted(phi, dx))}


class BandAssembler:
    """Assembles the indicator integrals over the owned cells that meet a ball centred on the axis.

    P2 velocity on affine triangles: per cell the quadrature points and weighted Jacobian
    weights (the flow geometry's `weight_at`) are computed once; a placement selects the cells
    within reach of the ball and evaluates phi there."""

    def __init__(self, flow: FlowSolver, radius: float, width: float):
        mesh = flow.mesh
        self.radius, self.width = radius, width
        owned = mesh.topology.index_map(2).size_local
        nodes = geometry_cells(mesh)[:owned]
        corners = mesh.geometry.x[nodes][:, :, :2]  # (cells, 3, 2)
        points, weights = basix.make_quadrature(basix.CellType.triangle, QUADRATURE_DEGREE)
        element = basix.create_element(basix.ElementFamily.P, basix.CellType.triangle, 2,
                                       basix.LagrangeVariant.equispaced)
        self.basis = element.tabulate(0, points)[0, :, :, 0]  # (q, 6)
        jacobian = np.stack([corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]], axis=2)  # (c, 2, 2)
        self.points = corners[:, None, 0, :] + np.einsum("cij,qj->cqi", jacobian, points)  # (c, q, 2)
        det = np.abs(np.linalg.det(jacobian))
        self.weights = det[:, None] * weights[None, :] * flow.geometry.weight_at(self.points)  # dV per point
        centroid = corners.mean(axis=1)
        self.centroid_r, self.centroid_z = centroid[:, 0], centroid[:, 1]
        self.reach = np.linalg.norm(corners - centroid[:, None, :], axis=2).max(axis=1)
        self.dofs_r = flow.W.sub(0).sub(0).dofmap.list[:owned]
        self.dofs_z = flow.W.sub(0).sub(1).dofmap.list[:owned]
        self.cells = np.zeros(0, dtype=np.int64)
        self.phi = self.phi_weights = np.zeros((0, len(weights)))

    def place(self, center: float) -> None:
        """Select the cells that meet the ball and tabulate phi dV at their quadrature points."""
        distance = np.hypot(self.centroid_r, self.centroid_z - center)
        self.cells = np.flatnonzero(distance - self.reach < self.radius)
        p = self.points[self.cells]
        depth = (self.radius - np.hypot(p[:, :, 0], p[:, :, 1] - center)) / self.width
        self.phi = smooth_step(depth)  # (c, q)
        self.phi_weights = self.phi * self.weights[self.cells]

    def indicator(self, local: np.ndarray) -> float:
        """Add the cells' part of b_phi into a W-vector's local array; return their part of V_phi."""
        np.add.at(local, self.dofs_z[self.cells], self.phi_weights @ self.basis)
        return float(self.phi_weights.sum())

    def forcing(self, local: np.ndarray, velocity: np.ndarray, scale: float) -> None:
        """Add scale * int phi u . v dV (u: a W-function's local array) into a W-vector's local array."""
        for dofs in (self.dofs_r[self.cells], self.dofs_z[self.cells]):
            at_points = velocity[dofs] @ self.basis.T  # (c, q)
            np.add.at(local, dofs, scale * (self.phi_weights * at_points) @ self.basis)


class ImmersedSphere:
    """One sphere's indicator in `flow` and its unit response y1; radius (outer edge of phi), width [m] of
    the indicator's band, center [m] of its first placement."""

    def __init__(self, flow: FlowSolver, radius: float, width: float, center: float):
        self.flow = flow
        self.band = BandAssembler(flow, radius, width)
        self.center = math.nan
        self.b_phi = flow.rhs.duplicate()
        self.force = flow.rhs.duplicate()
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
        self.volume = self.flow.geometry.total(part)

    def interior(self, vector: PETSc.Vec) -> float:
        """I(w) = int phi w_z dV of a mixed-space vector [m^4/s for a velocity]."""
        return self.b_phi.dot(vector)

    @property
    def unit_stale(self) -> bool:
        """True when the sphere moved since y1 was computed."""
        return self._unit_at != self.center

    def unit_forcing(self, rate: float | None = None) -> PETSc.Vec:
        """rho rate b_phi (rate [1/s], by default the step's c), ready for the flow solver; y1 = A^-1 of it must
        then go to `self.unit`."""
        flow, out = self.flow, self.force
        self.b_phi.copy(out)
        out.scale(flow.density * (flow.c if rate is None else rate))
        with out.localForm() as local:  # b_phi is accumulated; force_rhs() accumulates ghosts again
            local.array[out.getLocalSize():] = 0.0
        self._unit_at = self.center
        return flow.force_rhs(out)

    def destroy(self) -> None:
        self.b_phi.destroy()
        self.force.destroy()


def check_hold(min_gap: float, pair_hold: float, what: str) -> None:
    """Refuse a hold gap [m] below min_gap: the flow's spheres could come so close that their
    indicators overlap.  `what` says where the hold comes from, for the message."""
    if pair_hold < min_gap:
        raise SceneError(
            f"numerics.fd: neighbouring spheres' indicators overlap when their surfaces are closer than "
            f"{min_gap:.4g} m (radius_offset x fine size each), but the flow places them down to "
            f"{pair_hold:.4g} m apart ({what}): raise numerics.fd.cells_per_diameter or contact.delta_sl "
            f"(contact.near_wall = \"correction\" holds a pair at its delta_sl gap)")


class ImmersedBodies:
    """The spheres on the axis in `flow` (fluid.FlowSolver): outer radii a_h,i and true radii a_i [m],
    the band width [m] and the centres [m] of their first placement, sphere 1 (lowest) first."""

    def __init__(self, flow: FlowSolver, radii, true_radii, width: float, centers):
        self.flow = flow
        self.spheres = [ImmersedSphere(flow, radius, width, center) for radius, center in zip(radii, centers)]
        offsets = [max(a_h - a, 0.0) for a_h, a in zip(radii, true_radii)]
        self.min_gaps = np.add(offsets[:-1], offsets[1:])  # each neighbouring pair's [m]
        self._contact_distances = np.add(true_radii[:-1], true_radii[1:])  # centre distances at touching [m]
        self.forced = fem.Function(flow.W)  # y0, the response to every sphere's forcing of -u~
        self._force = flow.rhs.duplicate()
        self.check_separation([sphere.center for sphere in self.spheres])

    @property
    def volumes(self) -> np.ndarray:
        """V_phi = int phi dV of each sphere [m^3]."""
        return np.array([sphere.volume for sphere in self.spheres])

    @property
    def ball_volumes(self) -> np.ndarray:
        """The volumes 4/3 pi a_h^3 of the balls the indicators cover [m^3]: all of it moves with the sphere
        under the implicit constraint's friction, the band included."""
        return np.array([4.0 / 3.0 * math.pi * sphere.band.radius**3 for sphere in self.spheres])

    def check_separation(self, centers) -> None:
        gaps = np.diff(centers) - self._contact_distances
        for k in np.flatnonzero(gaps < self.min_gaps * (1.0 - 1e-12)):
            raise SceneError(f"numerics.fd: the surfaces of spheres {k + 1} and {k + 2} are {gaps[k]:.4g} m apart, "
                             f"closer than {self.min_gaps[k]:.4g} m where their indicators start to overlap")

    def place(self, centers) -> None:
        """Put the indicators' centres at z = centers [m] (each re-assembled only if it moved)."""
        self.check_separation(centers)
        for sphere, center in zip(self.spheres, centers):
            if center != sphere.center:
                sphere.place(center)

    def stale_units(self) -> tuple[list, list]:
        """The unit forcings rho c phi_j e_z of the spheres that moved since their y1_j, and the functions
        y1_j goes to: the time loop solves them with its predictor in one pass over the factors."""
        stale = [sphere for sphere in self.spheres if sphere.unit_stale]
        return [sphere.unit_forcing() for sphere in stale], [sphere.unit for sphere in stale]

    def forget_units(self) -> None:
        """Every y1_j stale (the step's c and matrix changed: the one-shot penalty's shortened last step)."""
        for sphere in self.spheres:
            sphere._unit_at = None

    def forcing(self, predicted: fem.Function) -> PETSc.Vec:
        """-rho c sum_i phi_i u~, ready for the flow solver; its response y0 goes to `self.forced`."""
        flow = self.flow
        with self._force.localForm() as local:
            local.set(0.0)
            for sphere in self.spheres:
                sphere.band.forcing(local.array, predicted.x.array, -flow.density * flow.c)
        return flow.force_rhs(self._force)

    def interiors(self, vector: PETSc.Vec) -> np.ndarray:
        """I_i of a mixed-space vector, one per sphere [m^4/s for a velocity]."""
        return np.array([sphere.interior(vector) for sphere in self.spheres])

    def integrals(self, predicted: fem.Function) -> InteriorIntegrals:
        return InteriorIntegrals(volume=self.volumes, predicted=self.interiors(predicted.x.petsc_vec),
                                 forced=self.interiors(self.forced.x.petsc_vec),
                                 unit=np.array([[sphere.interior(other.unit.x.petsc_vec) for other in self.spheres]
                                                for sphere in self.spheres]))

    def field(self, predicted: fem.Function, amplitudes, out: PETSc.Vec) -> PETSc.Vec:
        """u = u~ + y0 + sum_j s_j y1_j as a W-vector."""
        predicted.x.petsc_vec.copy(out)
        out.axpy(1.0, self.forced.x.petsc_vec)
        for sphere, s in zip(self.spheres, amplitudes):
            out.axpy(float(s), sphere.unit.x.petsc_vec)
        return out

    def destroy(self) -> None:
        self._force.destroy()
        for sphere in self.spheres:
            sphere.destroy()


def interior_slip(flow: FlowSolver, velocity_field: fem.Function, center: float, velocity: float,
                  depth: float) -> float:
    """max |u - U e_z| [m/s] over the velocity dofs within `depth` [m] of a sphere's centre z = center [m] moving
    at U = velocity [m/s] (all ranks): how rigid the constraint holds its interior."""
    worst = 0.0
    for component, target in ((0, 0.0), (1, velocity)):
        space, dofs = collapse(flow.W.sub(0).sub(component))
        x = space.tabulate_dof_coordinates()
        inside = np.hypot(x[:, 0], x[:, 1] - center) <= depth
        if inside.any():
            worst = max(worst, float(np.abs(velocity_field.x.array[dofs[inside]] - target).max()))
    return flow.mesh.comm.allreduce(worst, op=MPI.MAX)
