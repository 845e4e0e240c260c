"""Moving the flow to a new mesh after remeshing, keeping it divergence-free and its momentum: the ale
model's remeshing around its moving sphere and the fd model's moving refined patch share it.

The old mesh and one finite-element function on it are gathered onto every rank as a serial
copy (`SerialField`), where any point can be looked up (bounding-box tree, `Function.eval`);
each rank then evaluates it at its own new degrees of freedom (`interpolate_from`).
Points of the new mesh that fall just outside the old one (the two polygons approximating
the sphere differ) take the value of the nearest old cell, extrapolated: dolfinx's own
non-matching interpolation (`Function.interpolate_nonmatching`) leaves such points without a
value.

Interpolation leaves a field that is not discretely divergence-free on the new mesh; the
next step's pressure would remove that in one step, as a force spike on the sphere.
`DivergenceFreeProjection` instead takes the L2-closest (in the physical volume, fem.geometry's
weighted measure) discretely divergence-free field with the right boundary values,

    (u, v) - (p, div v) = (u_interpolated, v),    (q, div u) = 0,   u = g on Dirichlet sides,

one saddle-point solve.  That also conserves momentum: in a closed domain (every side
fixing the normal velocity, as in every moving-sphere scene) a discretely divergence-free
field has exactly the momentum its boundary values dictate, because the P1 pressure space
contains q = z and (q, div u) = 0 with q = z is

    int u_z dV = int_boundary z (u . n) dS    (= -(sphere volume) U on the sphere),

so the fluid's momentum after the transfer equals its momentum before, up to the small
difference between the two meshes' polygonal sphere volumes.  model.py reports both.
"""
from __future__ import annotations

import basix.ufl
import numpy as np
import ufl
from dolfinx import fem, geometry
from dolfinx import mesh as dmesh
from dolfinx.fem.petsc import create_vector
from mpi4py import MPI

from .compat import collapse, geometry_cells
from .functions import gather_values, scatter_values
from .geometry import Axisymmetric
from .matrix import FormMatrix
from .solver import FactorizedOperator, FieldSplitOperator, ReusedFactorOperator
from .taylor_hood import field_indices, lifted_rhs, owned_dirichlet_rows

# The projection's field split (fem.solver.FieldSplitOperator's options): the velocity block is a mass matrix, which
# its diagonal preconditions well, and the Schur complement's multigrid (on B diag(M)^-1 B^T) smooths with that
# matrix, not with the complement itself, each of whose products would solve the velocity block again (measured
# against MUMPS's factorisation and against the complement in the smoother: docs/performance.md, "A new mesh's cost")
FIELD_SPLIT = {"fieldsplit_u_pc_type": "jacobi", "fieldsplit_p_pc_use_amat": False}


def _gather_mesh(mesh) -> tuple[np.ndarray, np.ndarray]:
    """(points (N, 2), triangles (M, 3)) of the whole mesh as it is now, on every rank."""
    owned = mesh.topology.index_map(mesh.topology.dim).size_local
    cells = geometry_cells(mesh)[:owned]
    corners = mesh.geometry.x[cells, :2].reshape(-1, 2)
    corners = np.concatenate(mesh.comm.allgather(corners))
    points, index = np.unique(corners, axis=0, return_inverse=True)
    return points, index.reshape(-1, 3).astype(np.int64)


class SerialField:
    """A serial copy of `function` (any Lagrange or mixed Lagrange space) and its mesh on every rank.

    Collective over the function's mesh communicator."""

    def __init__(self, function: fem.Function, tolerance: float):
        mesh = function.function_space.mesh
        points, triangles = _gather_mesh(mesh)
        domain = ufl.Mesh(basix.ufl.element("Lagrange", mesh.basix_cell(), 1, shape=(2,)))
        self.mesh = dmesh.create_mesh(MPI.COMM_SELF, triangles, domain, points)
        copy = fem.Function(fem.functionspace(self.mesh, function.function_space.ufl_element()))
        data = mesh.comm.bcast(gather_values(function), root=0)
        scatter_values(copy, data, tolerance)
        # Function.eval cannot evaluate a mixed function: keep its parts (u, p) as functions of their own
        count = copy.function_space.num_sub_spaces
        self.parts = [copy.sub(k).collapse() for k in range(count)] if count else [copy]
        tdim = self.mesh.topology.dim
        self.tree = geometry.bb_tree(self.mesh, tdim)
        cells = np.arange(self.mesh.topology.index_map(tdim).size_local, dtype=np.int32)
        self.midpoints = geometry.create_midpoint_tree(self.mesh, tdim, cells)

    def evaluate(self, points: np.ndarray, part: int = 0) -> np.ndarray:
        """Values (n, value size) of one part (the k-th sub-function of a mixed function) at points (n, 2) [m]."""
        xyz = np.zeros((len(points), 3))
        xyz[:, :2] = points
        candidates = geometry.compute_collisions_points(self.tree, xyz)
        colliding = geometry.compute_colliding_cells(self.mesh, candidates, xyz)
        cells = np.full(len(points), -1, dtype=np.int32)
        for k in range(len(points)):
            found = colliding.links(k)
            if len(found):
                cells[k] = found[0]
        outside = np.flatnonzero(cells < 0)
        if outside.size:
            cells[outside] = geometry.compute_closest_entity(self.tree, self.midpoints, self.mesh, xyz[outside])
        return self.parts[part].eval(xyz, cells)


