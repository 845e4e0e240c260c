"""The immersed-boundary model's numerical core: kernel, operators, projection, forces."""

import numpy as np
import pytest

from fem_bounce.models.ib import body, delta, grid, operators, solver

RNG = np.random.default_rng(7)


def uniform_grid(n=16, bottom=grid.WALL, top=grid.SLIP, outer=grid.SLIP, size=1.0, height=1.0):
    h = size / n
    return grid.make_grid(h, size, (0.0, height), size, height, 1.0, grid.Boundaries(bottom, top, outer))


# -- the regularised delta function -------------------------------------------------------------

@pytest.mark.parametrize("shift", RNG.uniform(0.0, 1.0, 6))
def test_roma_kernel_moments(shift):
    """Roma, Peskin & Berger (1999): sum phi = 1, sum x phi = 0, sum phi^2 = 1/2 for every shift."""
    x = shift - np.arange(-3, 4)
    phi = delta.roma_kernel(x)
    assert phi.sum() == pytest.approx(1.0, abs=1e-14)
    assert (x * phi).sum() == pytest.approx(0.0, abs=1e-14)
    assert (phi**2).sum() == pytest.approx(0.5, abs=1e-14)


def test_roma_kernel_support_and_continuity():
    assert delta.roma_kernel(np.array([1.5, 1.6, -1.5, 3.0])).max() == 0.0
    for edge in (0.5, 1.5):
        left, right = delta.roma_kernel(np.array([edge - 1e-9, edge + 1e-9]))
        assert left == pytest.approx(right, abs=1e-6)


# -- interpolation and spreading --------------------------------------------------------------------

def random_points(g, n, near_axis=True, near_wall=True):
    h = g.h
    r = RNG.uniform(0.2 * h if near_axis else 2 * h, 0.6, n)
    z = RNG.uniform(0.05 * h if near_wall else 2 * h, 0.8, n)
    return r, z


def test_interpolation_matches_the_plain_double_loop():
    g = uniform_grid(12)
    ops = operators.AxisymmetricOperators(g)
    q = RNG.normal(size=g.n_velocity)
    u, w = ops.unpack(q)
    r, z = random_points(g, 5)
    fast = delta.interpolation_matrix(g, r, z) @ q
    for k in range(5):
        reference = delta.interpolate_reference(g, u, w, r[k], z[k])
        assert fast[k] == pytest.approx(reference[0], abs=1e-13)
        assert fast[5 + k] == pytest.approx(reference[1], abs=1e-13)


def test_interpolation_is_exact_for_linear_fields_even_at_the_axis():
    """u = a r (odd in r) and w = b + c z + d r^2 ... linear parts are reproduced exactly;
    the axis images keep this true for points within the kernel's reach of r = 0."""
    g = uniform_grid(16, bottom=grid.SLIP)  # no wall image: linear in z is exact everywhere inside
    ops = operators.AxisymmetricOperators(g)
    u = 2.0 * np.broadcast_to(g.R[:, None], (g.nr + 1, g.nz)).copy()
    w = 1.0 + 3.0 * np.broadcast_to(g.Z[None, :], (g.nr, g.nz + 1))
    r, z = random_points(g, 20, near_wall=False)
    values = delta.interpolation_matrix(g, r, z) @ ops.pack(u, w)
    assert values[:20] == pytest.approx(2.0 * r, abs=1e-12)
    assert values[20:] == pytest.approx(1.0 + 3.0 * z, abs=1e-12)


def test_spreading_conserves_force_and_its_moment():
    """E^T spreads each point force with weights that sum to one and centre on the point."""
    g = uniform_grid(16)
    r, z = random_points(g, 8, near_axis=False, near_wall=False)
    E = delta.interpolation_matrix(g, r, z)
    f = RNG.normal(size=16)
    spread = E.T @ f
    n_u = g.n_u
    assert spread[:n_u].sum() == pytest.approx(f[:8].sum(), rel=1e-12)
    assert spread[n_u:].sum() == pytest.approx(f[8:].sum(), rel=1e-12)
    z_w = np.broadcast_to(g.Z[None, 1:-1], (g.nr, g.nz - 1)).ravel()
    assert (spread[n_u:] * z_w).sum() == pytest.approx((f[8:] * z).sum(), rel=1e-12)


def test_spreading_is_the_adjoint_of_interpolation():
    """<E q, f> = <q, E^T f>: the work done by the point forces equals the work of the spread force."""
    g = uniform_grid(10)
    r, z = random_points(g, 6)
    E = delta.interpolation_matrix(g, r, z)
    q, f = RNG.normal(size=g.n_velocity), RNG.normal(size=12)
    assert (E @ q) @ f == pytest.approx(q @ (E.T @ f), rel=1e-12)


