"""What a model is to the run: the FlowModel interface, and the bodies' predicted motion it is given.

The run controller (fem_bounce.run) owns the time loop; a model owns its flow.  One step of length dt:

    prediction = predictor.predict(t, integrator.gaps, integrator.velocities, dt, previous_dt)  # AB2
    fluid = model.linearised_force(prediction)   # advance the flow; f_sim = F* - M_a dV/dt (or None: f_thr)
    integrator.advance(model.next_time(), fluid) # the shared body integrator sub-cycles to t_{n+1}
    model.complete(integrator.velocities, t)     # the step's flow for the velocities the bodies reached
    predictor.push(integrator.velocities)

Every per-body value is an array over the bodies on the axis (sphere 1 first; one sphere is N = 1),
every added mass an N x N matrix.

then the observers (progress, trajectory rows, fields, checkpoints) and the stop conditions: that is
fem_bounce.steppers.CoupledStep.  A model that holds the bodies at a steady state (`steady`) is solved
once (SteadyStep); the ode model has no flow (OdeStep).

Adding a model means writing one FlowModel and its entry in models/registry.py, nothing else.
"""
from __future__ import annotations

import math
from abc import ABC, abstractmethod
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .bodies import scene_bodies
from .kinematics import FluidForce, Prediction
from .scene import pair_diameter


def flow_gaps(gaps, diameters, holds, held=None) -> np.ndarray:
    """Where a resolved flow places the bodies: their lowest points above z = 0 [m], the predicted `gaps`
    with sphere 1 kept at least holds[0] above the wall and each sphere k + 1 at least holds[k + 1] above
    sphere k's flow position (the near-wall correction holds the flow's geometry at delta_sl and adds
    what it misses; contact.py; BodyIntegrator.hold_gaps).  A hold of 0 places them where predicted.
    `held` (a mask over the bodies): those stay at their entries of `gaps`, and a moving sphere just below
    a held one stays at least its hold below it."""
    placed = np.array(gaps, dtype=float)
    held = np.zeros(len(placed), dtype=bool) if held is None else np.asarray(held, dtype=bool)
    for k in range(len(placed) - 2, -1, -1):
        if held[k + 1] and not held[k]:
            placed[k] = min(placed[k], placed[k + 1] - diameters[k] - holds[k + 1])
    if not held[0]:
        placed[0] = max(placed[0], holds[0])
    for k in range(1, len(placed)):
        if not held[k]:
            placed[k] = max(placed[k], placed[k - 1] + diameters[k - 1] + holds[k])
    return placed


class PastLevels:
    """Values at the last time levels t_n, t_{n-1}, ..., newest first, by name: the bodies' velocities and
    what a model keeps beside them (the mesh's sphere centres, the spheres' interior integrals), each level an
    array over the bodies.  With the coming step's BDF coefficients `bdf` (dy/dt ~ sum_j bdf[j] y^{n+1-j} / dt)
    it gives a quantity's reference (`reference`: dy/dt ~ c (y^{n+1} - reference)) and the rate of a new level.
    Predictor, the moving mesh (models/moving_mesh.py) and the fd model on its fixed mesh keep their levels here."""

    def __init__(self, **levels: list):
        self.levels = {name: list(values) for name, values in levels.items()}

    def __getitem__(self, name: str) -> list:
        return self.levels[name]

    def __setitem__(self, name: str, values: list) -> None:
        self.levels[name] = list(values)

    @property
    def velocities(self) -> list:
        return self.levels["velocities"]

    def push(self, **newest) -> None:
        """A new level t_{n+1} of every quantity (each by its name); the oldest leaves."""
        if newest.keys() != self.levels.keys():
            raise ValueError(f"a new level needs {sorted(self.levels)}, got {sorted(newest)}")
        for name, value in newest.items():
            self.levels[name] = [value] + self.levels[name][:-1]

    def reference(self, name: str, bdf: tuple) -> np.ndarray:
        """-sum_{j>=1} bdf[j] y^{n+1-j} / bdf[0] of the quantity `name`: with dy/dt ~ c (y^{n+1} - reference)."""
        return -sum(a * v for a, v in zip(bdf[1:], self.levels[name])) / bdf[0]

    def rate(self, name: str, newest: np.ndarray, bdf: tuple, dt: float) -> np.ndarray:
        """The BDF rate of the quantity `name` if it reaches `newest` at the end of a step dt [s]."""
        return (bdf[0] * newest + sum(a * z for a, z in zip(bdf[1:], self.levels[name]))) / dt

    def state(self) -> dict:
        """For a checkpoint: per name a list of levels, each a list over the bodies."""
        return {name: [np.asarray(v).tolist() for v in values] for name, values in self.levels.items()}


