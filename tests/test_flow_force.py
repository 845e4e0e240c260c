"""A resolved flow's force through its fluid step (kinematics.FluidForce.ramp, numerics.ode.flow_force): the
explicit part runs linearly from the step before's value to the step's own, and the integrator takes its
trapezoid, not the end's value held (the rectangle rule, first order in the step)."""
from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI  # noqa: F401  (loads MPI before PETSc)

from fem_bounce import scene as scenes
from fem_bounce.integrator import BodyIntegrator
from fem_bounce.kinematics import FluidForce, PlaneForce

MASS = np.array([[2.0e-3]])  # an added mass [kg]


def test_the_ramp_runs_from_the_step_befores_force_to_the_steps_own():
    before = FluidForce(np.array([1.0]), MASS, PlaneForce(np.array([2.0, 4.0]), np.zeros((3, 3))))
    step = FluidForce(np.array([3.0]), MASS, PlaneForce(np.array([0.0, 8.0]), np.zeros((3, 3))))
    ramped = step.ramped(before, 1.0, 2.0)
    for t, normal, plane in ((1.0, 1.0, (2.0, 4.0)), (1.25, 1.5, (1.5, 5.0)), (2.0, 3.0, (0.0, 8.0)),
                             (0.5, 1.0, (2.0, 4.0)), (2.5, 3.0, (0.0, 8.0))):  # held at its ends outside the step
        now = ramped.at(t)
        assert now.explicit == pytest.approx([normal], rel=1e-12)
        assert now.plane.explicit == pytest.approx(plane, rel=1e-12)
        assert now.added_mass is step.added_mass
    assert step.at(1.5) is step  # no ramp: the end's value
    other = FluidForce(np.array([1.0, 2.0]), np.zeros((2, 2)))
    assert step.ramped(other, 1.0, 2.0) is step  # the step before had other bodies: no ramp


@pytest.mark.parametrize("rule", ["linear", "end"])
def test_the_integrator_takes_the_trapezoid_of_the_ramped_force(rule):
    """Case 3's sphere far from the wall without gravity feels only the flow's force: over a step with the
    explicit part from F0 to F1 and the added mass M, (m + M) dV = (F0 + F1) dt / 2 (linear) or F1 dt (end)."""
    integrator = BodyIntegrator(scenes.load("li2011-case3", {"gravity": 0.0, "initial_gap": 0.02,
                                                              "initial_velocity": -0.3}), resolved=True)
    try:
        start, dt, forces = 0.0, 1e-3, (1.0e-2, 3.0e-2)
        step = FluidForce(np.array([forces[1]]), MASS)
        if rule == "linear":
            step = step.ramped(FluidForce(np.array([forces[0]]), MASS), start, start + dt)
        integrator.advance(start + dt, step)
        mean = 0.5 * sum(forces) if rule == "linear" else forces[1]
        expected = -0.3 + mean * dt / (integrator.bodies[0].mass + MASS[0, 0])
        assert integrator.velocities[0] == pytest.approx(expected, abs=1e-6)  # the rules differ by 1.8e-3 m/s
    finally:
        integrator.destroy()