def test_meridian_points_are_about_one_cell_apart_and_avoid_the_axis():
    r, z = body.meridian_points(0.5, 0.05)
    spacing = np.hypot(np.diff(r), np.diff(z))
    assert spacing.max() == pytest.approx(spacing.min(), rel=1e-12)
    assert 0.045 < spacing[0] <= 0.05 and r.min() > 0.0
    assert np.hypot(r, z) == pytest.approx(np.full_like(r, 0.5))


# -- operators -------------------------------------------------------------------------------------

def helmholtz_error(n):
    """Solve (M - L) q = M f for u = r(1-r) sin(pi z/2), w = cos(pi r) sin(pi z) on [0,1]^2
    (wall below, slip above and outside); max error at the unknowns."""
    g = uniform_grid(n)
    ops = operators.AxisymmetricOperators(g)
    ru, zu = np.meshgrid(g.R[1:-1], g.zc, indexing="ij")
    rw, zw = np.meshgrid(g.rc, g.Z[1:-1], indexing="ij")
    u_exact = ru * (1 - ru) * np.sin(np.pi * zu / 2)
    w_exact = np.cos(np.pi * rw) * np.sin(np.pi * zw)
    # u - (lap u - u/r^2) and w - lap w, worked out by hand
    f_u = np.sin(np.pi * zu / 2) * (ru * (1 - ru) * (1 + np.pi**2 / 4) + 3.0)
    f_w = np.sin(np.pi * zw) * (np.cos(np.pi * rw) * (1 + 2 * np.pi**2) + np.pi * np.sin(np.pi * rw) / rw)
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    M = sp.diags(ops.mass)
    q = spla.spsolve((M - ops.laplacian).tocsc(), ops.mass * np.concatenate([f_u.ravel(), f_w.ravel()]))
    exact = np.concatenate([u_exact.ravel(), w_exact.ravel()])
    return np.abs(q[:g.n_u] - exact[:g.n_u]).max(), np.abs(q[g.n_u:] - exact[g.n_u:]).max()


def test_vector_laplacian_with_hoop_term_converges_at_second_order():
    errors = np.array([helmholtz_error(n) for n in (8, 16, 32)])
    rates = np.log2(errors[:-1] / errors[1:])
    assert rates.min() > 1.8, f"observed rates {rates}"
    assert errors[-1].max() < 2e-3


def test_laplacian_and_mass_are_symmetric_and_definite():
    g = grid.make_grid(0.1, 0.5, (0.2, 0.6), 2.0, 2.0, 1.2, grid.Boundaries(grid.WALL, grid.WALL, grid.WALL))
    ops = operators.AxisymmetricOperators(g)
    lap = ops.laplacian.toarray()
    assert np.abs(lap - lap.T).max() < 1e-14 * np.abs(lap).max()
    assert np.linalg.eigvalsh(lap).max() < 0.0 and ops.mass.min() > 0.0


def test_curl_fields_are_divergence_free_on_a_graded_grid():
    g = grid.make_grid(0.05, 0.5, (0.3, 0.9), 3.0, 4.0, 1.1, grid.Boundaries())
    ops = operators.AxisymmetricOperators(g)
    q = ops.curl @ RNG.normal(size=g.n_psi)
    flux_scale = np.abs(ops.divergence).max() * np.abs(q).max()
    assert np.abs(ops.divergence @ q).max() < 1e-14 * flux_scale


# -- one step of the flow with a sphere --------------------------------------------------------------

@pytest.fixture(scope="module")
def stepped():
    """A sphere (D = 0.4) set moving at 1 m/s in fluid at rest: one implicit step."""
    g = grid.make_grid(0.025, 0.6, (0.1, 1.0), 2.0, 2.5, 1.1, grid.Boundaries())
    ops = operators.AxisymmetricOperators(g)
    flow = solver.FlowSolver(ops, viscosity=0.01, dt=0.01)
    surface = body.SphereSurface(0.2, g.h)
    r, z = surface.positions(0.3)
    E = delta.interpolation_matrix(g, r, z)
    EC = (E @ flow.curl).tocsr()
    prediction = flow.predict()
    n = surface.n_points
    target = np.concatenate([np.zeros(n), np.ones(n)]) - E @ prediction.q
    forces = flow.solve_forces(EC, target, None, tol=1e-10)
    flow.accept(prediction, forces.psi, E.T @ forces.forces)
    yield g, ops, flow, E, forces
    flow.destroy()


