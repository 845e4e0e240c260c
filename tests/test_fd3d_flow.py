"""The 3-D fictitious-domain flow (fem_bounce.models.fd3d) and the geometry object (fem_bounce.fem.geometry).

Cheapest first: the Cartesian geometry's integrals and rigid modes (the axisymmetric geometry's forms:
tests/test_fem_forms.py); a Stokes flow the Taylor-Hood space holds (quadratic velocity, linear
pressure), penalty included, reproduced to round-off; the penalised sphere's interior moving rigidly within
1e-3 of its speed in each mode, in the steady solve and in a BDF2 step; the step's affine response against a
direct solve and its penalty force against the integral it stands for; the half box (symmetry plane y = 0)
against the full box; a mesh velocity carried by an amplitude (the oblique hold's) as its mode's forcing.  Meshes
of a few thousand unknowns; the whole file runs in well under a minute.
"""
from __future__ import annotations

import math

import basix.ufl
import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh
from mpi4py import MPI

from fem_bounce.fem.compat import collapse, geometry_cells
from fem_bounce.fem.geometry import Cartesian
from fem_bounce.fem.solver import FactorizedOperator
from fem_bounce.models.fd3d.flow import PenalisedFlow3D
from fem_bounce.models.fd3d.indicator import SphereIndicator
from fem_bounce.models.fd3d.mesh import SIDE_X, SIDE_Y, TOP, WALL, BoxSpec, create_box_mesh

COMM = MPI.COMM_WORLD
RADIUS, VISCOSITY, DENSITY = 1.0, 1.0, 1.0
CLOSED = {WALL: "no-slip", TOP: "no-slip", SIDE_X: "no-slip", SIDE_Y: "no-slip"}


# -- the geometry object (the axisymmetric one's forms: tests/test_fem_forms.py) ------------------------------
@pytest.mark.mpi
def test_cartesian_integrals_and_rigid_modes():
    domain = mesh.create_box(COMM, [[-1.0, 0.0, 0.0], [1.0, 1.0, 1.0]], [2, 2, 2])
    full, half = Cartesian(domain), Cartesian(domain, mirrored=True)
    assert full.integrate(full.weighted(1.0)) == pytest.approx(2.0, rel=1e-12)
    assert half.integrate(half.weighted(1.0)) == pytest.approx(4.0, rel=1e-12)  # the mirrored box [-1,1]^2 x [0,1]
    assert len(full.rigid_modes((0, 0, 0))) == 6 and half.mode_names == ("U_x", "U_z", "Omega_y")
    # the modes as UFL against numpy's U + omega x (x - X), with every mode in the combination
    center = (0.3, -0.2, 0.5)
    amplitudes = np.array([0.5, -1.0, 2.0, 0.7, -0.3, 1.1])
    V = fem.functionspace(domain, ("Lagrange", 1, (3,)))
    rigid = fem.Function(V)
    rigid.interpolate(fem.Expression(full.rigid_velocity(amplitudes, center), V.element.interpolation_points))
    points = V.tabulate_dof_coordinates()
    expected = full.rigid_velocity_at(points, amplitudes, center)
    assert np.allclose(rigid.x.array.reshape(-1, 3), expected, rtol=0, atol=1e-13)
    # a rotation about the centre has no net momentum over a box centred on it
    box = mesh.create_box(COMM, [[-1.0, -1.0, -1.0], [1.0, 1.0, 1.0]], [2, 2, 2])
    geometry = Cartesian(box)
    rotation = geometry.rigid_modes((0.0, 0.0, 0.0))[4]
    assert abs(geometry.integrate(geometry.weighted(rotation[0]))) < 1e-12
    assert geometry.integrate(geometry.weighted(ufl.inner(rotation, rotation))) == pytest.approx(16.0 / 3.0, rel=1e-12)
    force, torque = half.components([1.0, 2.0, 3.0])
    assert force.tolist() == [1.0, 0.0, 2.0] and torque.tolist() == [0.0, 3.0, 0.0]


