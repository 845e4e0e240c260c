"""The immersed-boundary model (`--model ib`): the paper's own method (section 2.1).

Each fluid step of size dt (fixed, chosen from the CFL number and the expected
impact speed; halved if the measured CFL number exceeds `max_cfl`, or where the
step could close more than the gap to the wall, flow_model.Approach at
MAX_GAP_FRACTION, never at the defaults; the last one shortened to end at
run.end_time: each new dt refactorises K, which Crank-Nicolson and the
variable-step AB2 convection allow):

1. predict the sphere's gap at t + dt from its last two velocities and place
   the Lagrangian points there;
2. advance the flow without immersed forces (FlowSolver.predict);
3. find the forces f0 that make the flow match the sphere's current velocity
   V_n at the points, and the forces f1 of a unit velocity (both by CG).  The
   flow is linear in the sphere's new velocity V': f = f0 + (V' - V_n) f1;
4. hand the sphere integrator the resolved force linearised in its
   acceleration (implicit coupling, docs/physics.md section 5):

       f_sim = -F(f) + m_l dV/dt,   F(f) = 2 pi rho_l sum_k f_k,z

   where -F is minus the total immersed force and m_l dV/dt the momentum change
   of the liquid that fills the sphere (Uhlmann 2005), so that

       explicit = -F(f0),   added_mass = F(f1) dt - m_l  (about m_l / 2);

5. the integrator sub-cycles through the contact to t + dt and returns V'; the
   flow is completed with f0 + (V' - V_n) f1.

The flow is a 2-D problem of 10^4-10^5 unknowns solved serially (PETSc on
COMM_SELF): under mpiexec the run goes to rank 0 alone while the other ranks wait
(fem_bounce.run.SERIAL; a one-line warning says so), so no rank repeats the solve
and results do not depend on the number of ranks.  Many ib runs use many cores
through a study's --jobs N or --executor mpi (fem_bounce.studies.runner).

The paper advanced the pair with explicit RK2; this coupling stays stable for
light spheres (see benchmarks/ib_validation.py for the measured limit).  With
`numerics.ib.coupling = "explicit"` the flow instead follows the old velocity V_n
and only the interior liquid's m_l dV/dt is implicit (Uhlmann 2005): kept to show
the difference, it fails as rho_p / rho_l approaches 1.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import scipy.linalg as sla

from ...errors import RunDiverged
from ...flow_model import MAX_GAP_FRACTION, FlowModel, approach_for
from ...kinematics import FluidForce, Prediction
from ...motion import is_free, is_held, series_speed
from ...output import CheckpointError
from ...scene import SceneError
from ..unread import refuse_unread
from .body import SphereSurface
from .delta import SUPPORT, interpolation_matrix
from .domain import build_grid
from .grid import WALL
from .operators import AxisymmetricOperators
from .snapshots import SnapshotWriter
from .solver import FlowSolver, ForcePreconditioner, ForceSolveError


def time_step(scene, h: float) -> tuple[float, float]:
    """(dt [s], speed scale [m/s]) from the CFL number and the viscous limit of numerics.ib."""
    opts, motion = scene.numerics.ib, scene.motion
    if is_free(scene):
        speed = scene.estimated_impact_speed()
    else:
        speed = max(abs(motion.velocity), abs(motion.stream_velocity), series_speed(scene))
    speed = max(speed, 1e-12)
    nu = scene.liquid.kinematic_viscosity
    dt = min(opts.cfl * h / speed, opts.viscous_cfl * h * h / nu, scene.run.end_time / 20.0)
    return dt, speed


class ImmersedBoundaryModel(FlowModel):
    name = "ib"
    resolved = True

    def __init__(self, scene, comm):
        super().__init__(scene, comm)
        refuse_unread(scene, self.name)  # settings this scene's run reads nowhere (models/unread.py)
        self.opts = self.settings
        self.solver: FlowSolver | None = None
        self.writer: SnapshotWriter | None = None
        self.grid = build_grid(scene)
        self.ops = AxisymmetricOperators(self.grid)
        self.held = is_held(scene)  # at its initial gap: the flow meets motion.velocity there, no f1 is needed
        self.dt, self.speed_scale = time_step(scene, self.grid.h)
        self.approach = approach_for(scene)
        self.bound = math.inf  # the longest step the gap allows where the coming one starts [s] (start_step)
        self._short = False
        h = self.grid.h
        exclusion = self.opts.wall_exclusion * h if self.grid.boundaries.bottom == WALL else -math.inf
        self.surface = SphereSurface(scene.sphere.radius, self.opts.point_spacing * h,
                                     self.opts.retraction * h, exclusion)

        self._check_fits(scene)

    def _check_fits(self, scene) -> None:
        """The delta kernel around the sphere must fit the uniform region before the first step; when it
        does not, the resolution (kernel width) or the region is wrong, not the run."""
        grid, d = self.grid, scene.sphere.diameter
        r_high, z_low, z_high = self._kernel_box(*self.surface.positions(scene.initial_gap))
        if not grid.in_fine_region(0.0, r_high, z_low, z_high):
            raise SceneError(
                f"numerics.ib: at {self.opts.cells_per_diameter:g} cells/D the delta kernel reaches "
                f"{SUPPORT * grid.h / d:.3g} D beyond the sphere's points (r up to {r_high / d:.3g} D, "
                f"z {z_low / d:.3g}..{z_high / d:.3g} D), past the uniform region (r <= "
                f"{grid.fine_r / d:.3g} D, z {grid.fine_z[0] / d:.3g}..{grid.fine_z[1] / d:.3g} D): raise "
                "numerics.ib.cells_per_diameter, or numerics.ib.fine_radius and fine_margin")

    def resolved_top(self) -> float:
        """The height [m] the sphere's top may reach with its delta kernel still in the uniform region."""
        return self.grid.fine_z[1] - SUPPORT * self.grid.h

    def _kernel_box(self, r: np.ndarray, z: np.ndarray) -> tuple[float, float, float]:
        """(r_max, z_min, z_max) [m] that the delta kernel around the points (r, z) [m] reaches."""
        reach = SUPPORT * self.grid.h
        z_low = z.min() - reach
        if self.grid.boundaries.bottom == WALL:
            z_low = max(z_low, 0.0)  # the kernel's mirror image handles the wall
        return r.max() + reach, z_low, z.max() + reach

    # -- pieces of a step ------------------------------------------------------------------------
    def _check_inside(self, r: np.ndarray, z: np.ndarray, t: float, gap: float) -> None:
        r_high, z_low, z_high = self._kernel_box(r, z)
        if self.grid.in_fine_region(0.0, r_high, z_low, z_high):
            return
        scene, d = self.scene, self.scene.sphere.diameter
        if (is_free(scene) and scene.sphere.density > scene.liquid.density
                and gap > scene.initial_gap):
            raise RunDiverged(f"t = {t:.5g} s: the sphere rose to gap {gap / d:.3g} D, above its release at "
                              f"{scene.initial_gap / d:.3g} D, which a sphere heavier than the liquid cannot: the "
                              "coupling went unstable (numerics.ib.coupling = \"explicit\" fails as rho_p / rho_l "
                              "nears 1; use \"implicit\", or a smaller numerics.ib.cfl)")
        raise RunDiverged(f"t = {t:.5g} s: the sphere and its delta kernel "
                          f"(z = {z_low / d:.3g}..{z_high / d:.3g} D) "
                          "left the uniform grid region "
                          f"(z = {self.grid.fine_z[0] / d:.3g}..{self.grid.fine_z[1] / d:.3g} D); "
                          "raise numerics.ib.fine_margin")

    # -- the FlowModel interface ----------------------------------------------------------------
    def build(self, integrator) -> None:
        opts = self.opts
        self.hold_gap = integrator.hold_gaps[0]  # above the wall [m]
        self.solver = FlowSolver(self.ops, self.scene.liquid.kinematic_viscosity, self.dt)
        self.stats = StepStatistics(calm_limit=0.5 * opts.max_cfl)
        self.preconditioner = ForcePreconditioner(self.grid.h)
        self.warm = WarmStarts(self.surface.n_points)
        self.drag_history: list[tuple[float, float]] = []
        self.time = integrator.time
        self._start_velocity = float(integrator.velocities[0])  # the one sphere's (registry: max_spheres 1)

    def initial_velocities(self) -> list[np.ndarray]:
        return [np.array([self._start_velocity]), np.array([self.warm.v_old])]

    def start_step(self, gaps: np.ndarray, velocities: np.ndarray) -> None:
        """The coming step: dt halved while it could close more than the gap to the wall (Approach.longest at
        MAX_GAP_FRACTION: at most the gap, delta_sl D where less), and shortened to end at run.end_time when it would
        pass it; either refactorises K (and drops the force tables, which depend on dt)."""
        solver, end_time = self.solver, self.scene.run.end_time
        self.bound = math.inf if self.held else self.approach.longest(gaps, velocities, MAX_GAP_FRACTION)
        dt = solver.dt
        while dt > self.bound:
            dt *= 0.5
        self._short = self.time + dt > end_time + 1e-9 * dt
        if self._short:
            dt = end_time - self.time
        if dt != solver.dt:
            solver.set_time_step(dt)
            self.preconditioner.clear()
            self.stats.refactorised()

    def time_step(self) -> float:
        return self.solver.dt

    def next_time(self) -> float:
        return self.time + self.solver.dt

    def finished(self, end_time: float) -> bool:
        return not self.time < end_time * (1.0 - 1e-12)

    def linearised_force(self, prediction: Prediction) -> FluidForce:
        """Steps 1-4 of the module docstring: the flow for the predicted points and the resolved force,
        linearised in the sphere's acceleration."""
        scene, opts, grid, solver = self.scene, self.opts, self.grid, self.solver
        # the one sphere's (registry: max_spheres 1)
        t, v, gap, dt = prediction.time, prediction.velocities_now[0], prediction.gaps_now[0], solver.dt
        # 1. the points where the sphere will be and the velocity the flow meets there; a moving sphere's flow
        # stops at the contact model's hold gap (it adds what the flow misses below)
        gap_next, v_ref = (gap, scene.motion.velocity) if self.held else (max(prediction.gaps[0], self.hold_gap), v)
        r_pts, z_pts = self.surface.positions(gap_next)
        self._check_inside(r_pts, z_pts, t, gap_next)
        active = self.surface.active(gap_next)
        n_act = int(active.sum())
        E = interpolation_matrix(grid, r_pts[active], z_pts[active])
        EC = (E @ solver.curl).tocsr()
        # 2. the flow without immersed forces; 3. the forces for V_n and for a unit velocity
        prediction_flow = solver.predict()
        zeros, ones = np.zeros(n_act), np.ones(n_act)
        S, keys = self.preconditioner.build(solver, gap_next + self.surface.radius, self._force_rows(solver))
        sel = np.concatenate([active, active])
        factor = sla.cho_factor(S[np.ix_(sel, sel)])
        apply = lambda res: sla.cho_solve(factor, res)  # noqa: E731
        warm = self.warm
        try:
            base = solver.solve_forces(EC, np.concatenate([zeros, v_ref * ones]) - E @ prediction_flow.q,
                                       warm.base[sel], opts.force_tolerance * self.speed_scale, apply)
            unit = None
            if not self.held and opts.coupling == "implicit":
                unit = solver.solve_forces(EC, np.concatenate([zeros, ones]), warm.unit[sel], opts.force_tolerance,
                                           apply)
        except ForceSolveError as err:
            raise RunDiverged(f"t = {t:.5g} s: {err}") from err
        if max(base.iterations, unit.iterations if unit else 0) > self.preconditioner.stale_after:
            self.preconditioner.mark_stale(keys)
        # 4. the resolved force, linearised in the sphere's acceleration
        to_newton = 2.0 * math.pi * scene.liquid.density  # kinematic ring forces / 2 pi -> N
        explicit = -to_newton * base.forces[n_act:].sum()
        if unit is None:  # explicit coupling, or held (dV/dt = 0): only the rigid interior liquid is implicit
            added = -scene.displaced_mass
        else:
            added = to_newton * unit.forces[n_act:].sum() * dt - scene.displaced_mass
        self._pending = (prediction_flow, E, sel, base, unit, v_ref, v, explicit)
        return FluidForce(explicit=np.array([explicit]), added_mass=np.array([[added]]))

    def complete(self, velocities: np.ndarray, time_now: float) -> None:
        """Step 5: the flow for the velocity the sphere actually reached; then the time step's adaptation."""
        solver, stats = self.solver, self.stats
        prediction_flow, E, sel, base, unit, v_ref, v, explicit = self._pending
        velocity = velocities[0]
        change = velocity - v_ref
        forces, psi = base.forces, base.psi
        if unit is not None:
            forces, psi = base.forces + change * unit.forces, base.psi + change * unit.psi
        solver.accept(prediction_flow, psi, E.T @ forces)
        self.warm.store(sel, forces, unit.forces if unit is not None else None, v)
        stats.record(base, unit, solver.cfl())
        if not (np.isfinite(velocity) and np.all(np.isfinite(solver.q))):
            raise RunDiverged(f"t = {self.time:.5g} s: the flow or the sphere became NaN")
        self.time = time_now
        self.step = stats.steps
        self.ended_short = self._short  # no checkpoint there: a run continued past its end goes on from the one before
        self.drag_history.append((time_now, explicit))
        if not self._short:
            self._adapt_time_step(solver, self.preconditioner, stats)

    # -- checkpoints: everything the next step reads, so a restart continues to the same numbers --
    def checkpoint_state(self) -> tuple[dict, dict]:
        solver, stats, warm, tables = self.solver, self.stats, self.warm, self.preconditioner.tables
        state = {"time": self.time, "dt": solver.dt, "dt_old": solver._dt_old, "v_old": warm.v_old,
                 "statistics": vars(stats), "force_tables_assembled": self.preconditioner.assembled,
                 "force_table_keys": sorted(tables)}
        arrays = {"psi": solver.psi, "q": solver.q, "w_top": solver.w_top, "q_boundary": solver.q_boundary,
                  "forcing": solver.forcing, "last_rhs": solver.last_rhs, "warm_base": warm.base,
                  "warm_unit": warm.unit, "drag_history": np.array(self.drag_history).reshape(-1, 2),
                  **{f"force_table_{k}": table for k, table in tables.items()}}
        if solver._conv_old is not None:
            arrays["convection_old"] = solver._conv_old
        return state, arrays

    def restore(self, state: dict, arrays) -> None:
        solver, warm = self.solver, self.warm
        if solver.psi.shape != arrays["psi"].shape:
            raise CheckpointError(f"the checkpoint's grid has {arrays['psi'].size} stream-function unknowns, this "
                                  f"scene's {solver.psi.size}: the scene was changed")
        if state["dt"] != solver.dt:
            solver.set_time_step(state["dt"])
        solver._dt_old = state["dt_old"]
        solver.psi, solver.q, solver.w_top = arrays["psi"], arrays["q"], arrays["w_top"]
        solver.q_boundary, solver.forcing, solver.last_rhs = arrays["q_boundary"], arrays["forcing"], arrays["last_rhs"]
        solver._conv_old = arrays.get("convection_old")
        warm.base, warm.unit, warm.v_old = arrays["warm_base"], arrays["warm_unit"], state["v_old"]
        self.preconditioner.tables = {k: arrays[f"force_table_{k}"] for k in state["force_table_keys"]}
        self.preconditioner.assembled = state["force_tables_assembled"]
        for key, value in state["statistics"].items():
            setattr(self.stats, key, value)
        self.drag_history = [tuple(row) for row in arrays["drag_history"]]
        self.time = state["time"]

    def open_outputs(self, out_dir: Path, restart: bool, fields: bool, sides: dict | None = None) -> None:
        if fields and self.comm.rank == 0:
            self.writer = SnapshotWriter(out_dir, self.grid.R, self.grid.Z,
                                         continue_until=self.time if restart else None)

    def write_fields(self, time_now: float) -> None:
        if self.writer is not None:
            self._snapshot(self.writer, self.solver, time_now)

    def close_outputs(self) -> None:
        if self.writer is not None:
            self.writer.close()

    def sizes(self) -> dict:
        grid = self.grid
        return {"unknowns": grid.n_psi, "cells": grid.n_cells, "fine_cells_per_diameter": self.opts.cells_per_diameter,
                "lagrangian_points": self.surface.n_points}

    def report(self) -> dict:
        return {"dt": self.dt, "final_dt": self.solver.dt, "speed_scale": self.speed_scale,
                **self.stats.summary(self.loop_seconds), "grid": self.grid.describe(),
                "lagrangian_points": self.surface.n_points,
                "snapshots": self.writer.count if self.writer is not None else 0,
                "force_tables_assembled": self.preconditioner.assembled, **self._drag_summary(self.drag_history),
                **self._recirculation_length(self.solver)}

    def destroy(self) -> None:
        if self.solver is not None:
            self.solver.destroy()

    def _force_rows(self, solver: FlowSolver):
        """z_centre -> E C for all points of a sphere centred at z_centre (for the force tables)."""
        r_all, z_all = self.surface.positions(-self.surface.radius)  # centred at z = 0
        return lambda z_centre: (interpolation_matrix(self.grid, r_all, z_centre + z_all) @ solver.curl).tocsr()

    def _adapt_time_step(self, solver: FlowSolver, preconditioner: ForcePreconditioner,
                         stats: "StepStatistics") -> None:
        """Halve dt when the CFL number exceeds max_cfl (an impact squeezes liquid out of the gap);
        double it back, up to the nominal dt, after 50 calm steps.  Either refactorises K."""
        limit = self.opts.max_cfl
        new_dt = None
        if stats.cfl > limit:
            new_dt = 0.5 * solver.dt
        elif stats.calm_steps >= 50 and solver.dt < self.dt and 2.0 * solver.dt <= self.bound:
            new_dt = min(2.0 * solver.dt, self.dt)
        if new_dt is not None:
            solver.set_time_step(new_dt)
            preconditioner.clear()
            stats.refactorised()

    def _drag_summary(self, history: list[tuple[float, float]]) -> dict:
        """For a fixed sphere in a stream: the drag coefficient over the last tenth of the run,
        and how much it moved from the tenth before (a steadiness check)."""
        scene = self.scene
        u = scene.motion.stream_velocity - scene.motion.velocity
        if not self.held or not u or len(history) < 20:
            return {}
        t, f = np.array(history).T
        cd = np.sign(u) * scene.drag_coefficient(f, u)
        last, before = t > t[-1] - 0.1 * t[-1], (t > t[-1] - 0.2 * t[-1]) & (t <= t[-1] - 0.1 * t[-1])
        return {"drag_coefficient": float(cd[last].mean()),
                "drag_coefficient_drift": float(cd[last].mean() - cd[before].mean())}

    def _recirculation_length(self, solver: FlowSolver) -> dict:
        """For a fixed sphere in an upward stream: the length of the reversed flow on the axis
        behind it, over D (Johnson & Patel 1999: 0.87 at Re 100, 1.46 at Re 200)."""
        scene, grid = self.scene, self.grid
        if not self.held or scene.motion.stream_velocity <= 0.0:
            return {}
        _, w = solver.full_velocity()
        axis = w[0, :]  # at r = h / 2
        top = scene.initial_gap + scene.sphere.diameter
        behind = np.nonzero(grid.Z > top + 0.5 * grid.h)[0]  # past the diffuse surface
        reverse = behind[axis[behind] < 0.0]
        if len(reverse) == 0 or grid.Z[reverse[0]] > top + 2.0 * grid.h:
            return {"recirculation_length_over_D": 0.0}
        j = reverse[np.argmax(np.diff(np.r_[reverse, reverse[-1] + 2]) > 1)]  # end of the first run
        z0, z1, w0, w1 = grid.Z[j], grid.Z[j + 1], axis[j], axis[j + 1]
        end = z0 - w0 * (z1 - z0) / (w1 - w0)
        return {"recirculation_length_over_D": float((end - top) / scene.sphere.diameter)}

    def _snapshot(self, writer: SnapshotWriter, solver: FlowSolver, t: float) -> None:
        ops = self.ops
        u, w = solver.full_velocity()
        ur, wz = ops.nodal_velocity(u, w)
        pressure = ops.nodal_from_cells(solver.pressure()) * self.scene.liquid.density
        writer.write(t, ur, wz, pressure, ops.vorticity(u, w))