def interpolate_from(source: SerialField, target: fem.Function) -> None:
    """Set every dof of `target` (same element as the source) to the source's value at its position."""
    space = target.function_space
    subspaces = [space.sub(k) for k in range(space.num_sub_spaces)] if space.num_sub_spaces else [space]
    for part, sub in enumerate(subspaces):
        collapsed, parent = collapse(sub)
        values = source.evaluate(collapsed.tabulate_dof_coordinates()[:, :2], part)
        # a blocked (vector) space lists each node once: its components are consecutive dofs
        target.x.array[parent] = values.reshape(-1)
    target.x.scatter_forward()


class DivergenceFreeProjection:
    """The L2 projection (weighted: fem.geometry.Axisymmetric, or the `geometry` given) onto discretely
    divergence-free fields meeting `bcs`, on the mesh as it is.

    `solver`: "direct", MUMPS's factors; "reuse", after the mesh moved, `reassemble` and project with the first
    factors preconditioning flexible GMRES (fem.solver.ReusedFactorOperator, to |b - A x| <= rtol |b|) instead of
    factorising again; "fieldsplit", flexible GMRES preconditioned by the Schur field split (FIELD_SPLIT: in 3-D,
    where one projection's factorisation costs several of its iterative solves; to rtol 1e-8)."""

    def __init__(self, W, bcs: list, prefix: str = "ale_projection_", solver: str = "direct", rtol: float = 1e-7,
                 geometry=None):
        geometry = Axisymmetric(W.mesh) if geometry is None else geometry  # fem.geometry's (Cartesian in 3-D)
        (u, p), (v, q) = ufl.TrialFunctions(W), ufl.TestFunctions(W)
        self.field = fem.Function(W)
        self.a = fem.form(geometry.stokes_operator(u, p, v, q, 1.0, 0.0))
        self.L = fem.form(geometry.source(ufl.split(self.field)[0], v))
        self.bcs = bcs
        # the fixed rows scaled with the weighted forms: a reused factorisation's GMRES starts from the interpolated
        # field, off the new mesh's Dirichlet values, and weighs those rows against the others as before
        self.diagonal = geometry.dirichlet_diagonal
        self.assembler = FormMatrix(self.a, bcs, self.diagonal)
        self.matrix = self.assembler.petsc
        self.rhs = create_vector(W)
        if solver == "reuse":
            self.solver = ReusedFactorOperator(self.matrix, prefix + "reuse_", rtol=rtol,
                                               fixed_rows=owned_dirichlet_rows(bcs))
        elif solver == "fieldsplit":
            fields = [field_indices(W, k) for k in (0, 1)]
            self.solver = FieldSplitOperator(self.matrix, prefix, *fields, rtol=1e-8, options=FIELD_SPLIT)
            for field in fields:
                field.destroy()
        else:
            self.solver = FactorizedOperator(self.matrix, prefix)

    def reassemble(self) -> None:
        """The matrix on the mesh as it is now (moved): factorised again ("direct"), its field split set up again
        ("fieldsplit"), or projected with the first factors ("reuse")."""
        self.assembler.assemble()
        if isinstance(self.solver, ReusedFactorOperator):
            self.solver.end_step()  # the next solve starts from the field given, with the old factors
        else:
            self.solver.refactor()

    def project(self, function: fem.Function) -> None:
        """Replace the velocity of the mixed (u, p) `function` by its projection (its pressure is kept)."""
        self.field.x.array[:] = function.x.array
        b = lifted_rhs(self.rhs, self.L, self.a, self.bcs, self.diagonal)
        self.solver.solve(b, self.field.x.petsc_vec)
        self.field.x.scatter_forward()
        _, velocity = collapse(function.function_space.sub(0))
        function.x.array[velocity] = self.field.x.array[velocity]

    def destroy(self) -> None:
        self.solver.destroy()
        self.assembler.destroy()
        self.rhs.destroy()