# -- the penalised flow -------------------------------------------------------------------------------------
def _box(mirrored: bool, surface_size: float = 0.4, gap: float = 1.0):
    spec = BoxSpec(half_width=3.0, height=4.0, center=(0.0, 0.0, RADIUS + gap), radius=RADIUS,
                   surface_size=surface_size, coarse_size=1.5, grading=0.4, mirrored=mirrored)
    domain, _, facets = create_box_mesh(COMM, spec, cache=False)
    return spec, domain, facets


def _flow(mirrored: bool, strength: float = 1e4, surface_size: float = 0.4, sides=None, inflow=(0.0, 0.0, 0.0)):
    spec, domain, facets = _box(mirrored, surface_size)
    sphere = SphereIndicator(domain, RADIUS, 2.0 * surface_size, spec.center)
    rate = strength * VISCOSITY / (DENSITY * surface_size**2)
    return PenalisedFlow3D(Cartesian(domain, mirrored=mirrored), facets, CLOSED if sides is None else sides,
                           DENSITY, VISCOSITY, sphere, rate, inflow=inflow, prefix=f"test_fd3d_{int(mirrored)}_")


def _function(flow, vector):
    out = fem.Function(flow.W)
    vector.copy(out.x.petsc_vec)
    out.x.scatter_forward()
    return out


@pytest.mark.mpi
def test_stokes_flow_the_space_holds_is_reproduced_to_round_off():
    """u = (z^2 + x y, x^2 - y^2 / 2 ... ) quadratic and solenoidal, p linear, with the penalty on: the body force
    -mu Lap u + grad p plus rho c_B phi u (integrated with the penalty's own quadrature) and u on every side."""
    flow = _flow(mirrored=False, strength=1e3, sides={side: "inflow" for side in CLOSED},
                 inflow=lambda x: np.vstack([x[2] ** 2 + x[0] * x[1], x[0] ** 2 - 0.5 * x[1] ** 2, x[1] ** 2]))
    x = ufl.SpatialCoordinate(flow.mesh)
    exact = ufl.as_vector([x[2] ** 2 + x[0] * x[1], x[0] ** 2 - 0.5 * x[1] ** 2, x[1] ** 2])
    pressure = 2.0 * x[0] - x[1] + 0.5 * x[2]
    laplacian = ufl.as_vector([2.0, 1.0, 2.0])  # of each component (div exact = y - y = 0)
    body_force = -VISCOSITY * laplacian + ufl.grad(pressure)
    load = flow.geometry.source(body_force, flow.v) + flow.penalty(exact, flow.v)
    flow.steady(load)
    state = flow.x0
    V, velocity_dofs = collapse(flow.W.sub(0))
    expected = fem.Function(V)
    expected.interpolate(fem.Expression(exact, V.element.interpolation_points))
    error = np.abs(state.x.array[velocity_dofs] - expected.x.array).max()
    assert flow.mesh.comm.allreduce(error, op=MPI.MAX) < 1e-9 * 10.0  # |u| ~ 10 in the box
    Q, pressure_dofs = collapse(flow.W.sub(1))
    expected_p = fem.Function(Q)
    expected_p.interpolate(fem.Expression(pressure, Q.element.interpolation_points))
    shift = state.x.array[pressure_dofs] - expected_p.x.array  # p is pinned to 0 at a corner: a constant apart
    spread = flow.mesh.comm.allreduce(np.ptp(shift) if shift.size else 0.0, op=MPI.MAX)
    assert spread < 1e-8 * 10.0
    flow.destroy()


