"""The rigid-body constraint by a Lagrange multiplier, and the field-split flow solver, at toy size."""
import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI

from fem_bounce import output, scene
from fem_bounce.models.fd.domain import time_step
from fem_bounce.models.fd.model import FictitiousDomainModel
from fem_bounce.run import simulate
from fem_bounce.sphere import SphereIntegrator

TINY = {"numerics.fd.cells_per_diameter": 6, "run.end_time": 0.01}


@pytest.fixture(scope="module")
def multiplier_model():
    sc = scene.load("li2011-case3", {"numerics.fd.cells_per_diameter": 8, "numerics.fd.constraint": "multiplier"})
    fd = FictitiousDomainModel(sc, MPI.COMM_WORLD)
    fd.build(SphereIntegrator(sc, resolved=True))
    yield fd
    fd.destroy()


@pytest.mark.mpi
@pytest.mark.slow
def test_the_multiplier_holds_the_interior_rigid(multiplier_model):
    """From a fluid at rest, lambda for U = 0.1 m/s makes u = u~ - A^-1 Phi lambda move with the sphere
    where phi = 1: solved to a tight tolerance, the largest slip left (on the axis, whose rows the r
    weighting makes weak) is under 10 % of U and shrinks with the tolerance."""
    model = multiplier_model
    constraint, band, flow = model.constraint, model.sphere.band, model.flow
    speed = 0.1
    depth = band.radius - band.width
    slips = []
    for tolerance in (1e-2, 1e-4):
        # CG from a cold start needs ~1500 iterations at 1e-4 (serial, measured); 2000 left too little room on
        # 2 ranks, whose round-off differs (one failure in four MPI passes): the cap leaves room, the tolerance stays
        constraint.tolerance, constraint.max_iterations = tolerance, 5000
        constraint.multiplier.x.array[:] = 0.0
        constraint.response.x.array[:] = 0.0
        predicted = fem.Function(flow.W)  # u~ = 0: the fluid at rest
        constraint.solve(predicted, speed, responses_ready=True)
        assert constraint.unconverged == 0
        velocity = fem.Function(flow.W)
        velocity.x.array[:] = -constraint.response.x.array
        slips.append(constraint.interior_slip(velocity, speed, depth))
    assert slips[1] < 0.1 * speed
    assert slips[1] < slips[0]
    # the fluid is pushed along the sphere's motion: the hold force opposes it
    assert constraint.hold_force() < 0.0


def test_the_multiplier_removes_the_viscous_step_bound():
    """In 95 % glycerol the penalty's bound 0.025 h^2 / nu sets dt; the multiplier leaves the convective one."""
    changes = {"numerics.fd.cells_per_diameter": 12}
    penalty = scene.load("li2011-table3-steel-95", changes)
    multiplier = scene.load("li2011-table3-steel-95", {**changes, "numerics.fd.constraint": "multiplier"})
    fine = penalty.sphere.diameter / 12
    assert time_step(penalty) == pytest.approx(0.025 * fine**2 / penalty.liquid.kinematic_viscosity)
    assert time_step(multiplier) > 5.0 * time_step(penalty)


def test_a_multiplier_run_completes_and_reports_its_cost(tmp_path):
    sc = scene.load("li2011-case3", {**TINY, "numerics.fd.constraint": "multiplier"})
    summary = simulate(sc, "fd", MPI.COMM_WORLD, tmp_path, force=True, progress=False, plots=False)
    assert summary["status"] == "completed"
    report = summary["fd"]
    assert report["constraint"] == "multiplier"
    assert report["back_solves_per_step"] >= 2.0
    assert report["interior_slip_m_s"] < 0.1 * abs(output.read_trajectory(tmp_path)["velocity"][-1])


def test_the_field_split_solver_gives_the_direct_solution(tmp_path):
    """GMRES with the Schur field split and BoomerAMG reproduces the MUMPS trajectory to its tolerance."""
    runs = {}
    for solver in ("direct", "fieldsplit"):
        sc = scene.load("li2011-case3", {**TINY, "run.end_time": 0.003, "numerics.fd.solver": solver})
        simulate(sc, "fd", MPI.COMM_WORLD, tmp_path / solver, force=True, progress=False, plots=False)
        runs[solver] = output.read_trajectory(tmp_path / solver)
    assert np.allclose(runs["fieldsplit"]["velocity"], runs["direct"]["velocity"], rtol=1e-6, atol=1e-12)
    assert np.allclose(runs["fieldsplit"]["f_sim"], runs["direct"]["f_sim"], rtol=1e-5, atol=1e-12)
