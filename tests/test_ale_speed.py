"""The ale model at the speed of the hardware (issue 24): forms compiled once, the reused factorisation
(numerics.ale.factorisation = "reuse") against the every-step path, and the Krylov solver behind it."""
import numpy as np
import pytest
from mpi4py import MPI
from petsc4py import PETSc

import ffcx.codegeneration.jit as ffcx_jit
from fem_bounce import scene as scenes
from fem_bounce.fem import solver
from fem_bounce.run import simulate
from helpers import ALE_PLAIN

# case 3 at 6 cells/D to the apex after the first bounce, the surface unrefined and fixed steps: a few seconds, a
# remesh, held steps
TOY = {"numerics.ale.cells_per_diameter": 6, **ALE_PLAIN, "run.bounces": 1}


def _run(changes: dict, out=None) -> dict:
    return simulate(scenes.load("li2011-case3", {**TOY, **changes}), "ale", MPI.COMM_WORLD, out, force=True,
                    progress=False, plots=False)


@pytest.fixture
def compilations(monkeypatch):
    """Counts the form compiler's compilations (a form found in the cache is not compiled)."""
    calls = []
    original = ffcx_jit._compile_objects

    def counting(*args, **kwargs):
        calls.append(args[3] if len(args) > 3 else kwargs.get("module_name"))
        return original(*args, **kwargs)

    monkeypatch.setattr(ffcx_jit, "_compile_objects", counting)
    return calls


def test_a_second_run_with_other_numbers_compiles_no_form(compilations):
    """Density, viscosity, the step and the mesh enter the forms as Constants: a run after a first one
    (that may fill the cache) with other values of all of them, remeshing, compiles nothing."""
    _run({"numerics.ale.factorisation": "reuse"})
    before = len(compilations)
    summary = _run({"numerics.ale.factorisation": "reuse", "liquid.density": 1100.0, "liquid.viscosity": 0.06,
                    "numerics.ale.cfl": 0.45, "numerics.ale.surface_refinement": 2})
    assert summary["ale"]["remesh_count"] >= 1
    assert compilations[before:] == []


def test_reuse_gives_the_every_step_answer_and_factorises_on_each_new_mesh(monkeypatch):
    """"reuse" solves the same equations as "every-step" by FGMRES to |b - A x| <= 1e-7 |b_free|: at 6 cells/D the
    impact speed and the restitution agree to 1e-4 (measured 5e-6 and 3e-6 at 8 cells/D,
    benchmarks/ale_speed.py; a scheme change, e.g. extrapolated convection, moves them by 2e-4 to 7e-4).
    The step matrix is factorised at the first step on every new mesh and far less than once a step."""
    factorised_at = []
    original = solver.ReusedFactorOperator._factorise

    def recording(self, setup):
        factorised_at.append(model_steps[-1] if model_steps else 0)
        return original(self, setup)

    model_steps = []
    from fem_bounce.models.ale.model import AleModel
    step = AleModel.linearised_force

    def counting_step(self, prediction):
        model_steps.append(self.moving.step)
        return step(self, prediction)

    monkeypatch.setattr(solver.ReusedFactorOperator, "_factorise", recording)
    monkeypatch.setattr(AleModel, "linearised_force", counting_step)
    every = _run({"numerics.ale.factorisation": "every-step"})
    reuse = _run({"numerics.ale.factorisation": "reuse"})
    assert reuse["impacts"][0]["impact_speed"] == pytest.approx(every["impacts"][0]["impact_speed"], rel=1e-4)
    assert reuse["rebounds"][0]["restitution"] == pytest.approx(every["rebounds"][0]["restitution"], rel=1e-4)
    report = reuse["ale"]
    assert report["factorisations"] < 0.25 * reuse["steps"] and report["krylov_iterations"] > 0
    assert report["remesh_count"] >= 1
    for remesh in report["remeshes"]:  # the step after a remesh factorises the new mesh's matrix
        assert remesh["step"] in factorised_at
    assert every["ale"]["factorisations"] == every["steps"]


