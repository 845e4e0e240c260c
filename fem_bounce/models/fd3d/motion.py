"""The 3-D mesh follows the sphere: x = X + psi(X) s, s the sphere's displacement since the mesh was made.

X are the vertex positions as gmsh made them (the sphere centred at `reference_center`) and psi the unit harmonic
extension

    -div(k grad psi) = 0,   psi = 1 at the vertices of the cells that reach within `rigid_radius` of the centre,
                            psi = 0 on the wall, the top and the sides,  d psi / dn = 0 on the symmetry plane,

with the stiffening k = 1 / |cell volume| (Stein, Tezduyar & Benney 2003, J. Appl. Mech. 70), as the axisymmetric
models' fem.mesh_motion: the ball of rigid_radius (the sphere and a layer of cells around it) moves rigidly with
the sphere, so the penalty's indicator keeps its values on the same cells and the step's matrix changes only
where the mesh outside deforms; the large far cells take up most of the deformation.  The sphere only translates,
so the extension of its displacement is psi s exactly: one solve per mesh, and a new place costs one vector
update.  The symmetry plane y = 0 keeps its vertices as long as s has no y component (a motion in the plane).

The ALE mesh velocity of a BDF step is w = psi (sum_j alpha_j c^{n+1-j}) / dt, the BDF formula of the sphere's
centres c, the same formula as the flow's time derivative, so that with the non-conservative ALE form (convection
by u* - w, flow.PenalisedFlow3D) a uniform flow stays uniform on the moving mesh (the geometric conservation law).

Quality of a tetrahedron: q = 6 sqrt(2) V / l_rms^3 (l_rms the root mean square of its six edges), 1 for a
regular tetrahedron, 0 for a flat one, negative when the motion inverted it.
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem, la
from dolfinx.fem.petsc import apply_lifting, assemble_matrix, assemble_vector, set_bc
from mpi4py import MPI
from petsc4py import PETSc

from ...fem.compat import geometry_cells
from ...fem.mesh_motion import at_geometry_nodes
from ...fem.solver import FactorizedOperator
from .mesh import SIDE_X, SIDE_Y, TOP, WALL

EDGES = ((0, 1), (0, 2), (0, 3), (1, 2), (1, 3), (2, 3))


def tetrahedron_quality(points: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """q = 6 sqrt(2) V / l_rms^3 per tetrahedron (signed by the orientation of its vertices)."""
    corners = points[cells]
    a, b, c = (corners[:, k] - corners[:, 0] for k in (1, 2, 3))
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)) / 6.0
    squared = sum(np.sum((corners[:, j] - corners[:, i]) ** 2, axis=1) for i, j in EDGES) / 6.0
    return 6.0 * np.sqrt(2.0) * volume / squared**1.5


class MeshMotion3D:
    """Moves `mesh` (in place) with one sphere made centred at `reference_center` [m] (a 3-vector)."""

    def __init__(self, mesh, facet_tags, reference_center, rigid_radius: float, prefix: str = "fd3d_mesh_"):
        self.mesh = mesh
        self.reference_center = np.asarray(reference_center, dtype=float)
        self.space = fem.functionspace(mesh, ("Lagrange", 1))
        self.psi = fem.Function(self.space, name="psi")
        self._solve_extension(facet_tags, rigid_radius, prefix)
        self.cells = geometry_cells(mesh)
        self.reference = mesh.geometry.x.copy()
        self.psi_nodes = at_geometry_nodes(self.psi, self.cells)
        self.orientation = np.sign(tetrahedron_quality(self.reference, self.cells))
        self.shift = np.zeros(3)
        self.rates = fem.Constant(mesh, np.zeros(3, dtype=PETSc.ScalarType))  # the BDF rate of the centre [m/s]
        self.velocity = self.psi * self.rates  # the mesh velocity w (UFL)

    def _solve_extension(self, facet_tags, rigid_radius: float, prefix: str) -> None:
        V, mesh = self.space, self.mesh
        fdim = mesh.topology.dim - 1
        u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        a = fem.form(1.0 / ufl.CellVolume(mesh) * ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx)
        L = fem.form(fem.Constant(mesh, PETSc.ScalarType(0.0)) * v * ufl.dx)
        one, zero = fem.Function(V), fem.Function(V)
        one.x.array[:] = 1.0
        inside = self._rigid_vertices(rigid_radius)
        sides = np.concatenate([facet_tags.find(side) for side in (WALL, TOP, SIDE_X, SIDE_Y)])
        bcs = [fem.dirichletbc(one, inside), fem.dirichletbc(zero, fem.locate_dofs_topological(V, fdim, sides))]
        A = assemble_matrix(a, bcs=bcs)
        A.assemble()
        b = assemble_vector(L)
        apply_lifting(b, [a], [bcs])
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        set_bc(b, bcs)
        solver = FactorizedOperator(A, prefix)
        try:
            solver.solve(b, self.psi.x.petsc_vec)
            self.psi.x.scatter_forward()
        finally:
            solver.destroy()
            A.destroy()
            b.destroy()

    def _rigid_vertices(self, rigid_radius: float) -> np.ndarray:
        """The P1 dofs (this rank's) that move rigidly: the vertices within rigid_radius of the centre and every
        vertex of a cell that has one of them, made consistent across the ranks."""
        V = self.space
        center = self.reference_center
        within = fem.locate_dofs_geometrical(V, lambda x: np.linalg.norm(x.T - center, axis=1) <= rigid_radius)
        marker = fem.Function(V)
        marker.x.array[within] = 1.0
        cells = V.dofmap.list
        touching = cells[marker.x.array[cells].max(axis=1) > 0]
        marker.x.array[:] = 0.0
        marker.x.array[touching.ravel()] = 1.0
        marker.x.scatter_reverse(la.InsertMode.add)
        marker.x.scatter_forward()
        return np.flatnonzero(marker.x.array > 0).astype(np.int32)

    def positions(self, shift) -> np.ndarray:
        """Vertex positions with the sphere displaced by `shift` [m] from the reference."""
        return self.reference + self.psi_nodes[:, None] * np.asarray(shift, dtype=float)

    def quality(self, shift) -> float:
        """The worst tetrahedron quality (over all ranks) of the mesh moved by `shift` [m]."""
        local = tetrahedron_quality(self.positions(shift), self.cells) * self.orientation
        return self.mesh.comm.allreduce(local.min() if local.size else np.inf, op=MPI.MIN)

    def move_to(self, center) -> None:
        """Put the mesh where a sphere centred at `center` [m] has it."""
        self.shift = np.asarray(center, dtype=float) - self.reference_center
        self.mesh.geometry.x[:] = self.positions(self.shift)

    def set_rate(self, rate) -> None:
        """The BDF rate of the sphere's centre this step [m/s]: the mesh velocity is psi times it."""
        self.rates.value[:] = rate