def mean_velocity(levels: list, dt: float, previous_dt: float | None = None):
    """The mean velocity over a coming step dt [s] from the last velocity levels, newest first (AB2; one level: it
    held): 1.5 V_n - 0.5 V_{n-1}, or V_n + (dt / 2) (V_n - V_{n-1}) / dt_{n-1} after a step `previous_dt` [s] of
    another length."""
    v = levels
    if len(v) == 1:
        return v[0]
    if previous_dt is None:
        return 1.5 * v[0] - 0.5 * v[1]
    return v[0] + 0.5 * dt / previous_dt * (v[0] - v[1])


class Predictor:
    """The bodies' last velocities, newest first (order 2: AB2; order 1: the last velocities held), each
    an array over the bodies [m/s]; checkpoints store them as lists."""

    def __init__(self, velocities: list[np.ndarray]):
        self.history = PastLevels(velocities=[np.array(v, dtype=float) for v in velocities])

    @property
    def velocities(self) -> list[np.ndarray]:
        return self.history.velocities

    def predict(self, time: float, gaps: np.ndarray, velocities: np.ndarray, dt: float,
                previous_dt: float | None = None) -> Prediction:
        """The bodies at the end of a step dt [s]; `previous_dt` [s]: the step before, when it differed
        (FlowModel.previous_time_step): the mean velocity is then V_n + (dt / 2) (V_n - V_{n-1}) / dt_{n-1}."""
        return Prediction(time, gaps, velocities, dt, mean_velocity(self.velocities, dt, previous_dt))

    def push(self, velocities: np.ndarray) -> None:
        self.history.push(velocities=np.array(velocities, dtype=float))


# An adaptive step (numerics.ale.adaptive_step, numerics.fd.adaptive_step) is the longest that
GAP_FRACTION = 0.05  # moves the spheres by at most a fraction (the model's) of their gap to what they may hit,
JERK_TOLERANCE = 1e-3  # keeps the velocity's curvature |dA/dt| dt^2 below this fraction of the speed scale,
GROWTH = 1.5  # and is at most this many times the step before (variable-step BDF2 is zero-stable below 2.41)
MAX_GAP_FRACTION = 0.5  # the largest gap_fraction: Approach.longest then keeps every step short of the contact


@dataclass(frozen=True)
class Approach:
    """How fast the bodies can close the gaps to what they may hit (the wall, their neighbours), for the bound
    StepLimits puts on every adaptive step, the first included and whatever its floor.

    A contact's gap g closes over a step of length dt by at most s dt + a dt^2 / 2: s bounds how fast it closes
    now (sphere 1's speed |V_1| for the wall, |V_k| + |V_k+1| for a pair) and a how fast that can grow: each
    sphere's net weight over its own mass, |1 - rho_l / rho_k| g, more than it ever accelerates (the added mass
    and the drag only slow it; the liquid gives back at most what it took, which the run's energy bound
    watches).  Requiring s dt <= f g and a dt^2 / 2 <= f g (f the gap fraction) each, a step closes at most
    2 f g <= g for f <= MAX_GAP_FRACTION, also from rest, where s = 0 and the speed alone bounds nothing.  Below
    the contact model's gap delta_sl D (delta_sl 2a* for a pair: the collision is the contact model's there,
    the flow held at its hold or handing over to f_thr) g is taken as that gap, so the bound never falls to 0."""

    diameters: tuple  # [m], sphere 1 first
    accelerations: tuple  # each sphere's net weight over its mass [m/s2]
    contact_gaps: tuple  # delta_sl D1 (the wall's), then delta_sl 2a* of each neighbouring pair [m]
    wall: bool

    def longest(self, gaps, velocities, fraction: float) -> float:
        """The longest step [s] from the bodies' `gaps` (lowest points above z = 0 [m]) and `velocities` [m/s]
        over which no contact closes more than 2 `fraction` of its gap (math.inf: nothing can close)."""
        gaps, speeds = np.asarray(gaps, dtype=float), np.abs(np.asarray(velocities, dtype=float))
        accelerations = np.asarray(self.accelerations)
        between = np.diff(gaps) - np.asarray(self.diameters)[:-1]
        contacts = [(gaps[0], speeds[0], accelerations[0], self.contact_gaps[0])] if self.wall else []
        contacts += [(between[k], speeds[k] + speeds[k + 1], accelerations[k] + accelerations[k + 1],
                      self.contact_gaps[k + 1]) for k in range(len(between))]
        longest = math.inf
        for gap, speed, acceleration, contact in contacts:
            reach = fraction * max(gap, contact)
            if speed > 0.0:
                longest = min(longest, reach / speed)
            if acceleration > 0.0:
                longest = min(longest, math.sqrt(2.0 * reach / acceleration))
        return longest