@pytest.mark.mpi
def test_uniform_stream_through_slip_sides_is_reproduced():
    """In at the top, out through z = 0 (do nothing), slip sides and the symmetry plane, no penalty: the uniform
    stream with zero pressure is the discrete solution."""
    spec, domain, facets = _box(mirrored=True)
    sphere = SphereIndicator(domain, RADIUS, 0.8, spec.center)
    flow = PenalisedFlow3D(Cartesian(domain, mirrored=True), facets,
                           {TOP: "inflow", WALL: "outflow", SIDE_X: "slip", SIDE_Y: "slip"}, DENSITY, VISCOSITY,
                           sphere, 0.0, inflow=(0.0, 0.0, -2.0), prefix="test_fd3d_stream_")
    flow.steady()
    V, velocity_dofs = collapse(flow.W.sub(0))
    velocity = flow.x0.x.array[velocity_dofs].reshape(-1, 3)
    error = np.abs(velocity - np.array([0.0, 0.0, -2.0])).max(initial=0.0)
    _, pressure_dofs = collapse(flow.W.sub(1))
    pressure = np.abs(flow.x0.x.array[pressure_dofs]).max(initial=0.0)
    assert flow.mesh.comm.allreduce(max(error, pressure), op=MPI.MAX) < 1e-10
    flow.destroy()


@pytest.fixture(scope="module")
def half_box():
    flow = _flow(mirrored=True)
    response = flow.steady()
    yield flow, response
    flow.destroy()


@pytest.mark.mpi
def test_penalised_sphere_moves_rigidly_in_each_mode(half_box):
    flow, response = half_box
    depth = RADIUS - flow.sphere.width  # inside the band: where phi = 1
    points = collapse(flow.W.sub(0).sub(0))[0].tabulate_dof_coordinates()
    center = flow.sphere.center.value.copy()
    inside = points[np.linalg.norm(points - center, axis=1) <= depth]
    for k, name in enumerate(response.names):
        amplitudes = np.zeros(len(response.names))
        amplitudes[k] = 1.0  # a speed of 1 m/s, or of omega a = 1 m/s at the surface
        slip = flow.interior_slip(_function(flow, flow.field(amplitudes)), amplitudes, depth)
        assert slip < 1e-3, name
        # against rest the same field slips by the interior's own largest velocity component: the check can fail
        local = np.abs(flow.geometry.rigid_velocity_at(inside, amplitudes, center)).max(initial=0.0)
        speed = flow.mesh.comm.allreduce(local, op=MPI.MAX)
        assert speed > 0.1
        assert flow.interior_slip(_function(flow, flow.field(amplitudes)), 0 * amplitudes, depth) > 0.99 * speed


@pytest.mark.mpi
def test_resistance_is_symmetric_and_dissipative(half_box):
    _, response = half_box
    R = response.resistance
    assert np.abs(R - R.T).max() < 1e-8 * np.abs(R).max()
    assert np.linalg.eigvalsh(0.5 * (R + R.T)).max() < 0
    # Stokes drag 6 pi mu a within a factor 3 (a wall one radius below, walls 2 radii to the side, coarse mesh)
    assert 1.0 < -R[0, 0] / (6.0 * math.pi * VISCOSITY * RADIUS) < 3.0


def _mirrored(half_domain):
    """The full box made of the half box's tetrahedra and their mirror images in y = 0 (one process), with the
    facet groups: a mesh whose discrete problem is exactly symmetric."""
    x = half_domain.geometry.x
    cells = geometry_cells(half_domain)
    off_plane = np.abs(x[:, 1]) > 1e-12 * np.abs(x).max()
    image = np.arange(len(x))
    image[off_plane] = len(x) + np.arange(off_plane.sum())
    points = np.vstack([x, x[off_plane] * np.array([1.0, -1.0, 1.0])])
    domain = mesh.create_mesh(MPI.COMM_SELF, np.vstack([cells, image[cells]]).astype(np.int64),
                              ufl.Mesh(basix.ufl.element("Lagrange", "tetrahedron", 1, shape=(3,))), points)
    top, width = x[:, 2].max(), x[:, 0].max()
    markers = {WALL: lambda p: np.isclose(p[2], 0.0), TOP: lambda p: np.isclose(p[2], top),
               SIDE_X: lambda p: np.isclose(np.abs(p[0]), width), SIDE_Y: lambda p: np.isclose(np.abs(p[1]), width)}
    domain.topology.create_connectivity(2, 3)
    found = {tag: mesh.locate_entities_boundary(domain, 2, marker) for tag, marker in markers.items()}
    indices = np.concatenate(list(found.values()))
    values = np.concatenate([np.full(len(facets), tag, dtype=np.int32) for tag, facets in found.items()])
    order = np.argsort(indices)
    return domain, mesh.meshtags(domain, 2, indices[order].astype(np.int32), values[order])