class WarmStarts:
    """The last step's forces (all points; released ones hold zero) start the next CG solves."""

    def __init__(self, n_points: int):
        self.base = np.zeros(2 * n_points)
        self.unit = np.zeros(2 * n_points)
        self.v_old = 0.0  # the sphere velocity a step ago, for the position predictor [m/s]

    def store(self, sel: np.ndarray, forces: np.ndarray, unit: np.ndarray | None, velocity: float) -> None:
        self.base[:] = 0.0
        self.base[sel] = forces
        if unit is not None:
            self.unit[:] = 0.0
            self.unit[sel] = unit
        self.v_old = velocity


class StepStatistics:
    """What the run reports about its own numerics."""

    def __init__(self, calm_limit: float):
        self.calm_limit = calm_limit  # a CFL number below this counts as calm
        self.steps = self.iterations = self.solves = self.max_iterations = self.refactorisations = 0
        self.max_cfl = self.max_slip = self.cfl = 0.0
        self.calm_steps = 0  # steps since the CFL number was last above calm_limit

    def record(self, base, unit, cfl: float) -> None:
        self.steps += 1
        for sol in (base, unit):
            if sol is not None:
                self.iterations += sol.iterations
                self.solves += 1
                self.max_iterations = max(self.max_iterations, sol.iterations)
        self.max_slip = max(self.max_slip, base.slip)
        self.cfl = cfl
        self.max_cfl = max(self.max_cfl, cfl)
        self.calm_steps = self.calm_steps + 1 if cfl <= self.calm_limit else 0

    def refactorised(self) -> None:
        self.refactorisations += 1
        self.calm_steps = 0

    def summary(self, wall_time: float) -> dict:
        return {"cg_iterations_mean": self.iterations / max(self.solves, 1), "cg_iterations_max": self.max_iterations,
                "max_cfl": self.max_cfl, "refactorisations": self.refactorisations, "max_rms_slip": self.max_slip,
                "seconds_per_step": wall_time / max(self.steps, 1)}
