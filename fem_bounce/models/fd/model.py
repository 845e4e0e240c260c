"""The fictitious-domain model (`--model fd`): one fluid step, as a FlowModel (fem_bounce.flow_model).

One fluid step of length dt (fluid.FlowSolver, immersed.ImmersedSphere, coupling), driven by the run
controller (fem_bounce.run.Controller), which owns the loop, the observers and the checkpoints:

1. place the indicator where the controller predicts the sphere's centre at t_{n+1} (AB2);
2. predictor A x~ = b(u^n, u^{n-1});
3. responses A y0 = rho c phi (-u~), A y1 = rho c phi e_z (y1 reused while the sphere is held);
4. the force on the sphere is affine in its new velocity U: hand F* and the numerical added
   mass m_a to the shared BodyIntegrator, which sub-cycles through the contact and blends
   f_sim with f_thr below delta_sl exactly as every model does;
5. read back U and set the step's field u = u~ + y0 + s(U) y1.

A pair of spheres on the axis (scene.pair, issue 14) goes through the same step with one indicator,
one amplitude and one unit response per sphere (pair.ImmersedPair): the velocities and forces are
arrays, the added mass the 2 x 2 matrix of coupling.linearise_pair; the penalty scheme only.

A checkpoint holds the flow's BDF history by dof coordinates (fem.functions), so a run checkpointed
on two ranks can restart on one.
"""
from __future__ import annotations

import math
import resource
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ...bodies import scene_bodies
from ...fem.functions import CheckpointMismatch, gather_history, scatter_history
from ...fem.mesh import create_mesh
from ...fem.solver import SolverError
from ...flow_model import FlowModel, Prediction, flow_gaps, steps_to
from ...motion import is_stream, start_velocities, start_velocity
from ...output import CheckpointError, segment_path
from ...scene import SceneError, pair_diameter
from ...integrator import FluidForce
from . import coupling
from .domain import Domain, brinkman_rate, domain_for, time_step
from .fields import FieldWriter
from .fluid import FlowSolver
from .immersed import ImmersedSphere
from .constraint import RigidConstraint
from .pair import ImmersedPair, check_hold
from .steady import SteadyBrinkmanStokes, SteadyStokes


@dataclass
class History:
    """The sphere's velocities [m/s] and interior integrals I = U V_phi [m^4/s] of the last steps,
    newest first (for a pair each entry an array, one value per sphere); `bdf` are the flow's BDF
    coefficients."""

    bdf: tuple
    velocities: list
    interiors: list

    def push(self, velocity: float, interior: float) -> None:
        self.velocities = [velocity] + self.velocities[:-1]
        self.interiors = [interior] + self.interiors[:-1]

    def _reference(self, values: list) -> float:
        return -sum(a * v for a, v in zip(self.bdf[1:], values)) / self.bdf[0]

    @property
    def velocity(self) -> float:
        return self.velocities[0]

    @property
    def reference_velocity(self) -> float:
        """U_ref: dV/dt ~ c (U - U_ref) [m/s]."""
        return self._reference(self.velocities)

    @property
    def momentum_history(self) -> float:
        """J: the BDF history of the interior integrals [m^4/s]."""
        return self._reference(self.interiors)