def test_half_box_agrees_with_full_box():
    """The half box's weight 2 gives the whole sphere's resistance: the half box against the full box made of its
    tetrahedra and their mirror images (the same discrete problem, so to round-off), and the full box's
    out-of-plane modes do not couple to the in-plane ones."""
    if COMM.size > 1:
        pytest.skip("the mirrored mesh is put together on one process")
    spec, half_domain, half_facets = _box(mirrored=True)
    full_domain, full_facets = _mirrored(half_domain)
    flows = []
    cases = ((Cartesian(half_domain, mirrored=True), half_facets), (Cartesian(full_domain), full_facets))
    for geometry, facets in cases:
        sphere = SphereIndicator(geometry.mesh, RADIUS, 0.8, spec.center)
        flows.append(PenalisedFlow3D(geometry, facets, CLOSED, DENSITY, VISCOSITY, sphere, 1e4 / 0.4**2,
                                     prefix=f"test_fd3d_mirror_{len(flows)}_"))
    try:
        half, full = flows
        assert full.unknowns > 1.5 * half.unknowns  # the plane's dofs are shared
        R_half, R_full = half.steady().resistance, full.steady().resistance
        names = full.geometry.mode_names
        plane = [names.index(name) for name in half.geometry.mode_names]
        in_plane = R_full[np.ix_(plane, plane)]
        scale = np.abs(R_full).max()
        assert np.abs(R_half - in_plane).max() < 1e-7 * scale
        out = [names.index(name) for name in ("U_y", "Omega_x", "Omega_z")]
        assert np.abs(R_full[np.ix_(out, plane)]).max() < 1e-7 * scale
        for k, name in enumerate(names):  # all six rigid motions held in the full box
            amplitudes = np.eye(len(names))[k]
            slip = full.interior_slip(_function(full, full.field(amplitudes)), amplitudes, RADIUS - 0.8)
            assert slip < 1e-3, name
        assert np.abs(np.diag(R_full)[out]).min() > 0.1 * scale  # the out-of-plane motions do meet resistance
    finally:
        for flow in flows:
            flow.destroy()