def test_the_projected_field_is_divergence_free_at_round_off(stepped):
    g, ops, flow, E, _ = stepped
    div = flow.divergence()
    flux_scale = g.h * g.h * np.abs(flow.q).max()
    assert np.abs(div).max() < 1e-13 * flux_scale


def test_the_step_enforces_no_slip_at_every_point(stepped):
    g, ops, flow, E, forces = stepped
    n = E.shape[0] // 2
    slip = E @ flow.q - np.concatenate([np.zeros(n), np.ones(n)])
    assert np.abs(slip).max() < 1e-8
    assert forces.iterations > 0


def test_the_preconditioned_solve_agrees_with_plain_cg(stepped):
    """The sub-cell table preconditioner changes the iteration count, not the answer."""
    g, ops, flow, E, forces = stepped
    EC = (E @ flow.curl).tocsr()
    n = E.shape[0] // 2
    target = np.concatenate([np.zeros(n), np.ones(n)])
    plain = flow.solve_forces(EC, target, None, tol=1e-10)
    table = solver.ForcePreconditioner(g.h)
    surface = body.SphereSurface(0.2, g.h)
    r, dz = surface.positions(-0.2)

    def EC_at(z_centre):
        return (delta.interpolation_matrix(g, r, z_centre + dz) @ flow.curl).tocsr()

    import scipy.linalg as sla

    S, _ = table.build(flow, 0.5, EC_at)
    factor = sla.cho_factor(S)
    fast = flow.solve_forces(EC, target, None, tol=1e-10, preconditioner=lambda v: sla.cho_solve(factor, v))
    assert fast.iterations < plain.iterations / 3
    assert fast.forces[n:].sum() == pytest.approx(plain.forces[n:].sum(), rel=1e-7)


def test_pressure_recovery_balances_the_momentum_equation(stepped):
    """D^T p reproduces A q - r - E^T f: the residual the null-space step leaves lies in range(D^T)."""
    g, ops, flow, E, _ = stepped
    p = flow.pressure().ravel()
    residual = flow.A @ flow.q - flow.last_rhs - flow.forcing
    assert np.abs(ops.divergence.T @ p - residual).max() < 1e-8 * np.abs(residual).max()


def test_graded_axis_is_uniform_inside_and_grows_smoothly_outside():
    nodes = grid.graded_axis(0.3, 0.9, 0.05, 0.0, 5.0, 1.08)
    widths = np.diff(nodes)
    assert nodes[0] == 0.0 and nodes[-1] == 5.0
    fine = (nodes[:-1] >= 0.3 - 1e-12) & (nodes[1:] <= 0.9 + 1e-12)
    assert widths[fine] == pytest.approx(np.full(fine.sum(), 0.05))
    ratios = widths[1:] / widths[:-1]
    assert ratios.max() < 1.08 * 1.0001 and ratios.min() > 1.0 / (1.08 * 1.0001)


def test_scene_grids_cover_the_path_and_respect_the_container():
    from fem_bounce import scene
    from fem_bounce.models.ib import domain

    case3 = scene.load("li2011-case3")
    g = domain.build_grid(case3)
    assert g.boundaries == grid.Boundaries(grid.WALL, grid.SLIP, grid.SLIP)
    assert g.fine_z[0] == 0.0 and g.fine_z[1] >= case3.initial_gap + 0.0095
    assert g.R[-1] >= 15 * 0.0095 and g.h == pytest.approx(0.0095 / 32)
    box = domain.build_grid(scene.load("tencate2002-e4"))
    assert (box.boundaries.top, box.boundaries.outer) == (grid.WALL, grid.WALL)
    assert box.R[-1] == pytest.approx(0.0564) and box.Z[-1] == pytest.approx(0.16)
    stream = domain.build_grid(scene.load("sphere-drag-re100"))
    assert stream.boundaries.bottom == grid.INFLOW and stream.boundaries.inflow_velocity == 0.1


def test_a_uniform_stream_stays_uniform_through_inflow_and_outflow():
    g = grid.make_grid(0.00125, 0.01, (0.07, 0.1), 0.05, 0.15, 1.05,
                       grid.Boundaries(grid.INFLOW, grid.OUTFLOW, grid.SLIP, inflow_velocity=0.1))
    flow = solver.FlowSolver(operators.AxisymmetricOperators(g), viscosity=1e-5, dt=0.002)
    for _ in range(10):
        flow.accept(flow.predict(), np.zeros(g.n_psi), np.zeros(g.n_velocity))
    u, w = flow.full_velocity()
    assert np.abs(w - 0.1).max() < 1e-12 and np.abs(u).max() < 1e-12
    flow.destroy()
