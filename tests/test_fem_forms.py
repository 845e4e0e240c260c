"""The axisymmetric forms of fem_bounce.fem.geometry.Axisymmetric: the Stokes operator against a manufactured
solution, and the weighted forms against the plain r-weighted ones they stand for.

u = curl of the Stokes stream function psi = r^2 g(r, z) is solenoidal in the
axisymmetric sense for any smooth g and has u_r = 0 on the axis; p is arbitrary.
The body force that makes them exact is built with UFL from the strong form
(hoop term included), so a missing or wrong 1/r term breaks the rates.
Taylor-Hood P2/P1: velocity error O(h^3), pressure error O(h^2) in the L2 norm of the physical volume.
"""
import math

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from dolfinx.fem.petsc import LinearProblem, assemble_matrix, assemble_vector
from mpi4py import MPI
from petsc4py import PETSc

from fem_bounce.fem.compat import collapse, geometry_cells
from fem_bounce.fem.geometry import Axisymmetric
from fem_bounce.fem.taylor_hood import taylor_hood_space

RHO_C, MU = 3.0, 0.7  # a BDF2 mass coefficient and a viscosity, both of order one
COMM = MPI.COMM_WORLD


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


def solve(n, comm=COMM):
    domain = mesh.create_unit_square(comm, n, n, diagonal=mesh.DiagonalType.crossed)
    geometry = Axisymmetric(domain)
    W = taylor_hood_space(domain)
    x = ufl.SpatialCoordinate(domain)
    u_ex, p_ex = exact(x)
    (u, p), (v, q) = ufl.TrialFunctions(W), ufl.TestFunctions(W)
    dx = ufl.Measure("dx", domain=domain, metadata={"quadrature_degree": 8})
    a = geometry.stokes_operator(u, p, v, q, RHO_C, MU, dx)
    L = geometry.source(strong_residual(u_ex, p_ex, geometry.r), v, dx)

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
    # LinearProblem puts 1 on the Dirichlet rows beside the weighted rows: the same solution by a direct solve
    options = {"ksp_type": "preonly", "pc_type": "lu", "pc_factor_mat_solver_type": "mumps"}
    problem = LinearProblem(a, L, bcs=bcs, petsc_options_prefix="test_forms_", petsc_options=options)
    w = problem.solve()
    uh, ph = w.split()

    def norm(e):
        return np.sqrt(geometry.integrate(geometry.weighted(ufl.inner(e, e), dx)))

    return norm(uh - u_ex) / norm(u_ex), norm(ph - p_ex) / norm(p_ex)


@pytest.mark.mpi
def test_axisymmetric_stokes_converges_at_taylor_hood_rates():
    errors = np.array([solve(n) for n in (4, 8, 16)])
    rates = np.log2(errors[:-1] / errors[1:])
    assert rates[:, 0].min() > 2.8, f"velocity rates {rates[:, 0]}, errors {errors[:, 0]}"
    assert rates[:, 1].min() > 1.8, f"pressure rates {rates[:, 1]}, errors {errors[:, 1]}"
    assert errors[-1, 0] < 1e-4


# -- the plain reference: the r-weighted meridian forms, 2 pi left out ---------------------------------------
def plain_forms(r, dx):
    """The r-weighted forms written out as the strong form's weak form (Axisymmetric's docstring)."""
    def pressure_divergence(v, p):
        return -p * (v[0].dx(0) + v[1].dx(1)) * r * dx - p * v[0] * dx

    def viscous(u, v):
        return (ufl.inner(ufl.grad(u), ufl.grad(v)) * r + u[0] * v[0] / r) * dx

    def mass(u, v):
        return ufl.inner(u, v) * r * dx

    return {"mass": mass, "viscous": viscous, "pressure_divergence": pressure_divergence,
            "stokes_operator": lambda u, p, v, q, c, mu: (c * mass(u, v) + mu * viscous(u, v)
                                                          + pressure_divergence(v, p) + pressure_divergence(u, q)),
            "convection": lambda w, u, v: ufl.inner(ufl.grad(u) * w, v) * r * dx,
            "source": lambda f, v: ufl.inner(f, v) * r * dx}


def _matrix_norm_difference(form_a, form_b, scale):
    """(|A - scale B|_F, |A|_F) of two bilinear forms' matrices."""
    A, B = (assemble_matrix(fem.form(f)) for f in (form_a, form_b))
    A.assemble()
    B.assemble()
    norm = A.norm()
    A.axpy(-scale, B)
    difference = A.norm()
    A.destroy()
    B.destroy()
    return difference, norm


