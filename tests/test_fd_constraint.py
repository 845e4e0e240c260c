"""The rigid-body constraint as an implicit penalisation in the step's matrix (numerics.fd.constraint =
"implicit", models/fd/penalised.py), its adaptive steps through a collision, the refined patch that follows
the spheres (numerics.fd.patch), and the field-split flow solver, at toy size."""
import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI

from fem_bounce import output, scene
from fem_bounce.integrator import BodyIntegrator
from fem_bounce.models.fd.domain import penalty_rate, time_step
from fem_bounce.fem.compat import geometry_cells
from fem_bounce.models.fd.immersed import interior_slip
from fem_bounce.models.fd.model import FictitiousDomainModel
from fem_bounce.run import simulate

TINY = {"numerics.fd.cells_per_diameter": 6, "run.end_time": 0.01}
# its indicator's edge on the surface by default; on the fixed mesh (the moving one: tests/test_fd_moving.py)
IMPLICIT = {"numerics.fd.mesh": "fixed", "numerics.fd.constraint": "implicit"}


def implicit_model(changes: dict):
    sc = scene.load("li2011-case3", {"numerics.fd.cells_per_diameter": 8, **IMPLICIT, **changes})
    fd = FictitiousDomainModel(sc, MPI.COMM_WORLD)
    fd.build(BodyIntegrator(sc, resolved=True))
    return fd


@pytest.mark.mpi
def test_the_matrix_sees_the_indicator_the_band_assembler_integrates():
    """phi enters the matrix through a quadrature function at the band assembler's own points: its volume
    integral is V_phi to round-off, and zero once the sphere is placed elsewhere and back."""
    model = implicit_model({})
    try:
        flow, sphere = model.flow, model.immersed.spheres[0]
        volume = fem.form(flow.geometry.weighted(flow.indicator, flow.dx_indicator))
        assembled = flow.geometry.integrate(volume)
        assert assembled == pytest.approx(sphere.volume, rel=1e-10)
        center = sphere.center
        flow.place(model.immersed, [center + 0.3 * sphere.band.width])
        flow.place(model.immersed, [center])
        again = flow.geometry.integrate(volume)
        assert again == pytest.approx(assembled, rel=1e-12)
    finally:
        model.destroy()


@pytest.mark.mpi
def test_the_interior_follows_any_new_velocity_within_the_step():
    """Rigidity through a collision at toy size: the step's flow is u(U) = x_0 + U x_1 for whatever U the
    contact gives at the end of the step.  With the fluid and sphere moving at -0.4 m/s toward the wall
    0.2 D below and the step solved once, the interior holds U = -0.4, 0 and a rebound +0.3 m/s to 1e-3 of
    the speed (the penalty's slip ~1 / penalty_strength); with the penalty a thousand times weaker the slip
    is larger (the check can fail)."""
    speed, slips = -0.4, {}
    for strength in (1e5, 1e2):
        model = implicit_model({"numerics.fd.penalty_strength": strength, "initial_gap": 0.0019})
        try:
            flow, sphere = model.flow, model.immersed.spheres[0]
            flow.set_uniform((0.0, speed))
            model.history.velocities = [np.array([speed])] * len(model.history.velocities)
            model.history.interiors = [np.array([speed * sphere.volume])] * len(model.history.interiors)
            flow.linearise(model.history.momentum_history, model.history.reference_velocity)
            new = fem.Function(flow.W)
            depth = sphere.band.radius - sphere.band.width
            worst = 0.0
            for velocity in (speed, 0.0, 0.3):
                flow.field([velocity], new.x.petsc_vec)
                new.x.scatter_forward()
                worst = max(worst, interior_slip(flow, new, sphere.center, velocity, depth))
            slips[strength] = worst
        finally:
            model.destroy()
    assert slips[1e5] < 1e-3 * abs(speed)
    assert slips[1e2] > 3.0 * slips[1e5]


def test_the_implicit_constraint_has_no_viscous_step_bound():
    """In 95 % glycerol the one-shot penalty's bound 0.025 h^2 / nu sets dt; the implicit constraint keeps
    the convective one, and its friction rate beats the viscous rate by penalty_strength."""
    changes = {"numerics.fd.cells_per_diameter": 12}
    penalty = scene.load("li2011-table3-steel-95", {**changes, "numerics.fd.constraint": "penalty"})
    implicit = scene.load("li2011-table3-steel-95", {**changes, **IMPLICIT})
    fine = penalty.sphere.diameter / 12
    viscous_rate = penalty.liquid.kinematic_viscosity / fine**2
    assert time_step(penalty) == pytest.approx(0.025 / viscous_rate)
    assert time_step(implicit) > 5.0 * time_step(penalty)
    assert penalty_rate(implicit) >= implicit.numerics.fd.penalty_strength * viscous_rate


def test_an_implicit_run_completes_and_reports_its_cost(tmp_path):
    sc = scene.load("li2011-case3", {**TINY, **IMPLICIT})
    summary = simulate(sc, "fd", MPI.COMM_WORLD, tmp_path, force=True, progress=False, plots=False)
    assert summary["status"] == "completed"
    report = summary["fd"]
    assert report["constraint"] == "implicit"
    assert report["factorisations"] == summary["steps"]
    assert report["interior_slip_m_s"] < 1e-3 * abs(output.read_trajectory(tmp_path)["velocity"][-1])


