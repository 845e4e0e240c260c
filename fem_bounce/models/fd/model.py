"""The fictitious-domain model on a fixed mesh (`--model fd`, numerics.fd.mesh = "fixed"): one fluid step, as a
FlowModel (fem_bounce.flow_model).  The default mesh moves with the spheres: moving.py.

One fluid step of length dt (fluid.FlowSolver, immersed.ImmersedBodies, coupling), driven by the run
controller (fem_bounce.run.Controller), which owns the loop, the observers and the checkpoints:

1. place each sphere's indicator where the controller predicts its centre at t_{n+1} (AB2);
2. predictor A x~ = b(u^n, u^{n-1});
3. responses A y0 = rho c sum_i phi_i (-u~), A y1_j = rho c phi_j e_z (y1_j reused while sphere j
   stays put);
4. the forces on the spheres are affine in their new velocities U: hand F* and the numerical added
   mass matrix M to the shared BodyIntegrator, which sub-cycles through the contacts and blends
   f_sim with f_thr below delta_sl exactly as every model does;
5. read back U and set the step's field u = u~ + y0 + sum_j s_j(U) y1_j.

Every per-sphere value is an array over the spheres on the axis (one sphere is N = 1).
numerics.fd.constraint = "implicit" (penalised.PenalisedFlow) replaces steps 2-5 by one solve with the
spheres' friction in the step's matrix, factorised every step: no viscous step bound, and each step may have
its own length (numerics.fd.adaptive_step, flow_model.StepLimits, the ale model's controller): short through
a collision, which the contact makes within one step (with a long one the step's numerical added mass,
the liquid the step moves with the sphere, grows with dt, and the contact reverses it with the sphere).

A checkpoint holds the flow's BDF history by dof coordinates (fem.functions), so a run checkpointed
on two ranks can restart on one.
"""
from __future__ import annotations

import math
import resource
import time
from dataclasses import fields
from pathlib import Path

import numpy as np

from ...bodies import scene_bodies
from ...fem.domain import speed_scale
from ...fem.field_writer import FieldWriter
from ...fem.functions import CheckpointMismatch, gather_history, scatter_history
from ...fem.mesh import check_size, create_mesh
from ...fem.transfer import DivergenceFreeProjection, SerialField, interpolate_from
from ...fem.solver import SolverError
from ...flow_model import (MAX_GAP_FRACTION, FlowModel, PastLevels, StepLimits, approach_for, end_clipped,
                           fixed_step_time, flow_gaps, nearest_gap, safe_fixed_step, steps_to)
from ...kinematics import FluidForce, Prediction
from ...motion import is_stream
from ...output import CheckpointError, body_array, per_body, segment_path
from ...scene import SceneError, pair_diameter
from ..unread import refuse_unread
from . import coupling
from .domain import PEAK_SPEED_FACTOR, Domain, domain_for, patch_center, penalty_rate, time_step
from .fluid import FlowSolver
from .immersed import ImmersedBodies, check_hold, interior_slip
from .penalised import PenalisedFlow
from .steady import SteadyStokes


class History(PastLevels):
    """The spheres' velocities [m/s] and interior integrals I = U V_phi [m^4/s] of the last steps, newest first,
    each an array over the spheres (flow_model.PastLevels's levels "velocities" and "interiors"); `bdf` are the
    flow's BDF coefficients (the coming step's: the model sets them when the steps vary)."""

    def __init__(self, bdf: tuple, velocities: list, interiors: list):
        super().__init__(velocities=velocities, interiors=interiors)
        self.bdf = bdf

    def push(self, velocity: np.ndarray, interior: np.ndarray) -> None:
        super().push(velocities=velocity, interiors=interior)

    @property
    def velocities(self) -> list:
        return self["velocities"]

    @velocities.setter
    def velocities(self, values: list) -> None:
        self["velocities"] = values

    @property
    def interiors(self) -> list:
        return self["interiors"]

    @interiors.setter
    def interiors(self, values: list) -> None:
        self["interiors"] = values

    @property
    def velocity(self) -> np.ndarray:
        return self.velocities[0]

    @property
    def reference_velocity(self) -> np.ndarray:
        """U_ref: dV/dt ~ c (U - U_ref) [m/s]."""
        return self.reference("velocities", self.bdf)

    @property
    def momentum_history(self) -> np.ndarray:
        """J: the BDF history of the interior integrals [m^4/s]."""
        return self.reference("interiors", self.bdf)


