"""The fictitious-domain model (`--model fd`): the time loop.

One fluid step of length dt (fluid.FlowSolver, immersed.ImmersedSphere, coupling):

1. predict the sphere centre at t_{n+1} (AB2 from the last two velocities) and place the indicator;
2. predictor A x~ = b(u^n, u^{n-1});
3. responses A y0 = rho c phi (-u~), A y1 = rho c phi e_z (y1 reused while the sphere is held);
4. the force on the sphere is affine in its new velocity U: hand F* and the numerical added
   mass m_a to the shared SphereIntegrator, which sub-cycles through the contact and blends
   f_sim with f_thr below delta_sl exactly as every model does;
5. read back U and set the step's field u = u~ + y0 + s(U) y1.

Observers act on a cadence after each step: the progress line, XDMF fields every
`output_every` steps, a checkpoint every `checkpoint_every` steps.
"""
from __future__ import annotations

import math
import resource
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from petsc4py import PETSc

from ...fem.mesh import create_mesh
from ...fem.solver import SolverError
from ...output import CheckpointError
from ...errors import RunDiverged
from ...scene import SceneError
from ...sphere import FluidForce, PenetrationError
from . import checkpoint, coupling
from .domain import Domain, domain_for, is_stream, speed_scale, steps_to, time_step
from .fields import FieldWriter, segment_path
from .fluid import FlowSolver
from .immersed import ImmersedSphere
from .multiplier import RigidConstraint
from .steady import SteadyMultiplierStokes, SteadyStokes


@dataclass
class History:
    """The sphere's velocities [m/s] and interior integrals I = U V_phi [m^4/s] of the last steps,
    newest first; `bdf` are the flow's BDF coefficients."""

    bdf: tuple
    velocities: list
    interiors: list
    step: int = 0

    def push(self, velocity: float, interior: float) -> None:
        self.step += 1
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


class Every:
    """Call `action(model)` after every `every`-th step (never when every = 0)."""

    def __init__(self, every: int, action: Callable):
        self.every, self.action = every, action

    def __call__(self, model) -> None:
        if self.every and model.history.step % self.every == 0:
            self.action(model)