@pytest.mark.mpi
def test_axisymmetric_forms_are_the_r_weighted_ones_times_two_pi():
    # the half-plane away from and touching the axis: the 1/r terms are evaluated at interior quadrature points
    domain = mesh.create_rectangle(COMM, [[0.0, 0.0], [1.0, 2.0]], [4, 6], diagonal=mesh.DiagonalType.crossed)
    geometry = Axisymmetric(domain)
    W = taylor_hood_space(domain)
    (u, p), (v, q) = ufl.TrialFunctions(W), ufl.TestFunctions(W)
    r = geometry.r
    plain = plain_forms(r, ufl.Measure("dx", domain=domain))
    w_u = fem.Function(collapse(W.sub(0))[0])  # a convecting velocity with both components, u_r nonzero
    w_u.interpolate(lambda x: np.vstack([x[0] * (1.0 + x[1]), np.cos(x[0]) + x[1] ** 2]))
    f = ufl.as_vector([ufl.sin(r), r * ufl.SpatialCoordinate(domain)[1]])
    pairs = [(geometry.mass(u, v), plain["mass"](u, v)),
             (geometry.viscous(u, v), plain["viscous"](u, v)),
             (geometry.pressure_divergence(v, p), plain["pressure_divergence"](v, p)),
             (geometry.stokes_operator(u, p, v, q, 3.0, 0.7), plain["stokes_operator"](u, p, v, q, 3.0, 0.7)),
             (geometry.convection(w_u, u, v), plain["convection"](w_u, u, v))]
    for ours, theirs in pairs:
        difference, norm = _matrix_norm_difference(ours, theirs, 2.0 * math.pi)
        assert norm > 0 and difference <= 1e-12 * norm
    ours, theirs = (assemble_vector(fem.form(form)) for form in (geometry.source(f, v), plain["source"](f, v)))
    for vector in (ours, theirs):
        vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    norm = ours.norm()
    ours.axpy(-2.0 * math.pi, theirs)
    assert norm > 0 and ours.norm() <= 1e-12 * norm
    assert geometry.dirichlet_diagonal == pytest.approx(2.0 * math.pi, rel=1e-15)
    # integrate: the cylinder r <= 1, 0 <= z <= 2 has volume 2 pi; the divergence of x = (r, z) is 3 in space
    assert geometry.integrate(geometry.weighted(1.0)) == pytest.approx(2.0 * math.pi, rel=1e-12)
    position = ufl.SpatialCoordinate(domain)
    assert geometry.integrate(geometry.weighted(geometry.divergence(position))) == pytest.approx(6.0 * math.pi,
                                                                                                 rel=1e-12)
    # the azimuthal vorticity d(u_r)/dz - d(u_z)/dr of u = (z, -r) is 2 everywhere
    rotation = ufl.as_vector([position[1], -position[0]])
    assert geometry.integrate(geometry.weighted(geometry.vorticity(rotation))) == pytest.approx(4.0 * math.pi,
                                                                                                rel=1e-12)
    assert geometry.mode_names == ("U_z",)


@pytest.mark.mpi
def test_a_quadrature_sum_by_hand_with_weight_at_is_the_weighted_integral():
    """weight_at and total: the midpoint rule over each triangle of r^0 (the cylinder's volume, exact for the
    linear weight) summed over the ranks, against the assembled form."""
    domain = mesh.create_rectangle(COMM, [[0.0, 0.0], [1.0, 2.0]], [3, 5])
    geometry = Axisymmetric(domain)
    owned = domain.topology.index_map(2).size_local
    corners = domain.geometry.x[geometry_cells(domain)[:owned]][:, :, :2]
    (a_r, a_z), (b_r, b_z) = (np.moveaxis(corners[:, k] - corners[:, 0], 1, 0) for k in (1, 2))
    areas = 0.5 * np.abs(a_r * b_z - a_z * b_r)
    part = float(np.sum(areas * geometry.weight_at(corners.mean(axis=1))))
    assert geometry.total(part) == pytest.approx(geometry.integrate(geometry.weighted(1.0)), rel=1e-12)
    assert geometry.total(part) == pytest.approx(2.0 * math.pi, rel=1e-12)