@pytest.mark.mpi
def test_bdf2_step_is_affine_in_the_rigid_amplitudes():
    """One step from a steady state with the sphere's motion changed: field(s) is the direct solve with the rigid
    motion in the right-hand side, the interior moves with the sphere, and the penalty force is
    rho c_B int phi (u - U_rigid) . m_i."""
    flow = _flow(mirrored=True)
    flow.steady()
    flow.set_state(flow.field([1.0, 0.0, 0.0]))  # the sphere translating along the wall, held
    flow.set_time_step(0.05, order=1)
    response = flow.step()
    amplitudes = np.array([0.8, -0.3, 0.5])
    u = _function(flow, flow.field(amplitudes))
    # the plain reference: one solve with sum_j s_j rho c_B b_j in the right-hand side
    rhs = flow.step_rhs().copy()
    for s, unit in zip(amplitudes, flow.units):
        rhs.axpy(float(s), unit)
    operator = FactorizedOperator(flow.step_matrix, "test_fd3d_direct_")
    direct = rhs.duplicate()
    operator.solve(rhs, direct)
    difference = direct.copy()
    difference.axpy(-1.0, u.x.petsc_vec)
    assert difference.norm() < 1e-9 * direct.norm()
    operator.destroy()
    translation, rotation = flow.geometry.components(amplitudes)
    speed = np.linalg.norm(translation) + np.linalg.norm(rotation) * RADIUS  # the fastest point of the sphere
    assert flow.interior_slip(u, amplitudes, RADIUS - flow.sphere.width) < 1e-3 * speed
    # the penalty's reaction integrated directly, mode by mode
    geometry, sphere = flow.geometry, flow.sphere
    velocity = ufl.split(u)[0]
    rigid = geometry.rigid_velocity(amplitudes, sphere.center)
    direct_force = np.array([flow.density * flow.penalty_rate * geometry.integrate(
        geometry.weighted(sphere.phi * ufl.inner(velocity - rigid, m), sphere.dx)) for m in flow.modes])
    assert np.abs(direct_force).max() > 1.0  # the step's inertia and the changed motion push on the sphere
    assert np.allclose(response.penalty_force(amplitudes), direct_force, rtol=1e-8,
                       atol=1e-10 * np.abs(direct_force).max())
    assert flow.factorisations == 1
    flow.destroy()


@pytest.mark.mpi
def test_a_carried_mesh_velocity_joins_its_modes_forcing():
    """flow.PenalisedFlow3D's `carried` (the oblique hold's mesh velocity along z, moving with the amplitude U_z):
    its load is the convection term a matrix with that mesh velocity has, taken about u* (A_w u* - A u* = -load,
    off the boundary rows), and the step stays affine: field(s) solves A u = b + sum_j s_j rho c_B b_j + s_z load."""
    spec, domain, facets = _box(True, 0.4)
    x = ufl.SpatialCoordinate(domain)
    carried = ufl.as_vector((0.0, 0.0, ufl.exp(-(x[0] ** 2 + x[1] ** 2 + (x[2] - spec.center[2]) ** 2))))

    def flow(**extra):
        sphere = SphereIndicator(domain, RADIUS, 0.8, spec.center)
        return PenalisedFlow3D(Cartesian(domain, mirrored=True), facets, CLOSED, DENSITY, VISCOSITY, sphere,
                               1e4 * VISCOSITY / (DENSITY * 0.4**2), prefix="test_fd3d_carried_", **extra)

    plain, moved = flow(carried=("U_z", carried)), flow(mesh_velocity=carried)
    for each in (plain, moved):
        each.steady()
        each.set_state(each.field([0.3, 1.0, 0.2]))  # u* of the step: the steady flow of a moving sphere
        each.set_time_step(0.05, order=1)
    plain.carrying = True
    plain.step()
    moved.step()
    amplitudes = np.array([0.8, -0.3, 0.5])
    load = plain._carried[2]
    star = plain.states[0].x.petsc_vec
    product, reference = star.duplicate(), star.duplicate()
    moved.step_matrix.mult(star, product)
    plain.step_matrix.mult(star, reference)
    product.axpy(-1.0, reference)  # A_w u* - A u*
    product.axpy(1.0, load)
    # round-off: a few ulps of A u* (the penalty's rows make it ~1e4 here, the load ~0.2)
    assert load.norm() > 1e-3 and product.norm() < 1e-10 * load.norm() + 1e-14 * reference.norm()
    rhs = plain.step_rhs().copy()
    for s, unit in zip(amplitudes, plain.units):
        rhs.axpy(float(s), unit)
    rhs.axpy(float(amplitudes[plain.geometry.mode_names.index("U_z")]), load)
    operator = FactorizedOperator(plain.step_matrix, "test_fd3d_carried_direct_")
    direct = rhs.duplicate()
    operator.solve(rhs, direct)
    direct.axpy(-1.0, plain.field(amplitudes))
    assert direct.norm() < 1e-9 * rhs.norm()
    operator.destroy()
    for each in (plain, moved):
        each.destroy()
