"""fem.matrix.FormMatrix: the same matrix as PETSc's own assembly, assembled again in place, and a direct solver
that factorises it sees every re-assembly."""
import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from dolfinx.fem.petsc import assemble_matrix
from mpi4py import MPI

from fem_bounce.fem.matrix import FormMatrix
from fem_bounce.fem.solver import FactorizedOperator
from fem_bounce.fem.taylor_hood import taylor_hood_space


@pytest.mark.mpi
def test_form_matrix_is_petscs_assembly_and_refactors_after_reassembly():
    domain = mesh.create_unit_square(MPI.COMM_WORLD, 6, 5, mesh.CellType.triangle)
    W = taylor_hood_space(domain)
    (u, p), (v, q) = ufl.TrialFunctions(W), ufl.TestFunctions(W)
    coefficient = fem.Constant(domain, 1.0)
    wind = fem.Function(W)
    a = fem.form(coefficient * ufl.inner(u, v) * ufl.dx + ufl.inner(ufl.grad(u), ufl.grad(v)) * ufl.dx
                 + ufl.inner(ufl.grad(u) * ufl.split(wind)[0], v) * ufl.dx - p * ufl.div(v) * ufl.dx
                 - q * ufl.div(u) * ufl.dx)
    boundary = mesh.locate_entities_boundary(domain, 1, lambda x: np.isclose(x[0], 0.0))
    velocity, _ = W.sub(0).collapse()
    dofs = fem.locate_dofs_topological((W.sub(0), velocity), 1, boundary)
    bcs = [fem.dirichletbc(fem.Function(velocity), dofs, W.sub(0))]
    matrix = FormMatrix(a, bcs)
    solver = FactorizedOperator(matrix.petsc, "test_form_matrix_")
    b = matrix.petsc.createVecLeft()
    b.setRandom()
    x, y = b.duplicate(), b.duplicate()
    try:
        for value in (1.0, 7.0):
            coefficient.value = value
            wind.x.array[:] = value * np.sin(np.arange(wind.x.array.size))
            matrix.assemble()
            solver.refactor()
            reference = assemble_matrix(a, bcs=bcs)
            reference.assemble()
            reference.axpy(-1.0, matrix.petsc)
            assert reference.norm() <= 1e-12 * matrix.petsc.norm()
            reference.destroy()
            solver.solve(b, x)
            matrix.petsc.mult(x, y)  # the factors are those of the matrix as assembled now
            y.axpy(-1.0, b)
            assert y.norm() <= 1e-8 * b.norm()
    finally:
        solver.destroy()
        matrix.destroy()