def test_the_rebound_does_not_move_with_the_step(tmp_path):
    """Case 3 on the fixed mesh at 12 cells/D to the first apex: the contact reverses the sphere within one fluid
    step, and how much liquid that step reverses with it grows with dt, so with the cfl step throughout the apex
    moves 3.7 % from cfl 0.8 to 0.2 (4.61 -> 4.44 mm; e_1 0.780 -> 0.777, both 2 % above the adaptive runs' 0.765).
    Adaptive steps (numerics.fd.adaptive_step, the default) shorten to min_step_factor times the cfl step
    through the contact: e_1 then moves 0.5 % (0.767 -> 0.763), the apex 1.6 % (4.34 -> 4.27 mm, the rise)."""
    runs = {}
    for cfl in (0.8, 0.2):
        changes = {**IMPLICIT, "numerics.fd.cells_per_diameter": 12, "numerics.fd.peak_cfl": cfl, "run.bounces": 1}
        sc = scene.load("li2011-case3", changes)
        summary = simulate(sc, "fd", MPI.COMM_WORLD, tmp_path / str(cfl), force=True, progress=False, plots=False)
        assert summary["fd"]["shortest_step_s"] == pytest.approx(sc.numerics.fd.min_step_factor * time_step(sc))
        runs[cfl] = summary["rebounds"][0]
    assert runs[0.2]["restitution"] == pytest.approx(runs[0.8]["restitution"], rel=0.01)
    assert runs[0.2]["apex_gap"] == pytest.approx(runs[0.8]["apex_gap"], rel=0.025)


def test_adaptive_steps_need_the_implicit_constraint():
    """The one-shot penalty keeps its factors, so it takes one step length: asking it for adaptive steps is
    refused before anything is built, naming the setting."""
    sc = scene.load("li2011-case3", {"numerics.fd.constraint": "penalty", "numerics.fd.adaptive_step": True})
    with pytest.raises(scene.SceneError, match="numerics.fd.adaptive_step"):
        FictitiousDomainModel(sc, MPI.COMM_WORLD)
    assert not scene.load("li2011-case3", {"numerics.fd.constraint": "penalty"}).numerics.fd.resolved("adaptive_step")


def largest_cell_near(mesh, center: float, reach: float) -> float:
    """The longest triangle edge [m] among the cells whose centroid lies within `reach` of (0, center) (all ranks)."""
    corners = mesh.geometry.x[geometry_cells(mesh)[:mesh.topology.index_map(2).size_local]][:, :, :2]
    near = np.hypot(corners[:, :, 0].mean(axis=1), corners[:, :, 1].mean(axis=1) - center) < reach
    edges = np.linalg.norm(corners - np.roll(corners, 1, axis=1), axis=2).max(axis=1)
    return mesh.comm.allreduce(float(edges[near].max(initial=0.0)), op=MPI.MAX)


@pytest.mark.mpi
@pytest.mark.parametrize("constraint", ["penalty", "implicit"])
def test_the_refined_patch_follows_the_sphere_to_the_wall(constraint):
    """The sphere falls from 1.6 D to touching in steps of 0.05 D: the patch moves (a new mesh) whenever the
    centre strays half the margin from it, never otherwise, and at every position the cells within a quarter
    diameter of the surface have the fine size (gmsh's edges up to 1.5 of it; a patch left behind grades to
    coarser cells there), the liquid carried over stays at rest, and a new mesh's indicator is where the sphere
    is."""
    sc = scene.load("li2011-case3", {"numerics.fd.cells_per_diameter": 6, "numerics.fd.patch": True,
                                     "numerics.fd.constraint": constraint})
    model = FictitiousDomainModel(sc, MPI.COMM_WORLD)
    model.build(BodyIntegrator(sc, resolved=True))
    try:
        a, diameter, fine = sc.sphere.radius, sc.sphere.diameter, model.domain.fine_size
        half_margin = 0.5 * sc.numerics.fd.patch_margin * diameter
        centers = np.arange(sc.initial_gap + a, a, -0.05 * diameter)
        for center in centers:
            before, patch = model.remeshes, model.patches[0]
            model.follow([center])
            moved = abs(center - patch) > half_margin
            assert model.remeshes == before + moved
            if moved:  # the new mesh's indicator where the sphere is
                assert model.immersed.spheres[0].center == pytest.approx(center)
            assert abs(center - model.patches[0]) <= half_margin
            assert largest_cell_near(model.mesh, center, a + 0.25 * diameter) < 1.5 * fine
            assert np.abs(model.flow.now.x.array).max() < 1e-12
        assert model.remeshes >= 3
    finally:
        model.destroy()


def test_the_field_split_solver_gives_the_direct_solution(tmp_path):
    """GMRES with the Schur field split and BoomerAMG reproduces the MUMPS trajectory to its tolerance (on the fixed
    mesh: the moving one factorises its changing matrix directly and refuses the setting)."""
    runs = {}
    for solver in ("direct", "fieldsplit"):
        sc = scene.load("li2011-case3", {**TINY, **IMPLICIT, "run.end_time": 0.003, "numerics.fd.solver": solver})
        simulate(sc, "fd", MPI.COMM_WORLD, tmp_path / solver, force=True, progress=False, plots=False)
        runs[solver] = output.read_trajectory(tmp_path / solver)
    assert np.allclose(runs["fieldsplit"]["velocity"], runs["direct"]["velocity"], rtol=1e-6, atol=1e-12)
    assert np.allclose(runs["fieldsplit"]["f_sim"], runs["direct"]["f_sim"], rtol=1e-5, atol=1e-12)