class FictitiousDomainModel:
    name = "fd"
    resolved = True

    def __init__(self, scene, comm):
        self.scene = scene
        self.comm = comm
        self.settings = scene.numerics.fd
        self.domain: Domain = domain_for(scene)
        self.dt = time_step(scene)
        self.flow: FlowSolver | None = None
        self.sphere: ImmersedSphere | None = None
        self.constraint: RigidConstraint | None = None
        self.fields: FieldWriter | None = None
        self.timings = {"setup": 0.0, "steps": 0.0, "integrator": 0.0}
        self.last_checkpoint: tuple[int, float] | None = None
        self.steps_this_run = 0
        self.steady_iterations: int | None = None
        self.last_force: coupling.Linearised | None = None
        if self.settings.steady_stokes and (scene.motion.mode != "fixed" or is_stream(scene)):
            raise SceneError("numerics.fd.steady_stokes = true needs motion.mode = \"fixed\" without a stream")

    # -- set-up ---------------------------------------------------------------------------
    def setup(self) -> None:
        start = time.perf_counter()
        scene, domain, fd = self.scene, self.domain, self.settings
        mesh, _, facet_tags = create_mesh(self.comm, domain.spec)
        self.mesh = mesh
        self.flow = FlowSolver(mesh, facet_tags, domain.sides, scene.liquid.density, scene.liquid.viscosity, self.dt,
                               inflow_speed=domain.inflow_speed, order=fd.time_order, solver=fd.solver)
        self.flow.set_uniform((0.0, domain.inflow_speed))
        radius = scene.sphere.radius + fd.radius_offset * domain.fine_size
        self.sphere = ImmersedSphere(self.flow, radius, fd.interface_width * domain.fine_size, domain.center)
        if fd.constraint == "multiplier":
            self.constraint = RigidConstraint(self.flow, self.sphere, fd.constraint_tolerance, fd.unit_steps,
                                              speed_scale(scene))
        velocity = scene.motion.velocity if scene.motion.mode != "free" else 0.0
        order = self.flow.order
        self.history = History(self.flow.bdf, [velocity] * order, [velocity * self.sphere.volume] * order)
        self.timings["setup"] = time.perf_counter() - start

    # -- one step -------------------------------------------------------------------------
    def predicted_center(self, integrator) -> float:
        """Where the flow's sphere will be at t_{n+1} (AB2); held spheres stay put, and a free sphere's
        flow stops at the contact model's hold gap (below it the contact model adds what it misses) [m]."""
        if self.scene.motion.mode == "fixed":
            return self.domain.center
        v = self.history.velocities
        mean_velocity = 1.5 * v[0] - 0.5 * v[1] if len(v) > 1 else v[0]
        center = self.scene.sphere.radius + integrator.gap + self.dt * mean_velocity
        return self.scene.sphere.radius + max(center - self.scene.sphere.radius, integrator.contact.hold_gap, 0.0)

    def step(self, integrator) -> None:
        sphere = self.sphere
        center = self.predicted_center(integrator)
        if center != sphere.center:
            sphere.place(center)
        if self.constraint is not None:
            self._step_multiplier(integrator)
        else:
            self._step_penalty(integrator)

    def _advance_sphere(self, integrator, linear: coupling.Linearised, t_next: float) -> float:
        """Hand the linearised force to the sphere integrator; return the sphere's new velocity [m/s]."""
        if not all(math.isfinite(v) for v in (linear.explicit, linear.added_mass)):
            raise FloatingPointError(f"the fluid force became {linear.explicit} N at t = {t_next:.6g} s")
        self.last_force = linear
        start = time.perf_counter()
        added_mass = linear.added_mass if self.settings.coupling == "implicit" else 0.0
        integrator.advance(t_next, FluidForce(explicit=linear.explicit, added_mass=added_mass))
        self.timings["integrator"] += time.perf_counter() - start
        return integrator.velocity

    def _commit(self, new, velocity: float, t_next: float) -> None:
        if not math.isfinite(new.norm()):
            raise FloatingPointError(f"the flow field became non-finite at t = {t_next:.6g} s")
        self.flow.commit(new)
        self.history.push(velocity, velocity * self.sphere.volume)

    def _step_multiplier(self, integrator) -> None:
        """One step with the rigid-body constraint (multiplier.RigidConstraint): the predictor and the
        response to the last multiplier share one pass over the factors, CG corrects the multiplier
        for the extrapolated velocity U_e, and lambda_1 carries the force's dependence on U."""
        flow, sphere, h, constraint = self.flow, self.sphere, self.history, self.constraint
        t_next = (h.step + 1) * self.dt
        predicted = flow.predicted
        vectors, functions = constraint.first_pass()
        flow.solve([flow.predictor_rhs(), *vectors], [predicted, *functions])
        v = h.velocities
        extrapolated = 2.0 * v[0] - v[1] if len(v) > 1 else v[0]
        constraint.solve(predicted, extrapolated, responses_ready=True)
        rho, c = self.scene.liquid.density, flow.c
        volume = sphere.volume
        # F(U) = I(lambda(U)) + rho c (U V_phi - J), lambda(U) = lambda(U_e) + (U - U_e) lambda_1
        reference = h.reference_velocity
        explicit = (constraint.hold_force() + (reference - extrapolated) * constraint.unit_force()
                    + rho * c * (reference * volume - h.momentum_history))
        added_mass = -(constraint.unit_force() + rho * c * volume) / c
        velocity = self._advance_sphere(integrator, coupling.Linearised(explicit, added_mass, reference), t_next)
        new = constraint.field(predicted, velocity - extrapolated, flow.work)
        self._commit(new, velocity, t_next)

    def _step_penalty(self, integrator) -> None:
        """One step with the penalty forcing rho c phi (U - u~) (the scheme before the multiplier)."""
        flow, sphere, h = self.flow, self.sphere, self.history
        t_next = (h.step + 1) * self.dt
        # predictor and (if the sphere moved) the unit response share one pass over the factors
        predicted = flow.predicted
        if sphere.unit_stale:
            flow.solve([flow.predictor_rhs(), sphere.unit_forcing()], [predicted, sphere.unit])
        else:
            flow.solve([flow.predictor_rhs()], [predicted])
        flow.solve([sphere.forcing(predicted)], [sphere.forced])
        integrals = sphere.integrals(predicted)
        rho, c = self.scene.liquid.density, flow.c
        linear = coupling.linearise(integrals, rho, c, h.momentum_history, h.reference_velocity)
        velocity = self._advance_sphere(integrator, linear, t_next)
        s = coupling.rigid_amplitude(integrals, velocity)
        new = flow.work
        predicted.vector.copy(new)
        new.axpy(1.0, sphere.forced.vector)
        new.axpy(s, sphere.unit.vector)
        self._commit(new, velocity, t_next)

    def solve_steady(self, integrator) -> None:
        """Jump to the steady Stokes state of the step (steady.SteadyStokes) at the end time."""
        if self.constraint is not None:
            steady = SteadyMultiplierStokes(self.flow, self.sphere, tolerance=1e-6)
        else:
            steady = SteadyStokes(self.flow, self.sphere)
        try:
            force, integrals = steady.solve(self.scene.motion.velocity)
        finally:
            steady.destroy()
        self.steady_iterations = steady.iterations
        added_mass = coupling.added_mass(integrals, self.scene.liquid.density) if self.constraint is None else 0.0
        self.last_force = coupling.Linearised(force, added_mass, self.scene.motion.velocity)
        n_steps = steps_to(self.scene.run.end_time, self.dt)
        integrator.advance(n_steps * self.dt, FluidForce(explicit=force))
        self.history.step = n_steps

    @property
    def time(self) -> float:
        return self.history.step * self.dt

    def resolved_top(self) -> float:
        """The height [m] up to which the mesh is refined: a rising sphere is stopped there."""
        return self.domain.spec.refined[0].z_max

    # -- checkpoints and fields -------------------------------------------------------------
    def save_checkpoint(self, integrator, out_dir: Path) -> None:
        h = self.history
        state = {"step": h.step, "time": self.time, "dt": self.dt, "ranks": self.comm.size,
                 "velocities": h.velocities, "interiors": h.interiors, "integrator": integrator.state_dict()}
        checkpoint.save(self.comm, out_dir, state, self.flow.states)
        self.last_checkpoint = (h.step, self.time)

    def load_checkpoint(self, integrator, out_dir: Path) -> None:
        state = checkpoint.load(out_dir, self.flow.states, tolerance=1e-6 * self.domain.fine_size)
        if not math.isclose(state["dt"], self.dt, rel_tol=1e-12):
            raise CheckpointError(f"the checkpoint in {out_dir} was made with dt = {state['dt']:g} s, "
                                  f"this scene gives {self.dt:g} s: the scene was changed")
        self.history = History(self.flow.bdf, list(state["velocities"]), list(state["interiors"]), step=state["step"])
        integrator.load_state_dict(state["integrator"])  # the run module has cut the trajectory back to it
        self.last_checkpoint = (state["step"], state["time"])

    def write_fields(self, model=None) -> None:
        self.fields.write(self.flow.now, self.time)

    # -- the run --------------------------------------------------------------------------
    def run(self, integrator, progress, out_dir=None, restart=False) -> dict:
        self.setup()
        fd = self.settings
        if restart:
            self.load_checkpoint(integrator, out_dir)
        observers = [lambda model: progress(integrator.time, model.history.step, integrator.gap, integrator.velocity)]
        if out_dir is not None and fd.output_every:
            path = self.comm.bcast(segment_path(out_dir) if self.comm.rank == 0 else None, root=0)
            self.fields = FieldWriter(self.comm, self.mesh, self.flow.W, path)
            if not restart:
                self.write_fields()
            observers.append(Every(fd.output_every, FictitiousDomainModel.write_fields))
        if out_dir is not None and fd.checkpoint_every:
            observers.append(Every(fd.checkpoint_every, lambda model: model.save_checkpoint(integrator, out_dir)))
        n_steps = steps_to(self.scene.run.end_time, self.dt)
        start = time.perf_counter()
        steps_before = self.history.step
        try:
            if fd.steady_stokes:
                self.solve_steady(integrator)
                for observer in observers:
                    observer(self)
            while self.history.step < n_steps and not integrator.done:
                self.step(integrator)
                for observer in observers:
                    observer(self)
            self.timings["steps"] = time.perf_counter() - start
            self.steps_this_run = self.history.step - steps_before
            return {"steps": self.history.step, "sizes": self.sizes(), "extra": {"fd": self.report()}}
        except (SolverError, ArithmeticError, PenetrationError, PETSc.Error) as err:
            where = ("no checkpoint yet" if self.last_checkpoint is None else
                     f"last checkpoint at step {self.last_checkpoint[0]}, t = {self.last_checkpoint[1]:.6g} s")
            message = str(err)
            if isinstance(err, ArithmeticError) and not isinstance(err, FloatingPointError):
                message = (f"the coupled step broke down ({type(err).__name__}: {err}) near t = {integrator.time:.6g} s "
                           f"with the sphere at {integrator.velocity:.3g} m/s: unstable (for a light sphere use "
                           f"numerics.fd.coupling = \"implicit\"; otherwise lower numerics.fd.cfl)")
            raise RunDiverged(f"{message} ({where})") from err
        finally:
            if self.fields is not None:
                self.fields.close()
            self.destroy()

    def sizes(self) -> dict:
        cells = self.mesh.topology.index_map(2).size_global
        return {"cells": cells, "unknowns": self.flow.unknowns, "dt": self.dt, "fine_size": self.domain.fine_size}

    def report(self) -> dict:
        """Cost and discretisation details for summary.json."""
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
            "added_mass_over_displaced": (self.last_force.added_mass / self.scene.displaced_mass
                                          if self.last_force is not None else None),
            "indicator_volume_over_sphere": self.sphere.volume / self.scene.sphere.volume,
            "steady_gmres_iterations": self.steady_iterations,
            **(self.constraint_report() if self.constraint is not None else {}),
        }

    def constraint_report(self) -> dict:
        """The multiplier's cost and how rigid the interior is at the end (max |u - U e_z| where phi = 1)."""
        constraint, band = self.constraint, self.sphere.band
        slip = constraint.interior_slip(self.flow.now, self.history.velocity, band.radius - band.width)
        return {"constraint": "multiplier", "constraint_cg_iterations": constraint.iterations,
                "constraint_cg_iterations_per_step": constraint.iterations / max(self.steps_this_run, 1),
                "constraint_unit_cg_iterations": constraint.unit_iterations,
                "constraint_unconverged": constraint.unconverged, "interior_slip_m_s": slip}

    def destroy(self) -> None:
        """Free the PETSc objects (the mesh and the report's numbers stay)."""
        if self.constraint is not None:
            self.constraint.destroy()
        if self.sphere is not None:
            self.sphere.destroy()
        if self.flow is not None:
            self.flow.destroy()
