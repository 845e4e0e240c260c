"""The reduced model: f_sim replaced by the theory force f_thr everywhere.

Far from the wall f_thr is the usual far-field drag, added mass and history
force, so this is the classical equation of a sphere in a quiescent liquid with
the paper's contact model at the wall.  Milliseconds to a second per scene.
"""
from __future__ import annotations

import math


class OdeModel:
    name = "ode"
    resolved = False

    def __init__(self, scene, comm):
        self.scene = scene

    def resolved_top(self) -> float:
        """No mesh: nothing limits how high the sphere may go [m]."""
        return math.inf

    def run(self, integrator, progress, out_dir=None, restart=False) -> dict:
        end = self.scene.run.end_time
        integrator.observers.append(lambda row: progress(row["t"], integrator.steps, row["gap"], row["velocity"]))
        integrator.advance(end)
        return {"steps": integrator.steps, "sizes": {"unknowns": integrator.n}}
