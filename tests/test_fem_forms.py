"""The axisymmetric Stokes operator (fem_bounce.fem.forms) against a manufactured solution.

u = curl of the Stokes stream function psi = r^2 g(r, z) is solenoidal in the
axisymmetric sense for any smooth g and has u_r = 0 on the axis; p is arbitrary.
The body force that makes them exact is built with UFL from the strong form
(hoop term included), so a missing or wrong 1/r term breaks the rates.
Taylor-Hood P2/P1: velocity error O(h^3), pressure error O(h^2) in the r-weighted L2 norm.
"""
import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from dolfinx.fem.petsc import LinearProblem
from mpi4py import MPI

from fem_bounce.fem import forms
from fem_bounce.fem.compat import collapse
from fem_bounce.fem.taylor_hood import taylor_hood_space

RHO_C, MU = 3.0, 0.7  # a BDF2 mass coefficient and a viscosity, both of order one


def exact(x):
    r, z = x[0], x[1]
    g = ufl.sin(np.pi * z) * ufl.cos(0.5 * np.pi * r) + 0.3 * r * z
    u = ufl.as_vector([-r * g.dx(1), 2.0 * g + r * g.dx(0)])
    p = ufl.cos(np.pi * r) * ufl.sin(2.0 * z)
    return u, p


def strong_residual(u, p, r):
    """rho c u - mu Lap u + grad p, with the cylindrical vector Laplacian (no swirl)."""
    lap_r = (r * u[0].dx(0)).dx(0) / r + u[0].dx(1).dx(1) - u[0] / r**2
    lap_z = (r * u[1].dx(0)).dx(0) / r + u[1].dx(1).dx(1)
    return RHO_C * u - MU * ufl.as_vector([lap_r, lap_z]) + ufl.grad(p)


def solve(n, comm=MPI.COMM_WORLD):
    domain = mesh.create_unit_square(comm, n, n, diagonal=mesh.DiagonalType.crossed)
    W = taylor_hood_space(domain)
    x = ufl.SpatialCoordinate(domain)
    r = forms.radial_coordinate(domain)
    u_ex, p_ex = exact(x)
    (u, p), (v, q) = ufl.TrialFunctions(W), ufl.TestFunctions(W)
    dx = ufl.Measure("dx", domain=domain, metadata={"quadrature_degree": 8})
    a = forms.stokes_operator(u, p, v, q, RHO_C, MU, r, dx)
    L = forms.source(strong_residual(u_ex, p_ex, r), v, r, dx)

    V, _ = collapse(W.sub(0))
    u_bc = fem.Function(V)
    u_bc.interpolate(fem.Expression(u_ex, V.element.interpolation_points))
    fdim = domain.topology.dim - 1
    outer = mesh.locate_entities_boundary(
        domain, fdim, lambda x: np.isclose(x[0], 1.0) | np.isclose(x[1], 0.0) | np.isclose(x[1], 1.0))
    axis = mesh.locate_entities_boundary(domain, fdim, lambda x: np.isclose(x[0], 0.0))
    Vr, _ = collapse(W.sub(0).sub(0))
    Q, _ = collapse(W.sub(1))
    p_bc = fem.Function(Q)
    p_bc.interpolate(fem.Expression(p_ex, Q.element.interpolation_points))
    corner = fem.locate_dofs_geometrical((W.sub(1), Q), lambda x: np.isclose(x[0], 1.0) & np.isclose(x[1], 1.0))
    bcs = [
        fem.dirichletbc(u_bc, fem.locate_dofs_topological((W.sub(0), V), fdim, outer), W.sub(0)),
        fem.dirichletbc(fem.Function(Vr), fem.locate_dofs_topological((W.sub(0).sub(0), Vr), fdim, axis),
                        W.sub(0).sub(0)),
        fem.dirichletbc(p_bc, corner, W.sub(1)),
    ]
    options = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
    problem = LinearProblem(a, L, bcs=bcs, petsc_options_prefix="test_forms_", petsc_options=options)
    w = problem.solve()
    uh, ph = w.split()

    def norm(e):
        return np.sqrt(comm.allreduce(fem.assemble_scalar(fem.form(ufl.inner(e, e) * r * dx)), op=MPI.SUM))

    return norm(uh - u_ex) / norm(u_ex), norm(ph - p_ex) / norm(p_ex)


@pytest.mark.mpi
def test_axisymmetric_stokes_converges_at_taylor_hood_rates():
    errors = np.array([solve(n) for n in (4, 8, 16)])
    rates = np.log2(errors[:-1] / errors[1:])
    assert rates[:, 0].min() > 2.8, f"velocity rates {rates[:, 0]}, errors {errors[:, 0]}"
    assert rates[:, 1].min() > 1.8, f"pressure rates {rates[:, 1]}, errors {errors[:, 1]}"
    assert errors[-1, 0] < 1e-4