def safe_fixed_step(scene, speed: float) -> float:
    """The longest fixed step [s] that closes no contact by more than its gap (Approach.longest at MAX_GAP_FRACTION)
    where that gap is least, at the contact model's gap (delta_sl D; delta_sl 2a* for a pair), every moving body at
    the scene's speed scale `speed` [m/s] (a pair closing at twice it) and pulled by its net weight: a step at the
    impact speed then carries a sphere at most half across the contact's gap, so that the approach into it and the
    rebound out of it take steps of their own (math.inf: nothing can close).  What a model whose steps cannot be
    shortened refuses a longer step by (numerics.fd.constraint = "penalty")."""
    approach, bodies = approach_for(scene), scene_bodies(scene)
    gaps = [approach.contact_gaps[0]]
    for k in range(1, len(bodies)):
        gaps.append(gaps[-1] + bodies[k - 1].diameter + approach.contact_gaps[k])
    velocities = [0.0 if body.held else speed for body in bodies]
    return approach.longest(gaps, velocities, MAX_GAP_FRACTION)


def approach_for(scene) -> Approach:
    """The scene's Approach: its spheres, their net weights and the contact model's gaps."""
    bodies = scene_bodies(scene)
    delta = scene.contact.delta_sl
    accelerations = tuple(0.0 if body.held else abs(body.net_weight) / body.mass for body in bodies)
    pairs = tuple(delta * pair_diameter(lower.sphere, upper.sphere) for lower, upper in zip(bodies, bodies[1:]))
    return Approach(tuple(body.diameter for body in bodies), accelerations, (delta * bodies[0].diameter, *pairs),
                    scene.wall.present)


@dataclass(frozen=True)
class StepLimits:
    """How long an adaptive step may be: between min_factor and max_factor times the model's cfl step
    `base` [s]; `speed_scale` [m/s] the scene's, `gap_fraction` the part of the gap a step may close;
    `approach` (Approach) bounds every step, the first included and below the floor, by the gap it may close.

    A collision is a jump of the sphere's velocity within a few tens of microseconds; the flow meets it
    as a jump of its boundary velocity, and its answer (the rebound's drag and history, and how much
    liquid moves with the sphere while the contact reverses it) is decided in the steps around it: those
    need short steps, the fall far from the wall long ones.  BDF2's local error goes with the third
    derivative of the motion, the jerk, times the step squared."""

    base: float
    min_factor: float
    max_factor: float
    speed_scale: float
    gap_fraction: float = GAP_FRACTION
    approach: Approach | None = None

    def next(self, dt: float, gap: float, speed: float, jerk: float) -> float:
        """The coming step [s] after one of length dt [s] that leaves the spheres `gap` [m] from what they
        may hit, at `speed` [m/s], with their acceleration changing at `jerk` [m/s3]: at least the floor
        min_factor x base, or GROWTH dt after a step that first() shortened below it (the steps grow back to it,
        as variable-step BDF2 and the AB2 prediction need: a jump from there to the floor is unstable)."""
        longest = min(self.max_factor * self.base, GROWTH * dt)
        if speed > 0.0:
            longest = min(longest, self.gap_fraction * max(gap, 0.0) / speed)
        if jerk > 0.0:
            longest = min(longest, math.sqrt(JERK_TOLERANCE * self.speed_scale / jerk))
        return max(min(self.min_factor * self.base, GROWTH * dt), longest)

    def first(self, dt: float, gaps, velocities) -> float:
        """A step of `dt` [s] (next()'s, or the first) that starts with the bodies at `gaps` [m] and `velocities`
        [m/s], shortened to the longest that closes no contact by more than 2 gap_fraction of its gap, whatever
        the floor (Approach.longest; without an approach: dt).  FlowModel.start_step applies it."""
        if self.approach is None:
            return dt
        return min(dt, self.approach.longest(gaps, velocities, self.gap_fraction))

    def after(self, velocities: list, dt: float, last_step: float, gap: float) -> float:
        """The coming step [s] after one of length dt [s] that ended at velocities[0] (the bodies' last two or
        three velocities, newest first, arrays [m/s]; last_step [s] the step before it, 0 if none): the jerk
        from the three levels, the fastest body's (none from two).  Then bounded where it starts by first()."""
        acceleration = (velocities[0] - velocities[1]) / dt
        before = (velocities[1] - velocities[2]) / last_step if last_step and len(velocities) > 2 else acceleration
        jerk = float(np.max(np.abs(acceleration - before))) / (0.5 * (dt + (last_step or dt)))
        return self.next(dt, gap, float(np.max(np.abs(velocities[0]))), jerk)


