"""The rigid-body constraint solved for its force density (the implicit Brinkman penalty), and the
field-split flow solver, at toy size."""
import numpy as np
import pytest
from dolfinx import fem
from mpi4py import MPI

from fem_bounce import output, scene
from fem_bounce.models.fd.domain import brinkman_rate, time_step
from fem_bounce.models.fd.model import FictitiousDomainModel
from fem_bounce.run import simulate
from fem_bounce.integrator import BodyIntegrator

TINY = {"numerics.fd.cells_per_diameter": 6, "run.end_time": 0.01}


def brinkman_model(strength: float):
    sc = scene.load("li2011-case3", {"numerics.fd.cells_per_diameter": 8, "numerics.fd.constraint": "brinkman",
                                     "numerics.fd.penalty_strength": strength})
    fd = FictitiousDomainModel(sc, MPI.COMM_WORLD)
    fd.build(BodyIntegrator(sc, resolved=True))
    return fd


@pytest.mark.mpi
def test_the_brinkman_penalty_obeys_its_law_in_few_iterations_and_stiffens_with_its_strength():
    """From a fluid at rest, lambda for U = 0.1 m/s: CG in the Phi inner product reaches 1e-8 in tens of
    iterations (the exact multiplier by Euclidean CG needed thousands), the interior's momentum is
    U V_phi + eps I(lambda) (the penalty law integrated over the band), and ten times the strength leaves
    several times less slip."""
    speed, slips = 0.1, []
    for strength in (100.0, 1000.0):
        model = brinkman_model(strength)
        try:
            constraint, sphere, flow = model.constraint, model.immersed.spheres[0], model.flow
            constraint.tolerance, constraint.max_iterations = 1e-8, 500
            constraint.solve(fem.Function(flow.W), speed, responses_ready=True)  # u~ = 0: the fluid at rest
            assert constraint.unconverged == 0
            assert constraint.iterations - constraint.unit_iterations < 60 * (strength / 100.0) ** 0.5
            velocity = fem.Function(flow.W)
            velocity.x.array[:] = -constraint.response.x.array
            momentum = speed * sphere.volume + constraint.regularisation * constraint.hold_force()
            assert sphere.interior(velocity.x.petsc_vec) == pytest.approx(momentum, rel=1e-6)
            assert constraint.hold_force() < 0.0  # the fluid is pushed along: the hold force opposes it
            band = sphere.band
            slips.append(constraint.interior_slip(velocity, speed, band.radius - band.width))
        finally:
            model.destroy()
    assert slips[1] < 0.3 * slips[0]


def test_the_brinkman_constraint_removes_the_viscous_step_bound():
    """In 95 % glycerol the penalty's bound 0.025 h^2 / nu sets dt; brinkman leaves the convective one,
    and its rate does not depend on dt."""
    constraint = "brinkman"
    changes = {"numerics.fd.cells_per_diameter": 12}
    penalty = scene.load("li2011-table3-steel-95", changes)
    solved = scene.load("li2011-table3-steel-95", {**changes, "numerics.fd.constraint": constraint})
    fine = penalty.sphere.diameter / 12
    assert time_step(penalty) == pytest.approx(0.025 * fine**2 / penalty.liquid.kinematic_viscosity)
    assert time_step(solved) > 5.0 * time_step(penalty)
    finer_step = scene.load("li2011-table3-steel-95", {**changes, "numerics.fd.constraint": constraint,
                                                      "numerics.fd.cfl": 0.05})
    assert time_step(finer_step) < time_step(solved)
    assert brinkman_rate(finer_step) == brinkman_rate(solved)


def test_a_brinkman_run_completes_and_reports_its_cost(tmp_path):
    constraint = "brinkman"
    sc = scene.load("li2011-case3", {**TINY, "numerics.fd.constraint": constraint})
    summary = simulate(sc, "fd", MPI.COMM_WORLD, tmp_path, force=True, progress=False, plots=False)
    assert summary["status"] == "completed"
    report = summary["fd"]
    assert report["constraint"] == constraint
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
