"""The boundary-fitted ALE model (`--model ale`): each sphere a hole in the mesh with a no-slip surface moving
with it (flow.SphereFlow), on the mesh that follows the spheres (models/moving_mesh.py: the step, the holds near
contact, the remeshing and the transfer of the flow's history, the checkpoints), which the fd model's moving mesh
shares (models/fd/moving.py).

The N spheres on the axis (bodies.scene_bodies, sphere 1 the lowest) are holes in one mesh, each
with its own mesh extension and unit flow response (fem.mesh_motion, flow.py); every per-sphere value is
an array over them, the added mass an N x N matrix.  The flow's step assembles the step's matrix on the moved
mesh; N + 1 solves give the flow for the reference velocities U_ref and the response to a unit velocity of each
sphere (numerics.ale.factorisation: "every-step" factorises the matrix every step; "reuse", the default, solves
by flexible GMRES preconditioned with the factors of an earlier step and factorises when that pays: flow.py);
the step's field is x_ref + sum_k (U_k - U_ref,k) x_unit,k.

Held spheres (every body held: motion.mode = "fixed", and fixed upper spheres) are solved for
their steady state directly: steady Navier-Stokes by Newton in a stream (Cd), steady Stokes when
only sphere 1's surface moves (the quasi-steady approach of Brenner's check, defined only at
Re -> 0).  numerics.ale.fixed_solver = "march" time-marches them instead.
"""
from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np

from ...fem.mesh_motion import MeshMotion
from ...fem.solver import SolverError
from ...kinematics import FluidForce, Prediction
from ...motion import is_stream
from ..moving_mesh import MovingMesh, MovingMeshModel, StepRecord, checked_domain, first_step, launched
from ..unread import refuse_unread
from .domain import is_steady, step_limits, time_step
from .flow import SphereFlow


def force_columns(count: int) -> tuple[str, ...]:
    """ale_forces.csv's header for `count` spheres, suffixed as the trajectory's columns (one sphere's
    plain; _1, _2, ... per sphere and _12, ... per matrix entry for more): sphere 1's mesh gap to z = 0,
    each neighbouring pair's mesh gap, each sphere's variational and surface force, the added-mass
    matrix row by row, the worst triangle and whether the step remeshed."""
    one = count == 1
    spheres = [""] if one else [f"_{k + 1}" for k in range(count)]
    entries = [""] if one else [f"_{i + 1}{j + 1}" for i in range(count) for j in range(count)]
    pairs = ["mesh_pair_gap"] if count == 2 else [f"mesh_pair_gap_{k + 1}{k + 2}" for k in range(count - 1)]
    return ("t", "mesh_gap", *pairs, *(f"f_variational{s}" for s in spheres), *(f"f_surface{s}" for s in spheres),
            *(f"added_mass{e}" for e in entries), "min_quality", "remeshed")


class AleModel(MovingMeshModel):
    name = "ale"
    resolved = True
    divergences = (SolverError,)
    fields_at_end = True

    def __init__(self, scene, comm):
        super().__init__(scene, comm)
        refuse_unread(scene, self.name)  # settings this scene's run reads nowhere (models/unread.py)
        self.steady = is_steady(scene)
        self.launched = launched(scene)
        cfl_step, limits, adaptive = time_step(scene), step_limits(scene), self.settings.adaptive_step
        self.moving = MovingMesh(scene, comm, self.settings, checked_domain(scene, self.name), self.make_flow,
                                 self.sphere_volume, cfl_step=cfl_step, step_limits=limits, adaptive=adaptive,
                                 reuse=self.reuses_factors, first_step=first_step(scene, cfl_step, limits, adaptive))
        self._forces = None  # rank 0's writer of ale_forces.csv (run.py owns it: a side file)

    @property
    def reuses_factors(self) -> bool:
        """The step's matrix is solved with an earlier step's factors (numerics.ale.factorisation = "reuse")."""
        return self.settings.factorisation == "reuse"

    def make_flow(self, mesh, facet_tags, motion: MeshMotion, centers: np.ndarray, dt: float) -> SphereFlow:
        """The flow on a new mesh around the spheres centred at `centers` [m]: no-slip on their surfaces."""
        scene, domain, ale = self.scene, self.moving.domain, self.settings
        return SphereFlow(mesh, facet_tags, domain.sides, scene.liquid.density, scene.liquid.viscosity, dt,
                          motion.velocity, inflow_speed=domain.inflow_speed, order=ale.time_order,
                          sphere_tags=self.moving.sphere_tags, factorisation=ale.factorisation,
                          reuse_iterations=ale.reuse_iterations, krylov_rtol=ale.krylov_rtol,
                          factorisation_cost=ale.factorisation_cost)

    def sphere_volume(self, flow: SphereFlow) -> float:
        """The volume of the mesh's polygonal sphere: the domain's cylinder less the liquid [m^3]."""
        domain = self.moving.domain
        return math.pi * domain.radius**2 * domain.height - flow.fluid_volume()

    def linearised_force(self, prediction: Prediction) -> FluidForce:
        """The moving mesh's step, BDF1 over the first time_order steps of a sphere launched into liquid at rest:
        the liquid jumps to the surface's velocity in the first step, and BDF2 across that jump rings (the launch
        ends too fast: tests/test_ale.py)."""
        moving = self.moving
        return moving.linearise(prediction, cold_start=self.launched and moving.step < self.settings.time_order)

    def complete(self, velocities: np.ndarray, time_now: float) -> None:
        self._record_force(super().complete(velocities, time_now))

    def _record_force(self, record: StepRecord) -> None:
        surface = self.moving.flow.surface_force()  # collective: every rank, though rank 0 alone writes
        if self._forces is None:
            return
        values = [record.time, record.gap, *self.moving.mesh_pair_gaps(self.moving.history["centers"][0]),
                  *np.ravel(record.force), *np.ravel(surface), *np.ravel(record.added_mass), record.quality,
                  int(record.remeshed)]
        self._forces(dict(zip(self._forces.columns, values)))

    def steady_force(self) -> FluidForce:
        """The held spheres' steady state (SphereFlow.steady), held from the start to the end time: each
        surface at its body's velocity (motion.velocity, second_sphere.velocity)."""
        moving = self.moving
        start = time.perf_counter()
        surfaces = np.array([body.start_velocity for body in moving.bodies])
        force = moving.flow.steady(surfaces, convection=is_stream(self.scene))
        moving.stats.factorisation_s += time.perf_counter() - start
        moving.hold_steady(force)
        return FluidForce(*moving.last_force)

    def complete_steady(self, time_now: float) -> None:
        moving = self.moving
        moving.step = self.step = 1
        force, no_added_mass = moving.last_force
        self._record_force(StepRecord(time_now, moving.stats.min_mesh_gap, force, no_added_mass,
                                      moving.motion.quality(moving.motion.shift), False))

    # -- outputs ----------------------------------------------------------------------------------
    def side_files(self) -> dict[str, tuple]:
        return {"ale_forces.csv": force_columns(len(self.moving.bodies))}

    def open_outputs(self, out_dir: Path, restart: bool, fields: bool, sides: dict | None = None) -> None:
        super().open_outputs(out_dir, restart, fields, sides)
        self._forces = (sides or {}).get("ale_forces.csv")