def end_clipped(t_next: float, end_time: float, dt: float) -> float:
    """The end of a coming step that would reach `t_next` [s]: `end_time` [s] when it would pass it by more than
    rounding (1e-9 of the step dt [s], as FlowModel.finished's tolerance), so that a run ends at its end time."""
    return end_time if t_next > end_time + 1e-9 * dt else t_next


def fixed_step_time(time: float, step: int, dt: float, last_step: float) -> float:
    """The end of the coming step [s] of a model with fixed steps dt [s] after `step` steps that reached `time`
    [s] (last_step [s] the one before): (step + 1) dt; off that grid (a run continued past the end time that
    shortened its last step, end_clipped) the steps grow back to dt at most GROWTH times a step."""
    if abs(time - step * dt) <= 1e-9 * dt:
        return (step + 1) * dt
    return time + min(dt, GROWTH * last_step) if last_step else time + dt


def nearest_gap(gaps, diameters, wall: bool) -> float:
    """The bodies' nearest gap [m] for their `gaps` (lowest points above z = 0) and `diameters` [m]: each
    neighbouring pair's and sphere 1's to the wall (to z = 0 for one sphere without a wall)."""
    between = list(np.diff(gaps) - np.asarray(diameters)[:-1])
    return float(min(between + [gaps[0]]) if wall or not between else min(between))


def steps_to(end_time: float, dt: float) -> int:
    """The number of steps of length dt that reach end_time."""
    return max(1, math.ceil(end_time / dt - 1e-9))


