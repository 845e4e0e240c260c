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
velocity agree; with the non-conservative ALE form (models/ale/flow.py) a uniform flow then stays
uniform on the moving mesh to round-off (the geometric conservation law; tested).

Every sphere on the axis has its own extension: psi_k = 1 on sphere k and 0 on the other spheres
and the outer sides, x = X + sum_k s_k psi_k e_z and w = sum_k psi_k e_z (BDF rate of s_k); all
come from one factorisation.  sum_k psi_k <= 1 (maximum principle), so the mesh between two
spheres is squeezed or stretched by their relative motion and is remade when its triangles
degrade, like the gap to the wall.  Per-sphere values (centres, shifts, rates) are arrays over the
spheres, sphere 1 (the lowest) first.

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

from .compat import geometry_cells
from .mesh import OUTER, SPHERE, TOP, WALL
from .solver import FactorizedOperator


def triangle_quality(points: np.ndarray, cells: np.ndarray, orientation: np.ndarray | None = None) -> np.ndarray:
    """q = 4 sqrt(3) A / sum(edge^2) per triangle; signed by `orientation` (the reference areas' signs)."""
    corners = points[cells]
    edges = np.roll(corners, -1, axis=1) - corners
    signed_area = 0.5 * (edges[:, 0, 0] * edges[:, 1, 1] - edges[:, 0, 1] * edges[:, 1, 0])
    if orientation is not None:
        signed_area = signed_area * orientation
    return 4.0 * np.sqrt(3.0) * signed_area / np.sum(edges**2, axis=(1, 2))


def at_geometry_nodes(function: fem.Function, cells: np.ndarray) -> np.ndarray:
    """Values of a P1 function at its mesh's geometry nodes (the two numberings differ); `cells`: the geometry's
    dofmap (compat.geometry_cells), for a mesh of affine cells."""
    node_of_dof = np.empty(function.x.array.size, dtype=np.int64)
    node_of_dof[function.function_space.dofmap.list.ravel()] = cells.ravel()
    values = np.empty(function.function_space.mesh.geometry.x.shape[0])
    values[node_of_dof] = function.x.array
    return values


class MeshMotion:
    """Moves `mesh` (in place) with the spheres; `center` holds the centres z it was made with [m] of the
    spheres whose surfaces carry `sphere_tags`, lowest first."""

    def __init__(self, mesh, facet_tags, center, prefix: str = "ale_mesh_", sphere_tags: tuple = (SPHERE,)):
        self.mesh = mesh
        self.reference_center = center
        self.space = fem.functionspace(mesh, ("Lagrange", 1))
        self.extensions = [fem.Function(self.space, name=f"psi_{k + 1}") for k in range(len(sphere_tags))]
        self.psi = self.extensions[0]
        if len(sphere_tags) == 1:
            self.psi.name = "psi"
        self._solve_extensions(facet_tags, sphere_tags, prefix)
        self.cells = geometry_cells(mesh)
        self.reference = mesh.geometry.x[:, :2].copy()
        self.extension_nodes = [at_geometry_nodes(psi, self.cells) for psi in self.extensions]
        self.psi_nodes = self.extension_nodes[0]
        self.orientation = np.sign(triangle_quality(self.reference, self.cells))
        self.shift = np.zeros(len(sphere_tags))
        # d(shift_k)/dt of the current step [m/s]: the mesh velocity is sum_k rate_k psi_k e_z (one vector
        # Constant: flow.SphereFlow says why)
        self.rates = fem.Constant(mesh, np.zeros(len(sphere_tags), dtype=PETSc.ScalarType))
        self.velocity = ufl.as_vector((0.0, sum(self.rates[k] * psi for k, psi in enumerate(self.extensions))))

    def _solve_extensions(self, facet_tags, sphere_tags, prefix: str) -> None:
        """psi_k for every sphere k: one matrix (the same Dirichlet rows for all), one factorisation."""
        V, mesh = self.space, self.mesh
        fdim = mesh.topology.dim - 1
        u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
        stiffness = 1.0 / ufl.CellVolume(mesh)
        a = fem.form(stiffness * ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx)
        L = fem.form(fem.Constant(mesh, PETSc.ScalarType(0.0)) * v * ufl.dx)
        one, zero = fem.Function(V), fem.Function(V)
        one.x.array[:] = 1.0
        conditions = []
        for tag in sphere_tags:
            others = [other for other in sphere_tags if other != tag]
            fixed = np.concatenate([facet_tags.find(side) for side in (WALL, OUTER, TOP, *others)])
            conditions.append([fem.dirichletbc(one, fem.locate_dofs_topological(V, fdim, facet_tags.find(tag))),
                               fem.dirichletbc(zero, fem.locate_dofs_topological(V, fdim, fixed))])
        A = assemble_matrix(a, bcs=conditions[0])
        A.assemble()
        b = assemble_vector(L)
        solver = FactorizedOperator(A, prefix)
        try:
            for psi, bcs in zip(self.extensions, conditions):
                with b.localForm() as local:
                    local.set(0.0)
                assemble_vector(b, L)
                apply_lifting(b, [a], [bcs])
                b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
                set_bc(b, bcs)
                solver.solve(b, psi.x.petsc_vec)
                psi.x.scatter_forward()
        finally:
            solver.destroy()
            A.destroy()
            b.destroy()

    def positions(self, shift) -> np.ndarray:
        """Vertex positions (r, z) with the sphere moved by `shift` from the reference [m]."""
        points = self.reference.copy()
        for s, nodes in zip(np.atleast_1d(shift), self.extension_nodes):
            points[:, 1] += s * nodes
        return points

    def quality(self, shift) -> float:
        """The worst triangle quality (over all ranks) of the mesh moved by `shift` [m]."""
        local = triangle_quality(self.positions(shift), self.cells, self.orientation)
        worst = local.min() if local.size else np.inf
        return self.mesh.comm.allreduce(worst, op=MPI.MIN)

    def move(self, shift) -> None:
        """Put the mesh where a sphere displaced by `shift` from the reference has it."""
        shifts = np.atleast_1d(shift)
        z = self.reference[:, 1] + shifts[0] * self.extension_nodes[0]
        for s, nodes in zip(shifts[1:], self.extension_nodes[1:]):
            z += s * nodes
        self.mesh.geometry.x[:, 1] = z
        self.shift = shift

    def move_to(self, center) -> None:
        """Put the mesh where a sphere centred at z = center [m] has it."""
        self.move(center - self.reference_center)

    def set_rates(self, rates) -> None:
        """The BDF rates of the sphere centres this step [m/s]: the mesh velocity."""
        self.rates.value[:] = rates
