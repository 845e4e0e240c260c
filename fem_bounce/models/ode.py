"""The reduced model: f_sim replaced by the theory force f_thr everywhere.

Far from the wall f_thr is the usual far-field drag, added mass and history
force, so this is the classical equation of a sphere in a quiescent liquid with
the paper's contact model at the wall.  Milliseconds to a second per scene.

As a FlowModel it has no flow: its one step is the whole run, which the shared
integrator takes with adaptive steps; the run's observers see each of them.
"""
from __future__ import annotations

from ..flow_model import FlowModel


class OdeModel(FlowModel):
    name = "ode"
    resolved = False
    observe_integrator_steps = True

    def build(self, integrator) -> None:
        self.unknowns = integrator.n

    def time_step(self) -> float:
        return self.scene.run.end_time

    def next_time(self) -> float:
        return self.scene.run.end_time

    def finished(self, end_time: float) -> bool:
        return self.step >= 1

    def linearised_force(self, prediction):
        return None

    def complete(self, velocities, time: float) -> None:
        self.step += 1

    def sizes(self) -> dict:
        return {"unknowns": self.unknowns}
