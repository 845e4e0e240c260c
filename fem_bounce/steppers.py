"""How time advances in a run: one small interface, one kind per way a model steps.

    stepper = stepper_for(info, flow_model, integrator)    # after flow_model.build(integrator)
    stepper.run(end_time, after_step)                       # after_step(): the controller's observers

- CoupledStep (the registry's stepper = "coupled": fd, ib, ale): the resolved flow and the bodies, one
  fluid step at a time.  The bodies' motion over the step is predicted (AB2, flow_model.Predictor), the
  flow advanced to it hands over its force linearised in the accelerations, the integrator sub-cycles
  to the step's end, and the flow is completed for the velocities the bodies reached.
- OdeStep ("ode"): no flow; the integrator takes the whole run with its adaptive steps, each an
  observed step.
- SteadyStep (a model whose scene holds the bodies at a steady state, FlowModel.steady): the steady
  flow solved once; the integrator holds its force to the end.

A stepper owns only how time advances; the controller (fem_bounce.run) owns the observers, their
cadences, the stop requests, the checkpoints and the run's status.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from .flow_model import FlowModel, Predictor
from .integrator import BodyIntegrator
from .kinematics import FluidForce, PlaneForce


class Stepper:
    """Advances a built flow model and the bodies' integrator to the end time."""

    def __init__(self, flow_model: FlowModel, integrator: BodyIntegrator):
        self.flow_model, self.integrator = flow_model, integrator

    def run(self, end_time: float, after_step: Callable[[], None]) -> None:
        """Advance to end_time [s] (or until the integrator is done), calling after_step() after each step."""
        raise NotImplementedError

    @property
    def steps(self) -> int:
        """The steps taken, as the summary counts them."""
        return self.flow_model.step

    def state(self) -> dict:
        """What a checkpoint needs to continue this stepper exactly (JSON-able)."""
        return {}

    def restore(self, state: dict) -> None:
        """Continue from a checkpoint's state."""


class CoupledStep(Stepper):
    """One fluid step of the flow and the bodies at a time (module docstring)."""

    def __init__(self, flow_model: FlowModel, integrator: BodyIntegrator):
        super().__init__(flow_model, integrator)
        self.predictor = Predictor(flow_model.initial_velocities())
        self.linear = flow_model.scene.numerics.ode.flow_force == "linear"
        self.before: FluidForce | None = None  # the step before's force (its explicit part at this step's start)

    def run(self, end_time: float, after_step: Callable[[], None]) -> None:
        while not self.flow_model.finished(end_time) and not self.integrator.done:
            self.step()
            after_step()

    def step(self) -> None:
        """One step of the flow and the bodies."""
        flow_model, integrator = self.flow_model, self.integrator
        flow_model.start_step(integrator.gaps, integrator.velocities)
        prediction = self.predictor.predict(integrator.time, integrator.gaps, integrator.velocities,
                                            flow_model.time_step(), flow_model.previous_time_step())
        fluid = flow_model.linearised_force(prediction)
        if self.linear and self.before is not None:
            fluid = fluid.ramped(self.before, integrator.time, flow_model.next_time())
        contacts = self._contacts()
        integrator.advance(flow_model.next_time(), fluid)
        flow_model.complete(integrator.velocities, integrator.time)
        self.predictor.push(integrator.velocities)
        # after a step with a contact in it the step's explicit force is the flow's before the reversal (the reversal is
        # in the added mass's part): the next step holds its own (validation.md section 12, "The flow's force through a
        # step")
        touched = contacts != self._contacts() or any(engaged for engaged, _ in contacts)
        self.before = None if touched else fluid

    def _contacts(self) -> tuple:
        """Each contact's state: whether it is engaged, and the impacts it has made."""
        return tuple((c.record.in_contact, len(c.record.impacts)) for c in self.integrator.contacts)

    def state(self) -> dict:
        """The predictor's velocities, newest first, one list over the bodies each [m/s], and the last step's
        explicit force [N] (and its plane's [N, N m]), where the coming step's ramp starts."""
        before = self.before
        return {"velocities": [v.tolist() for v in self.predictor.velocities],
                "flow_force": None if before is None else np.asarray(before.explicit).tolist(),
                "plane_force": None if before is None or before.plane is None else before.plane.explicit.tolist()}

    def restore(self, state: dict) -> None:
        self.predictor = Predictor(state["velocities"])
        explicit = state.get("flow_force")  # (none in a checkpoint from before 2026-12-08: the next step holds)
        if explicit is not None:
            count = len(explicit)
            plane = state.get("plane_force")
            self.before = FluidForce(np.array(explicit, dtype=float), np.zeros((count, count)),
                                     None if plane is None else PlaneForce(np.array(plane, dtype=float),
                                                                           np.zeros((3, 3))))


class OdeStep(Stepper):
    """The integrator alone, with its adaptive steps (module docstring)."""

    def run(self, end_time: float, after_step: Callable[[], None]) -> None:
        self.integrator.observers.append(lambda row: after_step())
        self.integrator.advance(end_time)

    @property
    def steps(self) -> int:
        return self.integrator.steps


class SteadyStep(Stepper):
    """The held bodies' steady flow, solved once and held to the end (module docstring)."""

    def run(self, end_time: float, after_step: Callable[[], None]) -> None:
        force = self.flow_model.steady_force()
        self.integrator.advance(self.flow_model.steady_end_time(end_time), force)
        self.flow_model.complete_steady(self.integrator.time)


STEPPERS: dict[str, type[Stepper]] = {"coupled": CoupledStep, "ode": OdeStep, "steady": SteadyStep}


def stepper_for(info, flow_model: FlowModel, integrator: BodyIntegrator) -> Stepper:
    """The stepper the registry names for the model (`info`, a models.registry.ModelInfo), or the steady
    one when the scene holds the bodies at a steady state; the flow model is built."""
    return STEPPERS["steady" if flow_model.steady else info.stepper](flow_model, integrator)
