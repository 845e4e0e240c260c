"""The reduced model: f_sim replaced by the theory force f_thr everywhere.

Far from the wall f_thr is the usual far-field drag, added mass and history
force, so this is the classical equation of a sphere in a quiescent liquid with
the paper's contact model at the wall.  Milliseconds to a second per scene.

It has no flow: its stepper (steppers.OdeStep, the registry's stepper = "ode")
lets the shared integrator take the whole run with its adaptive steps, and the
run's observers see each of them.
"""
from __future__ import annotations

from ..flow_model import FlowModel
from ..scene import SceneError


class OdeModel(FlowModel):
    name = "ode"
    resolved = False

    def __init__(self, scene, comm):
        super().__init__(scene, comm)
        if scene.numerics.ode.flow_force != "linear":
            raise SceneError(f'numerics.ode.flow_force = "{scene.numerics.ode.flow_force}" is read nowhere by the ode '
                             "model: it says how the integrator takes a resolved flow's force through a fluid step "
                             "(fd, ib, ale, fd3d), and the ode model has no flow: unset it")

    def build(self, integrator) -> None:
        self.unknowns = integrator.n

    def sizes(self) -> dict:
        return {"unknowns": self.unknowns}