class FlowModel(ABC):
    """A model of the liquid around the bodies.  Built for one scene (`__init__` checks it against the
    model and does nothing costly); `build` makes the meshes and solvers; then a stepper
    (fem_bounce.steppers) advances it: the coupled step calls `linearised_force` and `complete`, the
    steady one `steady_force` and `complete_steady`; a model without a flow (ode) needs neither.

    Class facts (name, resolution, restarts, cadences, stepper, colour, ...) live in models/registry.py;
    the controller reads them there and hands the model what it needs."""

    name: str = ""
    resolved: bool = True  # f_sim comes from this flow (False: f_thr everywhere)
    steady: bool = False  # held bodies solved for their steady state in one go (steppers.SteadyStep)
    divergences: tuple = ()  # exception types of the model's solvers that mean the run diverged
    fields_at_end: bool = False  # the final state also goes to the field files
    # the step just made was shortened to end at run.end_time (end_clipped): no checkpoint is written there, so that
    # a run continued past its end time goes on from the one before, as the uninterrupted longer run did
    ended_short: bool = False

    def __init__(self, scene, comm):
        self.scene = scene
        self.comm = comm
        self.step = 0  # fluid steps completed
        self.settings = getattr(scene.numerics, self.name)  # [numerics.NAME]
        self.loop_seconds = 0.0  # set by the controller: wall time of this segment's time loop [s]
        self.steps_this_run = 0  # set by the controller: steps taken in this segment (after a restart: since it)

    # -- set-up -----------------------------------------------------------------------------------
    def resolved_top(self) -> float:
        """The height [m] up to which the flow is resolved finely: a rising sphere is stopped there."""
        return math.inf

    @abstractmethod
    def build(self, integrator) -> None:
        """Make the meshes and solvers and set the liquid at rest (or in its stream); collective.  The
        shared sphere integrator is given for what the flow needs of it (its contact model's hold gap)."""

    def initial_velocities(self) -> list[np.ndarray]:
        """The predictor's history at the start, newest first, each an array over the bodies [m/s]."""
        return [np.array([body.start_velocity for body in scene_bodies(self.scene)])]

    # -- one step ---------------------------------------------------------------------------------
    def start_step(self, gaps: np.ndarray, velocities: np.ndarray) -> None:
        """The bodies' gaps [m] (lowest points above z = 0) and velocities [m/s] where the coming step starts,
        before it is asked for (time_step): a model with adaptive steps bounds it there by the gaps it may close
        (StepLimits.first)."""

    def time_step(self) -> float:
        """The length of the coming step [s] (a model with a fixed step sets self.dt)."""
        return self.dt

    def previous_time_step(self) -> float | None:
        """The length of the step before the coming one [s] when the steps vary, else None (equal steps)."""
        return None

    def next_time(self) -> float:
        """The end of the coming step [s]."""
        return (self.step + 1) * self.time_step()

    def finished(self, end_time: float) -> bool:
        """No step is left before end_time."""
        return self.step >= steps_to(end_time, self.time_step())

    def linearised_force(self, prediction: Prediction) -> FluidForce:
        """Advance the flow to the predicted body positions and return the forces on the bodies over the
        step, linearised in their accelerations (arrays over the bodies, an N x N added mass)."""
        raise NotImplementedError(f"the {self.name} model has no coupled step")

    def complete(self, velocities: np.ndarray, time: float) -> None:
        """Finish the step with the velocities the bodies reached at `time` [m/s, s] (an array, sphere 1
        first)."""
        raise NotImplementedError(f"the {self.name} model has no coupled step")

    # -- a steady model (steppers.SteadyStep) ---------------------------------------------------
    def steady_force(self) -> FluidForce:
        """The held bodies' steady state, solved once: its force, which holds to the end."""
        raise NotImplementedError(f"the {self.name} model has no steady solve")

    def steady_end_time(self, end_time: float) -> float:
        """Where the steady state is held to [s]: the end time."""
        return end_time

    def complete_steady(self, time: float) -> None:
        """Record the steady state held to `time` [s] as the run's steps."""
        raise NotImplementedError(f"the {self.name} model has no steady solve")

    # -- outputs ----------------------------------------------------------------------------------
    def side_files(self) -> dict[str, tuple]:
        """The model's own per-step CSV files in the run directory, {name: columns}.  The run owns them as it owns
        trajectory.csv (output.RunDirectory): synced with every checkpoint, which counts their rows, and cut back to
        those rows on a restart, so a killed and restarted run leaves them as an uninterrupted one would."""
        return {}

    def open_outputs(self, out_dir: Path, restart: bool, fields: bool, sides: dict | None = None) -> None:
        """Open the model's own files in the run directory (field snapshots when `fields`: the controller
        writes them on the scene's cadence); collective.  `restart`: continue what an earlier segment wrote.
        `sides`: rank 0's writers of side_files() by name (output.TrajectoryWriter: call one with a row dict of
        its columns); empty on the other ranks."""

    def write_fields(self, time: float) -> None:
        """One snapshot of the flow now (collective)."""

    def close_outputs(self) -> None:
        pass

    def checkpoint_state(self) -> tuple[dict, dict]:
        """(JSON-able state, arrays gathered on rank 0) that make this flow continue exactly; collective."""
        raise NotImplementedError(f"the {self.name} model writes no checkpoints")

    def restore(self, state: dict, arrays) -> None:
        """Set the flow from checkpoint_state's (state, arrays), read on every rank."""
        raise NotImplementedError(f"the {self.name} model writes no checkpoints")

    def sizes(self) -> dict:
        return {}

    def report(self) -> dict:
        """Cost and discretisation details for summary.json (under the model's name)."""
        return {}

    def destroy(self) -> None:
        """Free the solvers' PETSc objects."""