class FictitiousDomainModel(FlowModel):
    name = "fd"
    resolved = True
    divergences = (SolverError,)

    def __init__(self, scene, comm):
        super().__init__(scene, comm)
        self.domain: Domain = domain_for(scene)
        self.dt = time_step(scene)
        self.flow: FlowSolver | None = None
        self.sphere: ImmersedSphere | None = None
        self.constraint: RigidConstraint | None = None
        self.fields: FieldWriter | None = None
        self.timings = {"setup": 0.0, "steps": 0.0, "integrator": 0.0}
        self.steady_iterations: int | None = None
        self.last_force: coupling.Linearised | None = None
        self.steady = self.settings.steady_stokes
        if self.settings.steady_stokes and (scene.motion.mode != "fixed" or is_stream(scene)):
            raise SceneError("numerics.fd.steady_stokes = true needs motion.mode = \"fixed\" without a stream")
        self.pair: ImmersedPair | None = None
        if scene.pair:
            self._check_pair(scene)

    def _check_pair(self, scene) -> None:
        if self.settings.constraint != "penalty":
            raise SceneError(f"numerics.fd.constraint = \"{self.settings.constraint}\" holds one sphere only: "
                             "a pair needs \"penalty\"")
        if is_stream(scene):
            raise SceneError("a pair in a stream (motion.stream_velocity) is not modelled: give stream_velocity = 0")
        if self.steady and scene.second_sphere.mode != "fixed":
            raise SceneError("numerics.fd.steady_stokes = true with a pair needs second_sphere.mode = \"fixed\"")
        # which spheres the flow holds at their initial positions (their surfaces may still move)
        self.held = np.array([scene.motion.mode == "fixed", scene.second_sphere.mode == "fixed"])
        if not self.held.all():  # refused here, before the run writes anything
            min_gap = 2.0 * max(self.settings.radius_offset * self.domain.fine_size, 0.0)  # ImmersedPair.min_gap
            check_hold(min_gap, scene.contact.delta_sl * pair_diameter(scene.sphere, scene.second_sphere),
                       "the pair's hold gap of the contact model")

    # -- set-up ---------------------------------------------------------------------------
    def build(self, integrator) -> None:
        start = time.perf_counter()
        scene, domain, fd = self.scene, self.domain, self.settings
        self.hold_gaps = tuple(integrator.hold_gaps)  # (above the wall, each pair's) [m]
        mesh, _, facet_tags = create_mesh(self.comm, domain.spec)
        self.mesh = mesh
        self.flow = FlowSolver(mesh, facet_tags, domain.sides, scene.liquid.density, scene.liquid.viscosity, self.dt,
                               inflow_speed=domain.inflow_speed, order=fd.time_order, solver=fd.solver)
        self.flow.set_uniform((0.0, domain.inflow_speed))
        if scene.pair:
            self._build_pair()
            self.timings["setup"] = time.perf_counter() - start
            return
        radius = scene.sphere.radius + fd.radius_offset * domain.fine_size
        self.sphere = ImmersedSphere(self.flow, radius, fd.interface_width * domain.fine_size, domain.center)
        velocity = start_velocity(scene)
        if fd.constraint != "penalty":
            self.constraint = RigidConstraint(self.flow, self.sphere, self.regularisation(),
                                              fd.constraint_tolerance, fd.unit_steps)
        order = self.flow.order
        self.history = History(self.flow.bdf, [velocity] * order, [velocity * self.sphere.volume] * order)
        self.timings["setup"] = time.perf_counter() - start

    def regularisation(self) -> float:
        """eps = 1 / (rho c_B) of numerics.fd.constraint = "brinkman" [m^3 s/kg] (domain.brinkman_rate)."""
        return 1.0 / (self.scene.liquid.density * brinkman_rate(self.scene))

    def _build_pair(self) -> None:
        """Both spheres' indicators at their initial centres; the flow at rest (a projectile starts
        impulsively, as in the ale model), the history at the spheres' initial velocities."""
        scene, fd, fine = self.scene, self.settings, self.domain.fine_size
        radii = [sphere.radius for sphere in scene.spheres]
        self.pair = ImmersedPair(self.flow, [a + fd.radius_offset * fine for a in radii], radii,
                                 fd.interface_width * fine, [gap + a for gap, a in zip(scene.initial_gaps, radii)])
        velocity = np.array(start_velocities(scene))
        order = self.flow.order
        # the interiors' integrals are the flow's, at rest: a projectile's penalty force then sets its
        # interior liquid moving without taking that momentum from the sphere (a rigid sphere has none)
        self.history = History(self.flow.bdf, [velocity] * order, [np.zeros_like(velocity)] * order)

    def initial_velocities(self) -> list[np.ndarray]:
        return [np.atleast_1d(v) for v in self.history.velocities]

    # -- one step -------------------------------------------------------------------------
    def predicted_center(self, prediction: Prediction) -> float:
        """Where the flow's sphere will be at t_{n+1}; held spheres stay put, and a free sphere's flow
        stops at the contact model's hold gap (below it the contact model adds what it misses) [m]."""
        if self.scene.motion.mode == "fixed":
            return self.domain.center
        radius = self.scene.sphere.radius
        return radius + max(prediction.centers([radius])[0] - radius, self.hold_gaps[0], 0.0)

    def predicted_centers(self, prediction: Prediction) -> np.ndarray:
        """Where the flow's pair will be at t_{n+1} [m]: held spheres stay put, the others as predicted
        but no closer than the contact model's hold gaps (flow_model.flow_gaps); a sphere approaching a
        held one stops at the pair's hold gap below it."""
        scene, held = self.scene, self.held
        diameters = [sphere.diameter for sphere in scene.spheres]
        pair_hold = self.hold_gaps[1]
        gaps = np.array(prediction.gaps, dtype=float)
        gaps[held] = np.array(scene.initial_gaps)[held]
        if held[1] and not held[0]:
            gaps[0] = min(gaps[0], gaps[1] - diameters[0] - pair_hold)
        gaps = flow_gaps(gaps, diameters, self.hold_gaps)
        return gaps + np.array([sphere.radius for sphere in scene.spheres])

    def linearised_force(self, prediction: Prediction) -> FluidForce:
        if self.pair is not None:
            return self._linearised_pair_force(prediction)
        sphere = self.sphere
        t_next = (self.step + 1) * self.dt
        center = self.predicted_center(prediction)
        if center != sphere.center:
            sphere.place(center)
        linear = self._linearise_brinkman() if self.constraint is not None else self._linearise_penalty()
        if not all(math.isfinite(v) for v in (linear.explicit, linear.added_mass)):
            raise FloatingPointError(f"the fluid force became {linear.explicit} N at t = {t_next:.6g} s")
        self.last_force = linear
        self._integrator_start = time.perf_counter()
        added_mass = linear.added_mass if self.settings.coupling == "implicit" else 0.0
        return FluidForce(explicit=np.array([linear.explicit]), added_mass=np.array([[added_mass]]))

    def _linearised_pair_force(self, prediction: Prediction) -> FluidForce:
        """Both spheres: their forces and the 2 x 2 added mass (pair.ImmersedPair, coupling.linearise_pair)."""
        flow, pair, h = self.flow, self.pair, self.history
        pair.place(self.predicted_centers(prediction))
        predicted = flow.predicted
        vectors, functions = pair.stale_units()
        flow.solve([flow.predictor_rhs(), *vectors], [predicted, *functions])
        flow.solve([pair.forcing(predicted)], [pair.forced])
        self.integrals = integrals = pair.integrals(predicted)
        linear = coupling.linearise_pair(integrals, self.scene.liquid.density, flow.c, h.momentum_history,
                                         h.reference_velocity)
        if not (np.all(np.isfinite(linear.explicit)) and np.all(np.isfinite(linear.added_mass))):
            raise FloatingPointError(f"the fluid forces became {linear.explicit} N at "
                                     f"t = {(self.step + 1) * self.dt:.6g} s")
        self.last_force = linear
        self._integrator_start = time.perf_counter()
        added_mass = linear.added_mass if self.settings.coupling == "implicit" else np.zeros((2, 2))
        return FluidForce(explicit=linear.explicit, added_mass=added_mass)

    def _linearise_penalty(self) -> coupling.Linearised:
        """The penalty forcing rho c phi (U - u~) (the default scheme)."""
        flow, sphere, h = self.flow, self.sphere, self.history
        # predictor and (if the sphere moved) the unit response share one pass over the factors
        predicted = flow.predicted
        if sphere.unit_stale:
            flow.solve([flow.predictor_rhs(), sphere.unit_forcing()], [predicted, sphere.unit])
        else:
            flow.solve([flow.predictor_rhs()], [predicted])
        flow.solve([sphere.forcing(predicted)], [sphere.forced])
        self.integrals = integrals = sphere.integrals(predicted)
        return coupling.linearise(integrals, self.scene.liquid.density, flow.c, h.momentum_history,
                                  h.reference_velocity)

    def _linearise_brinkman(self) -> coupling.Linearised:
        """The implicit Brinkman penalty (constraint.RigidConstraint): the predictor and the response to the
        last force density share one pass over the factors, CG corrects it for the extrapolated
        velocity U_e, and lambda_1 carries the force's dependence on U."""
        flow, sphere, h, constraint = self.flow, self.sphere, self.history, self.constraint
        predicted = flow.predicted
        vectors, functions = constraint.first_pass()
        flow.solve([flow.predictor_rhs(), *vectors], [predicted, *functions])
        v = h.velocities
        self._extrapolated = extrapolated = 2.0 * v[0] - v[1] if len(v) > 1 else v[0]
        constraint.solve(predicted, extrapolated, responses_ready=True)
        rho, c = self.scene.liquid.density, flow.c
        volume = sphere.volume
        # F(U) = I(lambda) + rho d/dt int phi u (Uhlmann 2005) with the interior's momentum
        # int phi u = U V_phi + eps I(lambda) (the penalty law u = U + eps lambda integrated over the band):
        # F(U) = g I(lambda(U)) + rho c (U V_phi - J), g = 1 + rho c eps, lambda(U) = lambda(U_e) + (U - U_e) lambda_1
        reference, g = h.reference_velocity, 1.0 + rho * c * constraint.regularisation
        explicit = (g * (constraint.hold_force() + (reference - extrapolated) * constraint.unit_force())
                    + rho * c * (reference * volume - h.momentum_history))
        added_mass = -(g * constraint.unit_force() + rho * c * volume) / c
        return coupling.Linearised(explicit, added_mass, reference)

    def complete(self, velocities: np.ndarray, time_now: float) -> None:
        self.timings["integrator"] += time.perf_counter() - self._integrator_start
        flow, sphere = self.flow, self.sphere
        t_next = (self.step + 1) * self.dt
        velocity = np.array(velocities, dtype=float) if self.pair is not None else float(velocities[0])
        if self.pair is not None:
            new = self.pair.field(flow.predicted, coupling.rigid_amplitudes(self.integrals, velocity), flow.work)
            interior = velocity * self.integrals.volume
        elif self.constraint is not None:
            new = self.constraint.field(flow.predicted, velocity - self._extrapolated, flow.work)
            # the interior's momentum / rho, int phi u = U V_phi + eps I(lambda) (_linearise_brinkman)
            interior = velocity * sphere.volume + self.constraint.regularisation * self.constraint.hold_force()
        else:
            s = coupling.rigid_amplitude(self.integrals, velocity)
            new = flow.work
            flow.predicted.vector.copy(new)
            new.axpy(1.0, sphere.forced.vector)
            new.axpy(s, sphere.unit.vector)
            interior = velocity * self.integrals.volume
        if not math.isfinite(new.norm()):
            raise FloatingPointError(f"the flow field became non-finite at t = {t_next:.6g} s")
        flow.commit(new)
        self.history.push(velocity, interior)
        self.step += 1

    def steady_force(self) -> FluidForce:
        """The steady Stokes state of the step (steady.SteadyStokes), held from the start."""
        count = len(self.scene.spheres)
        return FluidForce(explicit=np.reshape(self.steady_forces(), count), added_mass=np.zeros((count, count)))

    def steady_end_time(self, end_time: float) -> float:
        """The end of the step that reaches end_time [s]."""
        return steps_to(end_time, self.dt) * self.dt

    def complete_steady(self, time_now: float) -> None:
        self.step = steps_to(self.scene.run.end_time, self.dt)

    def steady_velocities(self):
        """The held spheres' surface velocities [m/s]: motion.velocity, and for a held pair also
        second_sphere.velocity (its surface moving while held, as motion.mode = "fixed" holds sphere 1:
        the quasi-steady drag of a pair moving together or approaching, benchmarks/pair_stokes.py)."""
        if self.pair is None:
            return self.scene.motion.velocity
        return np.array([self.scene.motion.velocity, self.scene.second_sphere.velocity])

    def steady_forces(self):
        """The steady Stokes force on the held sphere [N] (an array, one per sphere, for a held pair); the
        flow's states are left at that steady state."""
        velocity = self.steady_velocities()
        if self.pair is not None:
            steady = SteadyStokes(self.flow, self.pair.spheres[0], spheres=self.pair.spheres)
            try:
                forces, integrals = steady.solve_pair(velocity)
            finally:
                steady.destroy()
            self.steady_iterations = steady.iterations
            self.integrals = integrals
            self.last_force = coupling.Linearised(forces, coupling.added_mass_matrix(integrals,
                                                  self.scene.liquid.density), velocity)
            return forces
        if self.constraint is not None:
            steady = SteadyBrinkmanStokes(self.flow, self.sphere, self.regularisation(), tolerance=1e-6)
        else:
            steady = SteadyStokes(self.flow, self.sphere)
        try:
            force, integrals = steady.solve(self.scene.motion.velocity)
        finally:
            steady.destroy()
        self.steady_iterations = steady.iterations
        added_mass = coupling.added_mass(integrals, self.scene.liquid.density) if self.constraint is None else 0.0
        self.last_force = coupling.Linearised(force, added_mass, self.scene.motion.velocity)
        return force

    def resolved_top(self) -> float:
        """The height [m] up to which the mesh is refined: a rising sphere is stopped there."""
        return self.domain.spec.refined[0].z_max

    # -- checkpoints and fields -------------------------------------------------------------
    def checkpoint_state(self) -> tuple[dict, dict]:
        """The BDF history of the flow (u, p at t_n, t_{n-1}, ...) by dof coordinates, gathered on rank 0,
        and of the sphere's velocities and interior integrals (for a pair, a list per sphere each)."""
        h = self.history
        if self.pair is not None:
            return ({"dt": self.dt, "velocities": [list(map(float, v)) for v in h.velocities],
                     "interiors": [list(map(float, i)) for i in h.interiors]}, gather_history(self.flow.states))
        return ({"dt": self.dt, "velocities": h.velocities, "interiors": h.interiors},
                gather_history(self.flow.states))

    def restore(self, state: dict, arrays) -> None:
        if not math.isclose(state["dt"], self.dt, rel_tol=1e-12):
            raise CheckpointError(f"the checkpoint was made with dt = {state['dt']:g} s, this scene gives "
                                  f"{self.dt:g} s: the scene was changed")
        try:
            scatter_history(self.flow.states, arrays, tolerance=1e-6 * self.domain.fine_size)
        except (ValueError, KeyError, CheckpointMismatch) as err:
            raise CheckpointError(f"the checkpoint does not fit this run's mesh: {err}") from None
        if self.pair is not None:
            if any(len(np.atleast_1d(v)) != 2 for v in state["velocities"]):
                raise CheckpointError("the checkpoint holds one sphere, this scene a pair: the scene was changed")
            self.history = History(self.flow.bdf, [np.array(v, dtype=float) for v in state["velocities"]],
                                   [np.array(i, dtype=float) for i in state["interiors"]])
            return
        self.history = History(self.flow.bdf, list(state["velocities"]), list(state["interiors"]))

    def open_outputs(self, out_dir: Path, restart: bool, fields: bool) -> None:
        if not fields:
            return
        path = self.comm.bcast(segment_path(out_dir) if self.comm.rank == 0 else None, root=0)
        self.fields = FieldWriter(self.comm, self.mesh, self.flow.W, path)

    def write_fields(self, time_now: float) -> None:
        self.fields.write(self.flow.now, self.step * self.dt)

    def close_outputs(self) -> None:
        if self.fields is not None:
            self.fields.close()

    # -- what the summary says ----------------------------------------------------------------
    def sizes(self) -> dict:
        cells = self.mesh.topology.index_map(2).size_global
        return {"cells": cells, "unknowns": self.flow.unknowns, "dt": self.dt, "fine_size": self.domain.fine_size}

    def report(self) -> dict:
        """Cost and discretisation details for summary.json."""
        self.timings["steps"] = self.loop_seconds
        steps = max(self.steps_this_run, 1)
        operator = self.flow.operator
        solves = operator.back_solves
        single = operator.single_solve_time / operator.single_solves if operator.single_solves else None
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0  # Linux reports kB
        return {
            "timings_s": self.timings,
            "time_per_step_s": self.timings["steps"] / steps,
            "back_solves": solves,
            "back_solves_per_step": solves / steps,
            "back_solve_s": single,
            "step_cost_in_back_solves": self.timings["steps"] / steps / single if single else None,
            "peak_memory_bytes": self.comm.allreduce(peak),  # sum over ranks of each rank's peak RSS
            "factorisation_memory_bytes": operator.factor_memory(),
            "solver": self.settings.solver,
            "krylov_iterations_per_solve": (operator.iterations / max(solves, 1) if hasattr(operator, "iterations")
                                            else None),
            "mesh_key": self.domain.spec.key(),
            **(self.pair_report() if self.pair is not None else {
                "added_mass_over_displaced": (self.last_force.added_mass / self.scene.displaced_mass
                                              if self.last_force is not None else None),
                "indicator_volume_over_sphere": self.sphere.volume / self.scene.sphere.volume}),
            "steady_gmres_iterations": self.steady_iterations,
            **(self.constraint_report() if self.constraint is not None else {}),
        }

    def pair_report(self) -> dict:
        """A pair's last 2 x 2 added mass, each row over its sphere's displaced mass, and each indicator's
        volume over its sphere's."""
        scene = self.scene
        displaced = np.array([body.displaced_mass for body in scene_bodies(scene)])
        matrix = self.last_force.added_mass if self.last_force is not None else None
        return {"added_mass_over_displaced": (matrix / displaced[:, None]).tolist() if matrix is not None else None,
                "indicator_volume_over_sphere": (self.pair.volumes
                                                 / np.array([sphere.volume for sphere in scene.spheres])).tolist(),
                "pair_min_flow_gap_m": self.pair.min_gap}

    def constraint_report(self) -> dict:
        """The Brinkman constraint's cost and how rigid the interior is at the end (max |u - U e_z| where
        phi = 1)."""
        constraint, band = self.constraint, self.sphere.band
        slip = constraint.interior_slip(self.flow.now, self.history.velocity, band.radius - band.width)
        return {"constraint": self.settings.constraint, "constraint_cg_iterations": constraint.iterations,
                "constraint_cg_iterations_per_step": constraint.iterations / max(self.steps_this_run, 1),
                "constraint_unit_cg_iterations": constraint.unit_iterations,
                "constraint_unconverged": constraint.unconverged, "interior_slip_m_s": slip}

    def destroy(self) -> None:
        """Free the PETSc objects (the mesh and the report's numbers stay)."""
        if self.constraint is not None:
            self.constraint.destroy()
        if self.sphere is not None:
            self.sphere.destroy()
        if self.pair is not None:
            self.pair.destroy()
        if self.flow is not None:
            self.flow.destroy()