def _laplacian(n: int, shift: float) -> PETSc.Mat:
    A = PETSc.Mat().createAIJ((n, n), nnz=3, comm=MPI.COMM_SELF)
    for i in range(n):
        A.setValue(i, i, 2.0 + shift)
        if i > 0:
            A.setValue(i, i - 1, -1.0)
        if i < n - 1:
            A.setValue(i, i + 1, -1.0)
    A.assemble()
    return A


def test_reused_factors_solve_a_changed_matrix_to_the_tolerance_and_mark_themselves_stale():
    n = 200
    A = _laplacian(n, 0.1)
    operator = solver.ReusedFactorOperator(A, "test_reuse_", rtol=1e-10, max_iterations=3, factorisation_cost=2.0)
    try:
        b, x = A.createVecs()
        b.setArray(np.sin(np.arange(n)))
        x.set(0.0)
        operator.solve(b, x)
        assert operator.last_iterations <= 1 and not operator.stale  # fresh factors: exact in one iteration
        changed = _laplacian(n, 0.2)  # the matrix changes in place, same pattern; the factors stay
        changed.copy(A, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        x.set(0.0)
        operator.solve(b, x)
        residual = b.duplicate()
        A.mult(x, residual)
        residual.aypx(-1.0, b)
        assert residual.norm() <= 1e-10 * b.norm() * (1 + 1e-6)
        assert operator.last_iterations > 3 and operator.stale and operator.factorisations == 1
        operator.refactor()
        x.set(0.0)
        operator.solve(b, x)
        assert operator.factorisations == 2 and not operator.stale and operator.last_iterations <= 1
        # the renewal rule: a step's iterations above (cost + all since the factorisation) / steps
        operator.end_step()
        assert not operator.stale  # 1 iteration against (2 + 1) / 1
        operator._step_iterations = 5
        operator.end_step()
        assert operator.stale  # 5 against (2 + 1 + 5) / 2
    finally:
        operator.destroy()
        A.destroy()


@pytest.mark.parametrize("key,value,message", [
    ("numerics.ale.factorisation", "sometimes",
     "numerics.ale.factorisation = 'sometimes' is not one of 'reuse', 'every-step'"),
    ("numerics.ale.krylov_rtol", 0.5, "numerics.ale.krylov_rtol = 0.5 is out of range: allowed in [1e-14, 0.001]"),
    ("numerics.ale.factorisation_cost", -1.0, "numerics.ale.factorisation_cost = -1.0 is out of range"),
    ("numerics.ale.reuse_iterations", 0, "numerics.ale.reuse_iterations = 0 is out of range"),
])
def test_bad_solver_settings_name_the_field(key, value, message):
    with pytest.raises(scenes.SceneError) as err:
        scenes.load("li2011-case3", {key: value})
    assert message in str(err.value) and "\n" not in str(err.value)


def test_the_tolerance_ignores_the_dirichlet_rows():
    """Row 0 an identity row holding 1e6 (as a Dirichlet row holds a velocity), the other rows of order 1e-6
    (as finite-element rows carry cell areas): the residual of the other rows must fall to rtol times their
    own size, which a tolerance on the whole |b| (1e-8 * 1e6) would never ask."""
    n = 50
    A = _laplacian(n, 0.1)
    A.zeroRowsColumns([0], diag=1.0)
    operator = solver.ReusedFactorOperator(A, "test_reuse_fixed_", rtol=1e-8, fixed_rows=[0])
    try:
        changed = A.duplicate(copy=True)
        changed.shift(0.05)  # the factors are now stale
        changed.zeroRowsColumns([0], diag=1.0)
        changed.copy(A, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        b, x = A.createVecs()
        b.setArray(np.r_[1e6, 1e-6 * np.cos(np.arange(n - 1))])
        x.set(0.0)
        operator.solve(b, x)  # fresh factors: one iteration from 0
        operator.end_step()
        x.set(0.0)
        x.setValue(0, 1e6)  # a guess meeting the Dirichlet value
        operator.solve(b, x)
        residual = b.duplicate()
        A.mult(x, residual)
        residual.aypx(-1.0, b)
        assert operator.last_iterations >= 2
        assert np.linalg.norm(residual.array[1:]) <= 1e-8 * np.linalg.norm(b.array[1:]) * (1 + 1e-6)
        changed.destroy()
    finally:
        operator.destroy()
        A.destroy()


# -- the adaptive step (numerics.ale.adaptive_step) -----------------------------------------------------
@pytest.mark.parametrize("ratio", [0.25, 1.0, 2.0])
def test_variable_step_bdf2_is_exact_for_a_quadratic_and_its_extrapolation_for_a_line(ratio):
    from fem_bounce.fem.taylor_hood import step_coefficients

    dt, before = 0.3, 0.3 / ratio  # the coming step and the one before it
    times = np.array([dt, 0.0, -before])  # t_{n+1}, t_n, t_{n-1}
    bdf, ext = step_coefficients(2, ratio)
    assert np.dot(bdf, times**2) / dt == pytest.approx(2.0 * dt, rel=1e-12)  # d(t^2)/dt at t_{n+1}
    assert np.dot(bdf, np.ones(3)) == pytest.approx(0.0, abs=1e-12)
    assert np.dot(ext, times[1:]) == pytest.approx(dt, rel=1e-12)  # the line t at t_{n+1}


@pytest.mark.parametrize("ratio", [0.25, 2.0])
def test_the_prediction_over_an_unequal_step_is_exact_for_a_constant_acceleration(ratio):
    from fem_bounce.flow_model import Predictor

    acceleration, dt = -9.0, 1e-3  # V = V_0 + a t: the mean over [t_n, t_n + dt] is V_n + a dt / 2
    before = dt / ratio
    predictor = Predictor([np.array([0.3 + acceleration * before]), np.array([0.3])])  # V_n, V_{n-1}
    prediction = predictor.predict(0.0, np.array([0.01]), np.array([0.3 + acceleration * before]), dt, before)
    assert prediction.mean_velocities[0] == pytest.approx(0.3 + acceleration * (before + 0.5 * dt), rel=1e-12)


def test_the_adaptive_step_stays_within_its_bounds_and_shortens_near_the_wall():
    from fem_bounce.flow_model import GROWTH
    from fem_bounce.models.ale.domain import step_limits, time_step

    scene = scenes.load("li2011-case3", {"numerics.ale.min_step_factor": 0.125, "numerics.ale.max_step_factor": 4.0})
    base, limits = time_step(scene), step_limits(scene)
    far = limits.next(base, gap=0.1, speed=0.01, jerk=0.0)  # slow, far away: grows by GROWTH
    assert far == pytest.approx(GROWTH * base, rel=1e-12)
    assert limits.next(10 * base, gap=0.1, speed=0.01, jerk=0.0) == pytest.approx(4.0 * base)
    near = limits.next(base, gap=1e-6, speed=0.4, jerk=0.0)  # about to touch: the shortest
    assert near == pytest.approx(0.125 * base, rel=1e-12)
    assert limits.next(base, gap=0.1, speed=0.01, jerk=1e9) == pytest.approx(0.125 * base)


def test_an_adaptive_step_held_at_the_cfl_step_is_the_constant_step():
    """With min_step_factor = max_step_factor = 1 the adaptive path takes the cfl step every time: the
    variable-step coefficients and the re-centred prediction reduce to the constant ones (to round-off in
    the step ratio, through the reused factors' 1e-7 tolerance).  On the fall, before the wall is near: there
    every adaptive step is bounded by the gap it may close whatever its floor (flow_model.Approach, at ale's
    gap fraction), and the fixed ones only by half the contact's gap (flow_model.safe_fixed_step)."""
    fall = {"run.end_time": 0.04}
    constant = _run(fall)
    held = _run({**fall, "numerics.ale.adaptive_step": True, "numerics.ale.min_step_factor": 1.0,
                 "numerics.ale.max_step_factor": 1.0})
    assert held["steps"] == constant["steps"] > 10
    assert held["final"]["velocity"] == pytest.approx(constant["final"]["velocity"], rel=1e-5)
    assert held["final"]["gap"] == pytest.approx(constant["final"]["gap"], rel=1e-5)