class FictitiousDomainModel(FlowModel):
    name = "fd"
    resolved = True
    divergences = (SolverError,)

    def __init__(self, scene, comm):
        super().__init__(scene, comm)
        self.path_domain: Domain = domain_for(scene)  # refined along the whole path: the largest mesh
        check_size(self.path_domain.spec, "numerics.fd")
        self.dt = self.cfl_step = time_step(scene)  # the coming step; the cfl step [s]
        self.adaptive = self.settings.resolved("adaptive_step")  # steps of their own length (StepLimits)
        fd = self.settings
        self.step_limits = StepLimits(self.cfl_step, fd.min_step_factor, fd.max_step_factor, speed_scale(scene, "fd"),
                                      fd.gap_fraction, approach_for(scene))
        self.time, self.last_step = 0.0, 0.0  # t_n and the step that reached it [s]
        self.bound = math.inf  # fixed implicit steps: the longest the gaps allow where the coming step starts [s]
        self.step_range = [math.inf, 0.0]  # the shortest and longest step taken [s]
        self.bodies = scene_bodies(scene)
        self.held = np.array([body.held for body in self.bodies])  # the flow holds them where they start
        centers = [body.initial_gap + body.sphere.radius for body in self.bodies]
        # the patches' centres [m] (numerics.fd.patch), None: refined along the path
        moving = self.settings.patch and not self.held.all()  # held spheres keep the path's (their own) box
        self.patches = [patch_center(scene, c, k) for k, c in enumerate(centers)] if moving else None
        self.domain = self.path_domain if self.patches is None else domain_for(scene, self.patches)
        self.remeshes, self.remesh_s = 0, 0.0
        self.retired = {"back_solves": 0, "factorisations": 0}  # the solver counts of the meshes left behind
        self.flow: FlowSolver | None = None
        self.immersed: ImmersedBodies | None = None
        self.fields: FieldWriter | None = None
        self.timings = {"setup": 0.0, "steps": 0.0, "integrator": 0.0}
        self.steady_iterations: int | None = None
        self.last_force: coupling.Linearised | None = None
        self.steady = self.settings.steady_stokes
        self.implicit = self.settings.constraint == "implicit"
        if self.adaptive and (not self.implicit or fd.time_order == 3):
            raise SceneError("numerics.fd.adaptive_step = true needs numerics.fd.constraint = \"implicit\" (the "
                             "penalty keeps its factors for one step length) and time_order 1 or 2")
        self._check_unread(scene)
        if self.steady and (not self.held.all() or is_stream(scene)):
            raise SceneError("numerics.fd.steady_stokes = true needs every sphere's mode = \"fixed\" (motion.mode, "
                             "second_sphere.mode) without a stream")
        if len(self.bodies) > 1:
            self._check_spheres(scene)
        if not self.implicit and not self.steady:
            self._check_penalty_step(scene)

    def _check_unread(self, scene) -> None:
        """Settings this mesh and constraint would read nowhere, refused (as the moving mesh refuses the fixed mesh's,
        moving.FIXED_MESH_ONLY)."""
        fd, defaults = self.settings, {f.name: f.default for f in fields(self.settings)}
        if fd.hold_delta != defaults["hold_delta"]:
            raise SceneError(f"numerics.fd.hold_delta = {fd.hold_delta:g} shapes the moving mesh only (where it stops "
                             "following a sphere); the fixed mesh places its spheres at the contact model's holds "
                             "(contact.delta_sl under the near-wall correction): unset it, or set numerics.fd.mesh = "
                             "\"moving\"")
        if not self.implicit and fd.penalty_strength != defaults["penalty_strength"]:
            raise SceneError(f"numerics.fd.penalty_strength = {fd.penalty_strength:g} sets the implicit constraint's "
                             "friction; constraint = \"penalty\" forces with rho c phi, c = 3 / (2 dt), and reads it "
                             "nowhere: unset it, and set numerics.fd.forcing_number (its rigidity: dt <= "
                             "forcing_number h^2 / nu) or numerics.fd.constraint = \"implicit\"")
        refuse_unread(scene, "fd")  # the other settings this mesh and constraint read nowhere (models/unread.py)

    def _check_penalty_step(self, scene) -> None:
        """The one-shot penalty keeps its factors for one step length, so its steps are never shortened near a
        contact: a step that could close more than the contact's gap (flow_model.safe_fixed_step: at the impact
        speed scale, half of delta_sl D) is refused, naming the setting that makes it."""
        fd, speed = self.settings, speed_scale(scene, "fd")
        safe = safe_fixed_step(scene, speed)
        if self.cfl_step <= safe * (1.0 + 1e-9):
            return
        fine, nu = scene.sphere.diameter / fd.cells_per_diameter, scene.liquid.kinematic_viscosity
        cfl = fd.resolved("peak_cfl")  # dt = min(peak_cfl h / (1.5 U), forcing_number h^2 / nu): either shortens it
        raise SceneError(f"numerics.fd.peak_cfl = {cfl:g} with forcing_number = {fd.forcing_number:g} makes the "
                         f"one-shot penalty's fixed step {self.cfl_step:.3g} s, longer than the {safe:.3g} s this "
                         f"scene allows (a step at the impact speed scale, {speed:.3g} m/s, carrying a sphere "
                         "at most half across the contact model's gap delta_sl D): the step could jump a collision, "
                         "and the penalty's factors keep one step length.  Allowed for this scene: "
                         f"numerics.fd.peak_cfl up to {safe * PEAK_SPEED_FACTOR * speed / fine:.3g}, "
                         f"or forcing_number up to {safe * nu / fine**2:.3g}; or set numerics.fd.constraint = "
                         "\"implicit\" (its adaptive steps are bounded by the gaps)")

    def _check_spheres(self, scene) -> None:
        """What more than one sphere needs, refused here, before the run writes anything."""
        if is_stream(scene):
            raise SceneError("a pair in a stream (motion.stream_velocity) is not modelled: give stream_velocity = 0")
        offset = self.settings.resolved("radius_offset")
        min_gap = 2.0 * max(offset * self.domain.fine_size, 0.0)  # ImmersedBodies.min_gaps
        spheres = scene.spheres
        for k in np.flatnonzero(~(self.held[:-1] & self.held[1:])):  # a neighbouring pair that can close
            check_hold(min_gap, scene.contact.delta_sl * pair_diameter(spheres[k], spheres[k + 1]),
                       "the pair's hold gap of the contact model")

    # -- set-up ---------------------------------------------------------------------------
    def build(self, integrator) -> None:
        """The mesh, the flow at rest (or in its stream) and every sphere's indicator where it starts; the
        history at the spheres' start velocities and the interiors' integrals of the flow as it is (a
        launched sphere's penalty force then sets its interior liquid moving without taking that momentum
        from the sphere: a rigid sphere has none)."""
        start = time.perf_counter()
        self.hold_gaps = tuple(integrator.hold_gaps)  # (above the wall, each pair's) [m]
        self._make_flow([body.initial_gap + body.sphere.radius for body in self.bodies])
        velocities = np.array([body.start_velocity for body in self.bodies])
        interiors = self.immersed.interiors(self.flow.now.x.petsc_vec)
        if self.implicit:  # the liquid's mean velocity over the ball the friction holds (penalised.py)
            interiors = interiors * self.immersed.ball_volumes / self.immersed.volumes
        order = self.flow.order
        self.history = History(self.flow.bdf, [velocities] * order, [interiors] * order)
        self.timings["setup"] = time.perf_counter() - start

    def _make_flow(self, centers) -> None:
        """The mesh of `self.domain`, its flow at rest (or in its stream) and the spheres' indicators at
        `centers` [m]."""
        scene, domain, fd, liquid = self.scene, self.domain, self.settings, self.scene.liquid
        mesh, _, facet_tags = create_mesh(self.comm, domain.spec)
        self.mesh = mesh
        options = dict(inflow_speed=domain.inflow_speed, order=fd.time_order, solver=fd.solver)
        if self.implicit:
            self.flow = PenalisedFlow(mesh, facet_tags, domain.sides, liquid.density, liquid.viscosity, self.dt,
                                      penalty_rate(scene), **options)
        else:
            self.flow = FlowSolver(mesh, facet_tags, domain.sides, liquid.density, liquid.viscosity, self.dt,
                                   **options)
        self.flow.set_uniform((0.0, domain.inflow_speed))
        radii = [body.sphere.radius for body in self.bodies]
        edge = fd.resolved("radius_offset") * domain.fine_size
        self.immersed = ImmersedBodies(self.flow, [a + edge for a in radii], radii,
                                       fd.interface_width * domain.fine_size, centers)
        if self.implicit:
            self.flow.place(self.immersed, centers)

    def follow(self, centers) -> None:
        """Move the refined patches (numerics.fd.patch) when a sphere's centre has strayed more than half the
        margin from its patch's: a new mesh around `centers` [m], the flow's BDF history carried over
        (fem.transfer: interpolated, then made discretely divergence-free); the penalty's interior integrals
        U V_phi rescaled to the new indicators' volumes."""
        margins = [0.5 * self.settings.patch_margin * body.diameter for body in self.bodies]
        if all(abs(c - p) <= m for c, p, m in zip(centers, self.patches, margins)):
            return
        start = time.perf_counter()
        old_flow, old_immersed = self.flow, self.immersed
        self.patches = [patch_center(self.scene, c, k) for k, c in enumerate(centers)]
        self.domain = domain_for(self.scene, self.patches)
        self._make_flow(centers)
        projection = DivergenceFreeProjection(self.flow.W, self.flow.bcs, prefix="fd_projection_")
        try:
            for old, new in zip(old_flow.states, self.flow.states):
                interpolate_from(SerialField(old, 1e-9 * self.domain.fine_size), new)
                projection.project(new)
        finally:
            projection.destroy()
        if not self.implicit:  # U V_phi: the new indicators' volumes (the implicit's balls are the same)
            scale = self.immersed.volumes / old_immersed.volumes
            self.history.interiors = [interior * scale for interior in self.history.interiors]
        self.retired["back_solves"] += old_flow.operator.back_solves
        self.retired["factorisations"] += getattr(old_flow, "factorisations", 0)
        old_immersed.destroy()
        old_flow.destroy()
        if self.fields is not None:  # the snapshots go on in a file on the new mesh (fields.read_snapshots merges)
            self.fields.close()
            self._open_fields()
        self.remeshes += 1
        self.remesh_s += time.perf_counter() - start

    def initial_velocities(self) -> list[np.ndarray]:
        return list(self.history.velocities)

    # The clock: t_n + dt with adaptive steps, (n + 1) dt with fixed ones, the last step shortened to end at
    # run.end_time (flow_model.end_clipped) with the variable-step BDF coefficients (order 2 for time_order 3, that
    # step only: fluid.FlowSolver.set_time_step).  The one-shot penalty keeps its factors for one step length: its
    # shortened last step assembles and factorises its matrix once more (_shorten_penalty_step), and its steps are
    # not shortened near a contact (a step that could jump one is refused: _check_penalty_step).
    def previous_time_step(self) -> float | None:
        if self.adaptive:
            return self.last_step if self.last_step else None
        length = self.step_length()
        return None if not self.last_step or math.isclose(length, self.last_step, rel_tol=1e-9) else self.last_step

    def start_step(self, gaps: np.ndarray, velocities: np.ndarray) -> None:
        """Adaptive steps: the coming one no longer than StepLimits.first allows from the spheres' `gaps` [m] and
        `velocities` [m/s] where it starts (the first step too).  Fixed implicit steps: shortened only where the
        gaps ask for it, closing no contact by more than its gap (Approach.longest at MAX_GAP_FRACTION, as the
        moving mesh's fixed steps: for one sphere never at the default peak_cfl)."""
        if self.adaptive:
            self.dt = self.step_limits.first(self.dt, gaps, velocities)
        elif self.implicit:
            self.bound = self.step_limits.approach.longest(gaps, velocities, MAX_GAP_FRACTION)

    def time_step(self) -> float:
        return self.step_length()

    def next_time(self) -> float:
        return end_clipped(self._unclipped_time(), self.scene.run.end_time, self.cfl_step)

    def _unclipped_time(self) -> float:
        if self.adaptive:
            return self.time + self.dt
        return min(fixed_step_time(self._now(), self.step, self.dt, self.last_step), self._now() + self.bound)

    def step_length(self) -> float:
        """The length of the coming step [s]: dt, or what is left of it (next_time)."""
        t_next = self.next_time()
        regular = t_next == (self.time + self.dt if self.adaptive else (self.step + 1) * self.dt)
        return self.dt if regular else t_next - self._now()

    def _now(self) -> float:
        """t_n [s] (a checkpoint of fixed steps from before time was kept: n dt)."""
        if self.time is None:
            self.time = self.step * self.dt
        return self.time

    def finished(self, end_time: float) -> bool:
        if self.adaptive or abs(self._now() - self.step * self.dt) > 1e-9 * self.dt:
            return self._now() >= end_time - 1e-9 * self.cfl_step  # (fixed steps: off their grid, past a restart)
        return self.step >= steps_to(end_time, self.dt)

    # -- one step -------------------------------------------------------------------------
    def predicted_centers(self, prediction: Prediction) -> np.ndarray:
        """Where the flow's spheres will be at t_{n+1} [m]: held spheres stay put, the others as predicted
        but no closer than the contact model's hold gaps (flow_model.flow_gaps; below them the contact
        model adds what the flow misses); a sphere approaching a held one from below stops at the pair's
        hold gap under it."""
        bodies = self.bodies
        gaps = np.where(self.held, [body.initial_gap for body in bodies], prediction.gaps)
        return (flow_gaps(gaps, [body.diameter for body in bodies], self.hold_gaps, self.held)
                + np.array([body.sphere.radius for body in bodies]))

    def linearised_force(self, prediction: Prediction) -> FluidForce:
        centers = self.predicted_centers(prediction)
        if self.patches is not None:
            self.follow(centers)
        self._length = self.step_length()
        self._short = self.next_time() != self._unclipped_time()  # shortened to end at end_time
        if self.implicit:  # (fixed steps: the same coefficients every step but a shortened last one)
            self.flow.set_time_step(self._length, self.previous_time_step())
            self.history.bdf = self.flow.bdf
        if self.adaptive:
            self._gap = nearest_gap(prediction.gaps, [body.diameter for body in self.bodies], self.scene.wall.present)
        if self.implicit:
            self.flow.place(self.immersed, centers)
            linear = self.flow.linearise(self.history.momentum_history, self.history.reference_velocity)
        else:
            self.immersed.place(centers)
            if self._short:
                self._shorten_penalty_step()
            linear = self._linearise_penalty()
        if not (np.all(np.isfinite(linear.explicit)) and np.all(np.isfinite(linear.added_mass))):
            raise FloatingPointError(f"the fluid force became {linear.explicit} N at "
                                     f"t = {self.next_time():.6g} s")
        self.last_force = linear
        self._integrator_start = time.perf_counter()
        implicit = self.settings.coupling == "implicit"
        return FluidForce(explicit=linear.explicit, added_mass=linear.added_mass if implicit
                          else np.zeros_like(linear.added_mass))

    def _shorten_penalty_step(self) -> None:
        """The one-shot penalty's last step, shortened to end at run.end_time: its matrix (rho c M + mu K, c of the
        variable-step BDF2) assembled and factorised once more, the unit responses (rho c phi) made again.  The run
        ends with it, and no checkpoint is written there (FlowModel.ended_short): a run continued past its end time
        goes on from the checkpoint before, on the whole step's factors."""
        flow = self.flow
        flow.set_time_step(self._length, self.previous_time_step())
        flow.assembler.assemble()
        flow.operator.refactor()
        self.history.bdf = flow.bdf
        self.immersed.forget_units()  # y1 = A^-1 rho c phi: both changed

    def _linearise_penalty(self) -> coupling.Linearised:
        """The penalty forcing rho c sum_i phi_i (U_i - u~) (the default scheme): the predictor and the unit
        responses of the spheres that moved share one pass over the factors."""
        flow, immersed, h = self.flow, self.immersed, self.history
        predicted = flow.predicted
        vectors, functions = immersed.stale_units()
        flow.solve([flow.predictor_rhs(), *vectors], [predicted, *functions])
        flow.solve([immersed.forcing(predicted)], [immersed.forced])
        self.integrals = integrals = immersed.integrals(predicted)
        return coupling.linearise(integrals, self.scene.liquid.density, flow.c, h.momentum_history,
                                  h.reference_velocity)

    def complete(self, velocities: np.ndarray, time_now: float) -> None:
        self.timings["integrator"] += time.perf_counter() - self._integrator_start
        flow = self.flow
        velocities = np.array(velocities, dtype=float)
        if self.implicit:
            new = flow.field(velocities, flow.work)
            interiors = velocities * self.immersed.ball_volumes  # the held ball's momentum / rho (penalised.py)
        else:
            new = self.immersed.field(flow.predicted, coupling.rigid_amplitudes(self.integrals, velocities), flow.work)
            interiors = velocities * self.integrals.volume
        if not math.isfinite(new.norm()):
            raise FloatingPointError(f"the flow field became non-finite at t = {self.next_time():.6g} s")
        flow.commit(new)
        if self.adaptive:
            self._advance_time(velocities)
        else:
            self.time, self.last_step = self.next_time(), self._length
        self.history.push(velocities, interiors)
        self.step += 1
        self.ended_short = self._short

    def _advance_time(self, velocities: np.ndarray) -> None:
        """t_n <- t_{n+1}, and the coming step from the one just made (StepLimits.after)."""
        dt, levels = self._length, [velocities, *self.history.velocities[:2]]  # BDF1 keeps one level: no jerk
        self.step_range = [min(self.step_range[0], dt), max(self.step_range[1], dt)]
        self.dt = self.step_limits.after(levels, dt, self.last_step, self._gap)
        self.time, self.last_step = self.time + dt, dt

    def steady_force(self) -> FluidForce:
        """The steady Stokes state of the step (steady.SteadyStokes), held from the start."""
        forces = self.steady_forces()
        return FluidForce(explicit=forces, added_mass=np.zeros((len(forces), len(forces))))

    def complete_steady(self, time_now: float) -> None:
        """The steady state held to the end time, counted as the steps that reach it."""
        self.step = steps_to(self.scene.run.end_time, self.dt)
        self.time = time_now

    def steady_forces(self) -> np.ndarray:
        """The steady Stokes forces on the held spheres [N], their surfaces moving at their velocities
        (bodies.Body.start_velocity: motion.velocity, second_sphere.velocity: the quasi-steady drag of an
        approach or of a pair moving together, benchmarks/pair_stokes.py); the flow's states are left at
        that steady state."""
        velocities = np.array([body.start_velocity for body in self.bodies])
        if self.implicit:
            forces = self.flow.steady(velocities)
            self.last_force = coupling.Linearised(forces, np.zeros((len(forces), len(forces))), velocities)
            return forces
        steady = SteadyStokes(self.flow, self.immersed.spheres)
        try:
            forces, integrals = steady.solve(velocities)
        finally:
            steady.destroy()
        self.steady_iterations = steady.iterations
        self.integrals = integrals
        added_mass = coupling.added_mass(integrals, self.scene.liquid.density)
        self.last_force = coupling.Linearised(forces, added_mass, velocities)
        return forces

    def resolved_top(self) -> float:
        """The height [m] up to which the mesh is refined: a rising sphere is stopped there."""
        return self.path_domain.spec.refined[0].z_max

    # -- checkpoints and fields -------------------------------------------------------------
    def checkpoint_state(self) -> tuple[dict, dict]:
        """The BDF history of the flow (u, p at t_n, t_{n-1}, ...) by dof coordinates, gathered on rank 0,
        and of the spheres' velocities and interior integrals (a list per level, one value per sphere)."""
        patches = {} if self.patches is None else {
            "patch_centers": list(self.patches), "placed_centers": [sphere.center for sphere in self.immersed.spheres]}
        steps = {"time": self._now(), "last_step": self.last_step,
                 **({"step_length": self.dt, "step_range": self.step_range} if self.adaptive else {})}
        operator = self.flow.operator  # the run's counts so far, which a restart continues (report)
        counts = {"remeshes": self.remeshes, "remesh_s": self.remesh_s,
                  "back_solves": operator.back_solves + self.retired["back_solves"],
                  "factorisations": getattr(self.flow, "factorisations", 0) + self.retired["factorisations"]}
        return ({"dt": self.cfl_step, **steps, **self.history.state(), **patches, "counts": counts},
                gather_history(self.flow.states))

    def restore(self, state: dict, arrays) -> None:
        if not math.isclose(state["dt"], self.cfl_step, rel_tol=1e-12):
            raise CheckpointError(f"the checkpoint was made with dt = {state['dt']:g} s, this scene gives "
                                  f"{self.cfl_step:g} s: the scene was changed")
        if self.adaptive:
            try:
                self.time, self.dt, self.last_step = (float(state[key]) for key in ("time", "step_length", "last_step"))
                self.step_range = [float(value) for value in state.get("step_range", self.step_range)]
            except (KeyError, TypeError, ValueError):
                raise CheckpointError("the checkpoint has no adaptive step (time, step_length, last_step): it was made "
                                      "with numerics.fd.adaptive_step = false") from None
        else:  # fixed steps: t_n and the last step (n dt and dt in a checkpoint from before they were kept)
            self.time = float(state["time"]) if "time" in state else None
            self.last_step = float(state.get("last_step", self.dt))
        if self.patches is not None and state.get("patch_centers") != self.patches:  # moved: that mesh again
            try:
                patches, placed = ([float(z) for z in state[key]] for key in ("patch_centers", "placed_centers"))
            except (KeyError, TypeError, ValueError):
                raise CheckpointError("the checkpoint has no patch_centers and placed_centers: it was made with "
                                      "numerics.fd.patch = false") from None
            if len(patches) != len(self.bodies) or len(placed) != len(self.bodies):
                raise CheckpointError(f"the checkpoint's patches are for {len(patches)} sphere(s), this scene has "
                                      f"{len(self.bodies)}: the scene was changed")
            self.immersed.destroy()
            self.flow.destroy()
            self.patches, self.domain = patches, domain_for(self.scene, patches)
            self._make_flow(placed)
        try:
            scatter_history(self.flow.states, arrays, tolerance=1e-6 * self.domain.fine_size)
        except (ValueError, KeyError, CheckpointMismatch) as err:
            raise CheckpointError(f"the checkpoint does not fit this run's mesh: {err}") from None
        counts = state.get("counts")  # (none in a checkpoint from before they were kept: this segment's only)
        if counts is not None:  # the flow built for the restart starts its own counts at 0
            self.remeshes, self.remesh_s = int(counts["remeshes"]), float(counts["remesh_s"])
            self.retired = {key: int(counts[key]) for key in ("back_solves", "factorisations")}
        velocities, interiors = ([body_array(v) for v in state[key]] for key in ("velocities", "interiors"))
        count = len(self.bodies)
        if any(len(v) != count for v in velocities):
            raise CheckpointError(f"the checkpoint holds {len(velocities[0])} sphere(s), this scene {count}: "
                                  "the scene was changed")
        self.history = History(self.flow.bdf, velocities, interiors)

    def open_outputs(self, out_dir: Path, restart: bool, fields: bool, sides: dict | None = None) -> None:
        if fields:
            self.fields_dir = out_dir
            self._open_fields()

    def _open_fields(self) -> None:
        """A field file of its own for the mesh as it is (a new segment after each new mesh)."""
        path = self.comm.bcast(segment_path(self.fields_dir) if self.comm.rank == 0 else None, root=0)
        self.fields = FieldWriter(self.comm, path, self.mesh)

    def write_fields(self, time_now: float) -> None:
        self.fields.write(self.flow.now, time_now)

    def close_outputs(self) -> None:
        if self.fields is not None:
            self.fields.close()

    # -- what the summary says ----------------------------------------------------------------
    def sizes(self) -> dict:
        cells = self.mesh.topology.index_map(2).size_global
        return {"cells": cells, "unknowns": self.flow.unknowns, "dt": self.cfl_step, "fine_size": self.domain.fine_size}

    def report(self) -> dict:
        """Cost and discretisation details for summary.json (per-sphere values: a number for one sphere,
        a list for more; the added mass's row i over sphere i's displaced mass)."""
        self.timings["steps"] = self.loop_seconds
        steps = max(self.steps_this_run, 1)  # this segment's (its loop's time); the counts are the run's
        operator = self.flow.operator
        solves = operator.back_solves + self.retired["back_solves"]
        single = operator.single_solve_time / operator.single_solves if operator.single_solves else None
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0  # Linux reports kB
        displaced = np.array([body.displaced_mass for body in self.bodies])
        matrix = self.last_force.added_mass if self.last_force is not None else None
        return {
            "timings_s": self.timings,
            "time_per_step_s": self.timings["steps"] / steps,
            "back_solves": solves,
            "back_solves_per_step": solves / max(self.step, 1),
            "back_solve_s": single,
            "step_cost_in_back_solves": self.timings["steps"] / steps / single if single else None,
            "peak_memory_bytes": self.comm.allreduce(peak),  # sum over ranks of each rank's peak RSS
            "factorisation_memory_bytes": operator.factor_memory(),
            "solver": self.settings.solver,
            "krylov_iterations_per_solve": (operator.iterations / max(solves, 1) if hasattr(operator, "iterations")
                                            else None),
            "mesh_key": self.domain.spec.key(),
            "added_mass_over_displaced": per_body(matrix / displaced[:, None]) if matrix is not None else None,
            "indicator_volume_over_sphere": per_body(self.immersed.volumes / np.array(
                [body.sphere.volume for body in self.bodies])),
            "pair_min_flow_gap_m": min(self.immersed.min_gaps, default=None),
            "steady_gmres_iterations": self.steady_iterations,
            **({} if self.patches is None else {"remeshes": self.remeshes, "remesh_s": self.remesh_s}),
            **({"shortest_step_s": self.step_range[0], "longest_step_s": self.step_range[1]} if self.adaptive
               and self.step_range[1] else {}),
            **(self.constraint_report() if self.implicit else {}),
        }

    def constraint_report(self) -> dict:
        """The implicit penalty's factorisations and how rigid the interiors are at the end (max |u - U_i e_z|
        deeper than the band, over the spheres) [m/s]."""
        slips = [interior_slip(self.flow, self.flow.now, sphere.center, velocity,
                               sphere.band.radius - sphere.band.width)
                 for sphere, velocity in zip(self.immersed.spheres, self.history.velocity)]
        factorisations = self.flow.factorisations + self.retired["factorisations"]
        return {"constraint": self.settings.constraint, "factorisations": factorisations,
                "penalty_rate_per_s": self.flow.penalty_rate, "interior_slip_m_s": max(slips)}

    def destroy(self) -> None:
        """Free the PETSc objects (the mesh and the report's numbers stay)."""
        for owner in (self.immersed, self.flow):
            if owner is not None:
                owner.destroy()
