"""The mesh follows the sphere: x = X + s psi(X) e_z.

X are the vertex positions of the mesh as gmsh made it (the reference, with the
sphere centre at z_ref), s = z_c - z_ref the sphere's displacement since, and psi
the unit harmonic extension

    -div(k grad psi) = 0,   psi = 1 on the sphere, 0 on the wall, outer and top sides,
                            d psi / dn = 0 on the axis (vertices slide along it),

with the Jacobian-based stiffening k = 1 / |cell area| (Stein, Tezduyar & Benney 2003,
J. Appl. Mech. 70): small cells near the sphere move nearly rigidly with it and the
large far cells take up the deformation.  Because the sphere only translates along the
axis, the extension of its displacement is s psi e_z exactly: one solve per mesh, and
the mesh at any sphere position costs one vector update.  The mesh moves only along z.

The ALE mesh velocity of a BDF step is w = psi e_z (sum_j alpha_j z^{n+1-j}) / dt, the
same BDF formula as the flow's time derivative, so the position of every vertex and its
velocity agree; with the non-conservative ALE form (flow.py) a uniform flow then stays
uniform on the moving mesh to round-off (the geometric conservation law; tested).

Quality of a triangle: q = 4 sqrt(3) A / (sum of its squared edge lengths), 1 for an
equilateral triangle, 0 for a degenerate one, negative when the motion inverted it.
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import apply_lifting, assemble_matrix, assemble_vector, set_bc
from mpi4py import MPI
from petsc4py import PETSc

from ...fem.mesh import OUTER, SPHERE, TOP, WALL
from ...fem.solver import FactorizedOperator


def triangle_quality(points: np.ndarray, cells: np.ndarray, orientation: np.ndarray | None = None) -> np.ndarray:
    """q = 4 sqrt(3) A / sum(edge^2) per triangle; signed by `orientation` (the reference areas' signs)."""
    corners = points[cells]
    edges = np.roll(corners, -1, axis=1) - corners
    signed_area = 0.5 * (edges[:, 0, 0] * edges[:, 1, 1] - edges[:, 0, 1] * edges[:, 1, 0])
    if orientation is not None:
        signed_area = signed_area * orientation
    return 4.0 * np.sqrt(3.0) * signed_area / np.sum(edges**2, axis=(1, 2))


class MeshMotion:
    """Moves `mesh` (in place) with the sphere; `center` is the sphere centre z it was made with [m]."""

    def __init__(self, mesh, facet_tags, center: float, prefix: str = "ale_mesh_"):
        self.mesh = mesh
        self.reference_center = center
        self.space = fem.FunctionSpace(mesh, ("Lagrange", 1))
        self.psi = fem.Function(self.space, name="psi")
        self._solve_extension(facet_tags, prefix)
        self.cells = mesh.geometry.dofmap.array.reshape(-1, 3)
        self.reference = mesh.geometry.x[:, :2].copy()
        self.psi_nodes = self._at_geometry_nodes(self.psi)
        self.orientation = np.sign(triangle_quality(self.reference, self.cells))
        self.shift = 0.0
        # d(shift)/dt of the current step [m/s]: the mesh velocity is rate * psi e_z
        self.rate = fem.Constant(mesh, PETSc.ScalarType(0.0))
        self.velocity = ufl.as_vector((0.0, self.rate * self.psi))

    def _solve_extension(self, facet_tags, prefix: str) -> None:
        V, mesh = self.space, self.mesh
        fdim = mesh.topology.dim - 1
        u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        stiffness = 1.0 / ufl.CellVolume(mesh)
        a = fem.form(stiffness * ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx)
        L = fem.form(fem.Constant(mesh, PETSc.ScalarType(0.0)) * v * ufl.dx)
        one, zero = fem.Function(V), fem.Function(V)
        one.x.array[:] = 1.0
        fixed = np.concatenate([facet_tags.find(tag) for tag in (WALL, OUTER, TOP)])
        bcs = [fem.dirichletbc(one, fem.locate_dofs_topological(V, fdim, facet_tags.find(SPHERE))),
               fem.dirichletbc(zero, fem.locate_dofs_topological(V, fdim, fixed))]
        A = assemble_matrix(a, bcs=bcs)
        A.assemble()
        b = assemble_vector(L)
        apply_lifting(b, [a], [bcs])
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        set_bc(b, bcs)
        solver = FactorizedOperator(A, prefix)
        try:
            solver.solve(b, self.psi.vector)
        finally:
            solver.destroy()
            A.destroy()
            b.destroy()
        self.psi.x.scatter_forward()

    def _at_geometry_nodes(self, function: fem.Function) -> np.ndarray:
        """Values of a P1 function at the mesh's geometry nodes (the two numberings differ)."""
        node_of_dof = np.empty(function.x.array.size, dtype=np.int64)
        dofs = self.space.dofmap.list.array.reshape(-1, 3)
        node_of_dof[dofs.ravel()] = self.cells.ravel()
        values = np.empty(self.reference.shape[0])
        values[node_of_dof] = function.x.array
        return values

    def positions(self, shift: float) -> np.ndarray:
        """Vertex positions (r, z) with the sphere moved by `shift` from the reference [m]."""
        points = self.reference.copy()
        points[:, 1] += shift * self.psi_nodes
        return points

    def quality(self, shift: float) -> float:
        """The worst triangle quality (over all ranks) of the mesh moved by `shift` [m]."""
        local = triangle_quality(self.positions(shift), self.cells, self.orientation)
        worst = local.min() if local.size else np.inf
        return self.mesh.comm.allreduce(worst, op=MPI.MIN)

    def move(self, shift: float) -> None:
        """Put the mesh where a sphere displaced by `shift` from the reference has it."""
        self.mesh.geometry.x[:, 1] = self.reference[:, 1] + shift * self.psi_nodes
        self.shift = shift

    def move_to(self, center: float) -> None:
        """Put the mesh where a sphere centred at z = center [m] has it."""
        self.move(center - self.reference_center)
