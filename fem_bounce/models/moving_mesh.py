"""The mesh that moves with the spheres: one machinery for the ale model (models/ale: each sphere a hole with a
no-slip surface) and the fd model on its moving mesh (models/fd/moving.py: each sphere filled, held rigid by a
penalty).  Each model owns a MovingMesh (composition: neither model is the other's subclass) and hands it the
flow it solves (`make_flow`, a factory called for every new mesh) and how that flow's sphere volume is measured.

The domain (MovingMeshDomain, from `[numerics.ale]` or `[numerics.fd]`) follows the rules every finite-element
model shares (fem.domain), with every sphere on the axis cut out (the fd model's filled), sphere 1 (the lowest)
first; the fine region covers the spheres' whole path, so the mesh moving with them stays fine.  Around each
sphere the triangles have the fine size on its surface (surface_refinement times finer if asked: the collision's
Stokes layer is thinner than a cell), and in the gap below it (to the wall or to the sphere beneath) at most
(local gap) / min_gap_cells (fem.mesh.SphereHole), so a remeshed gap is always resolved.

The N spheres on the axis (bodies.scene_bodies) sit in one mesh, each with its own mesh extension
(fem.mesh_motion); every per-sphere value is an array over them, the added mass an N x N matrix.
One fluid step of length dt (MovingMesh.linearise, then complete):

1. predict the sphere centres at t_{n+1} (AB2 from the last two velocities); the mesh puts its
   spheres there, placed by flow_model.flow_gaps with the holds below (a held sphere stays put);
2. if the moved mesh would have a triangle of quality below min_quality, remesh around those
   positions and carry the flow over (remesh below), then move the mesh and set its velocity;
3. the flow's step on the moved mesh gives the forces at the reference velocities U_ref and their slopes in
   the spheres' velocities (flow.step: the ale model's N + 1 solves, or the penalised flow's);
4. the variational forces are affine in the new velocities U, F_i = F*_i - c sum_j M_ij (U_j - U_ref,j)
   with M = -(dF_i/dU_j) / c: the model hands F* and M to the shared BodyIntegrator, which sub-cycles
   through the contacts and blends f_sim with f_thr below delta_sl as every model does;
5. read back U and keep the step's field for U (flow.commit); the velocities and the mesh's sphere centres
   join the history of past levels (flow_model.PastLevels), whose BDF reference gives U_ref and the mesh velocity.

Near contact.  The gap soon becomes thinner than a step's travel V dt, and thinner than any
mesh one would pay for; below delta_sl the contact model has already handed the force to
f_thr (H = 0.9933 at delta = 0.1, 0.99966 at delta = 0.04).  So the mesh stops following
sphere 1 at the gap hold_delta D above the wall, and a neighbouring pair at hold_delta 2a* (a*
their reduced radius); under the contact model's near-wall correction at its own holds instead
(integrator.hold_gaps: delta_sl D and delta_sl 2a*, below which it adds the lubrication the flow
misses).  The flow's sphere stays there, its surface still moving with the sphere's velocity U (a
quasi-steady squeeze, like the Brenner check), while the integrator carries the real sphere
through the contact and back; when it rises above the hold again the mesh follows it.  The f_sim
computed at the held gap is wrong by a factor of order lambda(delta) / lambda(hold_delta),
weighted by 1 - H; at the default hold 0.02 D that is below 1e-4 of f_thr.  With hold_delta = 0
the mesh follows the predicted positions until a step would put a sphere through the wall or its
neighbour (the run then stops, saying how close it got); in Li's case 3 it reached 0.004-0.007 D
at 8-32 cells/D without failing (the gap keeps min_gap_cells triangles across, and P2 holds the
parabolic lubrication profile exactly: the steady force stays within 1 % of Brenner's down to
0.01 D), overshooting the real sphere, whose microsecond reversal in the contact no fluid step can
see.  Nothing is gained: f_sim has no weight there.

Remeshing.  gmsh meshes the half-plane around the spheres' new positions; the flow's BDF
history is carried over by evaluating each old level on the old mesh where that level lived, at
the new mesh's nodes where they were at that level, and projecting it onto divergence-free fields
(fem.transfer), which also keeps the fluid's momentum.  Every new vertex is given the past positions
x - sum_k (z_k^{n+1} - z_k^j) psi_k(x) e_z of the new mesh's own motion law, so the nodal time
derivative and the mesh velocity stay consistent across the remesh.

Steps.  Each step has the cfl length, or with adaptive steps (numerics.ale.adaptive_step,
numerics.fd.adaptive_step) the length flow_model.StepLimits allows after the step before.
"""
from __future__ import annotations

import dataclasses
import math
import resource
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np

from ..bodies import scene_bodies
from ..errors import RunDiverged
from ..fem.domain import extent
from ..fem.field_writer import FieldWriter
from ..fem.functions import CheckpointMismatch, gather_history, scatter_history
from ..fem.mesh import SPHERE_TAGS, Box, HalfPlane, SphereHole, check_size, create_mesh
from ..fem.mesh_motion import MeshMotion
from ..fem.transfer import DivergenceFreeProjection, SerialField, interpolate_from
from ..flow_model import (MAX_GAP_FRACTION, FlowModel, PastLevels, StepLimits, end_clipped, fixed_step_time,
                          flow_gaps, nearest_gap, steps_to)
from ..kinematics import FluidForce, Prediction
from ..output import CheckpointError, body_array, per_body, segment_path
from ..scene import Scene, SceneError, pair_diameter

REMESH_QUANTUM = 1e-6  # [D] a new mesh is made around the spheres' positions rounded to this (MovingMesh.remesh)
TALLIES = ("factorisations", "krylov_iterations", "assembly_s", "factorise_s", "solve_s")  # a flow's solver counts


@dataclass(frozen=True)
class MovingMeshDomain:
    """Everything but the spheres' positions that shapes the mesh [m]."""

    radius: float  # R
    height: float  # Z
    refined: Box
    fine_size: float
    surface_size: float  # of the triangles on the spheres' surfaces
    coarse_size: float
    grading: float
    gap_cells: float
    radii: tuple  # of the spheres, sphere 1 (the lowest) first
    sides: dict  # WALL/OUTER/TOP -> boundary kind
    inflow_speed: float  # [m/s]
    initial_centers: tuple  # z of the sphere centres at t = 0
    # hold_delta as gaps: sphere 1's above the wall (hold_delta D1), then each neighbouring
    # pair's (hold_delta 2a*), as flow_model.flow_gaps takes them
    holds: tuple
    filled: bool = False  # the spheres' insides meshed too (the fd model's moving mesh: fem.mesh.SphereHole)

    def spec(self, centers) -> HalfPlane:
        """The half-plane with the spheres cut out (or filled) at z = centers [m] (a number: sphere 1's alone)."""
        holes = tuple(SphereHole(center=float(z), radius=a, surface_size=self.surface_size, gap_cells=self.gap_cells,
                                 filled=self.filled)
                      for z, a in zip(np.atleast_1d(centers), self.radii))
        return HalfPlane(radius=self.radius, height=self.height, fine_size=self.fine_size,
                         coarse_size=self.coarse_size, grading=self.grading, refined=(self.refined,), holes=holes)


def domain_for(scene: Scene, model: str = "ale") -> MovingMeshDomain:
    """The moving mesh's domain from `[numerics.model]` (the ale model's, or the fd model's with mesh = "moving",
    whose spheres are filled)."""
    table = getattr(scene.numerics, model)
    diameter = scene.sphere.diameter
    fine = diameter / table.cells_per_diameter
    coarse = max(diameter / table.coarse_cells_per_diameter, fine)
    half_plane = extent(scene, model)
    bodies = scene_bodies(scene)
    radii = tuple(body.sphere.radius for body in bodies)
    centers = tuple(gap + a for gap, a in zip(scene.initial_gaps, radii))
    if centers[-1] + radii[-1] + 2.0 * fine > half_plane.height:
        raise SceneError(f"numerics.{model}: the domain height {half_plane.height:g} m leaves no fluid above "
                         f"{bodies[-1].key}")
    # (a held sphere is never moved to a hold, flow_gaps keeps it at its gap: one nearer than hold_delta is no
    # reason to refuse the scene, and with every sphere held hold_delta is read nowhere, models/unread.py)
    holds = (table.hold_delta * diameter,
             *(table.hold_delta * pair_diameter(lower.sphere, upper.sphere)
               for lower, upper in zip(bodies, bodies[1:])))
    grading = table.resolved("grading") if model == "fd" else table.grading  # fd: unset is the moving mesh's own
    return MovingMeshDomain(radius=half_plane.radius, height=half_plane.height, refined=half_plane.refined,
                            fine_size=fine, surface_size=fine / table.surface_refinement, coarse_size=coarse,
                            grading=grading, gap_cells=table.min_gap_cells, radii=radii, sides=half_plane.sides,
                            inflow_speed=half_plane.inflow_speed, initial_centers=centers, holds=holds,
                            filled=model == "fd")


def checked_domain(scene, model: str) -> MovingMeshDomain:
    """The moving mesh's domain from `[numerics.model]` (domain_for), its size checked (fem.mesh)."""
    domain = domain_for(scene, model)
    check_size(domain.spec(domain.initial_centers), f"numerics.{model}")
    return domain


def launched(scene: Scene) -> bool:
    """Whether a free sphere starts moving in the liquid at rest (its liquid then jumps in the first step)."""
    return any(body.start_velocity != 0.0 and not body.held for body in scene_bodies(scene))


def first_step(scene: Scene, cfl_step: float, limits: StepLimits, adaptive: bool) -> float:
    """The first step [s]: the cfl step, or with adaptive steps the shortest when a free sphere is launched into the
    liquid at rest: it gives the liquid its added mass's momentum at once and slows fastest at first, and the steps
    then grow as StepLimits allows, the first ones BDF1 (MovingMesh.linearise's cold_start: BDF2 across the jump rings).
    Started at the fd default's cfl step, the first milliseconds of a launch went in one step, too fast
    (tests/test_fd_moving.py); a short first step with BDF2 across the start left the ale model's launch too fast
    (tests/test_ale.py)."""
    return limits.min_factor * cfl_step if adaptive and launched(scene) else cfl_step


@dataclass
class Remesh:
    """One remeshing: when, why, and what the transfer did to the fluid's momentum [SI]."""

    step: int
    time: float
    gap: float  # of the mesh's sphere 1 to the wall, after the move [m]
    quality: float  # the worst triangle had the move been made on the old mesh
    cells: int
    momentum_old: float  # of u^n on the old mesh [kg m/s]
    momentum_interpolated: float  # on the new mesh, straight after interpolation
    momentum_projected: float  # after the divergence-free projection
    sphere_volume_old: float  # of the old mesh's polygonal sphere [m^3]: a closed domain's fluid momentum
    sphere_volume: float  # is -rho V_h U exactly, so it changes by the ratio of these two
    seconds: float
    pair_gap: float | None = None  # the smallest gap between two of the mesh's spheres, after the move [m]


@dataclass
class Statistics:
    remeshes: list = field(default_factory=list)
    factorisation_s: float = 0.0
    integrator_s: float = 0.0
    remesh_s: float = 0.0
    setup_s: float = 0.0
    held_steps: int = 0
    longest_step: float = 0.0  # [s] (adaptive steps)
    min_mesh_gap: float = math.inf
    max_unknowns: int = 0
    min_mesh_pair_gap: float = math.inf  # the smallest gap between two of the mesh's spheres [m]
    # of the step matrix, over the meshes already left (tallied() adds the current mesh's)
    factorisations: int = 0
    krylov_iterations: int = 0
    assembly_s: float = 0.0
    factorise_s: float = 0.0
    solve_s: float = 0.0


@dataclass(frozen=True)
class StepRecord:
    """What one step did to the mesh, for the model's side file [SI]."""

    time: float  # t_{n+1}
    gap: float  # of the mesh's sphere 1 to the wall
    force: np.ndarray  # the variational force at the velocities reached [N]
    added_mass: np.ndarray  # [kg]
    quality: float  # the worst triangle
    remeshed: bool


class MovingMesh:
    """The mesh that follows the spheres, its flow, the history of past levels and the step's clock.

    `settings`: the model's numerics table (min_quality, time_order, hold_delta; krylov_rtol when `reuse`);
    `make_flow(mesh, facet_tags, motion, centers, dt)`: the model's flow on a new mesh; `sphere_volume(flow)`:
    the volume [m^3] of the mesh's spheres as that flow sees them (the remeshes' record); `reuse`: the flow
    solves with an earlier step's factors (the transfer's projection then reuses its own); `cfl_step` [s], the
    adaptive steps' `step_limits`, `first_step` [s] (default the cfl step)."""

    def __init__(self, scene, comm, settings, domain: MovingMeshDomain, make_flow: Callable, sphere_volume: Callable,
                 cfl_step: float, step_limits: StepLimits, adaptive: bool, reuse: bool = False,
                 first_step: float | None = None):
        self.scene, self.comm, self.settings, self.domain = scene, comm, settings, domain
        self.make_flow, self.sphere_volume, self.reuse = make_flow, sphere_volume, reuse
        self.cfl_step, self.step_limits, self.adaptive = cfl_step, step_limits, adaptive
        self.dt = cfl_step if first_step is None else first_step  # the coming step [s]
        self.ended_short = False  # the step just made was shortened to end at run.end_time
        self.bound = math.inf  # fixed steps: the longest the gaps allow where the coming step starts [s] (start_step)
        self.bodies = scene_bodies(scene)
        count = len(self.bodies)
        self.sphere_tags = SPHERE_TAGS[:count]
        self.diameters = np.array([body.diameter for body in self.bodies])
        self.radii = np.array(domain.radii)
        self.holds = domain.holds  # where the mesh holds the spheres near contact (build: the contact model's)
        self.mesh = self.motion = self.flow = None
        self.history: PastLevels | None = None  # velocities U [m/s] and the mesh's sphere centres z [m], per level
        self.step, self.time, self.last_step = 0, 0.0, 0.0  # steps made, t_n and the step that reached it [s]
        self.stats = Statistics()
        self.last_force = (np.zeros(count), np.zeros((count, count)))  # F* [N] and the added mass [kg]
        self.writer: FieldWriter | None = None

    # -- meshes ------------------------------------------------------------------------------
    def build_mesh(self, centers: np.ndarray, cache: bool = True) -> tuple:
        """(mesh, motion, flow) with the spheres centred at z = centers [m]."""
        mesh, _, facet_tags = create_mesh(self.comm, self.domain.spec(centers), cache=cache)
        motion = MeshMotion(mesh, facet_tags, centers, sphere_tags=self.sphere_tags)
        flow = self.make_flow(mesh, facet_tags, motion, centers, self.dt)
        self.stats.max_unknowns = max(self.stats.max_unknowns, flow.unknowns)
        return mesh, motion, flow

    def build(self, hold_gaps: tuple) -> None:
        """The mesh around the spheres where they start, the flow at rest (or in its stream), the history at the
        start velocities; the holds are the contact model's `hold_gaps` where it has them (its near-wall
        correction adds the lubrication the flow misses below them), elsewhere (a hold of 0) hold_delta's."""
        start = time.perf_counter()
        domain = self.domain
        order = self.settings.time_order
        self.holds = tuple(contact or own for own, contact in zip(self.holds, hold_gaps))
        centers = np.array(domain.initial_centers)
        self.mesh, self.motion, self.flow = self.build_mesh(centers)
        velocities = np.array([body.start_velocity for body in self.bodies])  # as the integrator's
        self.history = PastLevels(velocities=[velocities.copy() for _ in range(order)],
                               centers=[centers.copy() for _ in range(order)])
        self.flow.set_uniform((0.0, domain.inflow_speed))
        self.stats.setup_s = time.perf_counter() - start

    @staticmethod
    def _with_tallies(stats: Statistics, flow) -> None:
        """Add a flow's (a mesh's) solver counts and times to `stats`: the run's before the flow is dropped."""
        for key in TALLIES:
            setattr(stats, key, getattr(stats, key) + getattr(flow, key))

    def tallied(self) -> Statistics:
        """The statistics with the current mesh's solver tallies added (a copy)."""
        stats = dataclasses.replace(self.stats)
        self._with_tallies(stats, self.flow)
        return stats

    def remesh(self, center: np.ndarray, quality: float) -> None:
        """Mesh around the spheres centred at `center` [m] and carry the flow's history over.

        gmsh meshes the spheres at `center` rounded to REMESH_QUANTUM D (the new mesh then moves to `center`):
        its triangles change with the last bits of its input, and those differ between a serial run and one on
        2 ranks (1e-13 m in case 3), whose new meshes then differed by two triangles and their answers by 1e-5."""
        start = time.perf_counter()
        h = self.history
        old_motion, old_flow = self.motion, self.flow
        quantum = REMESH_QUANTUM * self.scene.sphere.diameter
        at = np.round(np.asarray(center) / quantum) * quantum
        try:
            mesh, motion, flow = self.build_mesh(at, cache=False)
        except Exception as err:  # gmsh raises plain Exception: the run ends as diverged, cleanly
            diameter = self.scene.sphere.diameter
            delta = (center[0] - self.radii[0]) / diameter
            between = "".join(f", pair gap {gap / diameter:.4g} D" for gap in self.mesh_pair_gaps(center))
            raise RunDiverged(f"remeshing at gap {delta:.4g} D{between} failed: {err}") from err
        tolerance = 1e-9 * self.scene.sphere.diameter
        momenta = []
        volumes = [self.sphere_volume(old_flow), self.sphere_volume(flow)]
        reuse = self.reuse
        projection = None
        try:
            for level, (old_state, new_state) in enumerate(zip(old_flow.states, flow.states)):
                old_motion.move_to(h["centers"][level])
                before = old_flow.momentum(old_state)
                # the new mesh where its own motion law puts it at that time level (if that is a valid mesh), and
                # only then the old field sampled at its nodes: sampled where the new mesh was built (at t_n+1),
                # each level's field came out shifted against its sphere by the step's travel (0.05 D at the fd
                # default; case 3's fall lost 2 % of its speed over three new meshes at delta_sl 0.1)
                motion.move_to(h["centers"][level] if motion.quality(h["centers"][level] - at) > 0.0 else center)
                interpolate_from(SerialField(old_state, tolerance), new_state)
                interpolated = flow.momentum(new_state)
                flow.set_boundary_values(h.velocities[level])
                if projection is None:
                    projection = DivergenceFreeProjection(flow.W, flow.bcs, solver="reuse" if reuse else "direct",
                                                          **({"rtol": self.settings.krylov_rtol} if reuse else {}))
                else:  # the older level, on the mesh moved there: factorised again or, reuse, the first level's factors
                    projection.reassemble()
                projection.project(new_state)
                momenta.append((before, interpolated, flow.momentum(new_state)))
        finally:
            if projection is not None:
                projection.destroy()
        motion.move_to(center)
        self._with_tallies(self.stats, old_flow)
        old_flow.destroy()
        self.mesh, self.motion, self.flow = mesh, motion, flow
        seconds = time.perf_counter() - start
        self.stats.remesh_s += seconds
        self.stats.remeshes.append(Remesh(
            step=self.step, time=self.time, gap=float(center[0] - self.radii[0]), quality=quality,
            cells=mesh.topology.index_map(2).size_global, momentum_old=momenta[0][0],
            momentum_interpolated=momenta[0][1], momentum_projected=momenta[0][2], sphere_volume_old=volumes[0],
            sphere_volume=volumes[1], seconds=seconds, pair_gap=min(self.mesh_pair_gaps(center), default=None)))

    def resolved_top(self) -> float:
        """The height [m] up to which the mesh is refined: a rising sphere is stopped there."""
        return self.domain.refined.z_max

    def mesh_pair_gaps(self, centers: np.ndarray) -> np.ndarray:
        """The gaps between neighbouring surfaces of the mesh's spheres centred at `centers` [m], lowest
        first (none for one sphere)."""
        return np.diff(centers) - self.radii[:-1] - self.radii[1:]

    # -- the clock ------------------------------------------------------------------------------
    def next_time(self) -> float:
        """The end of the coming step [s]: t_n + dt with adaptive steps, else (n + 1) dt as every constant-step
        model (flow_model.fixed_step_time); never past run.end_time (flow_model.end_clipped: the last step is
        shortened, with the variable-step BDF coefficients)."""
        return end_clipped(self._unclipped_time(), self.scene.run.end_time, self.cfl_step)

    def _unclipped_time(self) -> float:
        if self.adaptive:
            return self.time + self.dt
        return min(fixed_step_time(self.time, self.step, self.dt, self.last_step), self.time + self.bound)

    def step_length(self) -> float:
        """The length of the coming step [s]: dt, or what is left of it (next_time)."""
        t_next = self.next_time()
        regular = t_next == (self.time + self.dt if self.adaptive else (self.step + 1) * self.dt)
        return self.dt if regular else t_next - self.time

    def finished(self, end_time: float) -> bool:
        if self.adaptive:
            return self.time >= end_time - 1e-9 * self.cfl_step
        if abs(self.time - self.step * self.dt) > 1e-9 * self.dt:  # off the grid: a shortened last step before
            return self.time >= end_time - 1e-9 * self.cfl_step
        return self.step >= steps_to(end_time, self.dt)

    def start_step(self, gaps: np.ndarray, velocities: np.ndarray) -> None:
        """Adaptive steps: the coming one no longer than StepLimits.first allows from the spheres' `gaps` [m] and
        `velocities` [m/s] where it starts (the first step too).  Fixed steps: shortened (off their grid, growing
        back as fixed_step_time lets them) only where the gaps ask for it, a step closing no contact by more than its
        gap (Approach.longest at MAX_GAP_FRACTION).  For one sphere it never binds at the default cfl (ale's step
        carries it 0.03 D at the impact speed scale, against the half of delta_sl D = 0.2 D that would); a pair,
        closing at up to twice that speed over its own gap delta_sl 2a* (0.1 D for equal spheres), is bounded at
        0.025 D of travel per step, so its collision's few steps are shortened (refactor_check's ale-pair and
        ale-three at 6 cells/D: e 0.762 -> 0.742 and 0.873 -> 0.851, cfl 0.25 giving 0.749 and 0.854)."""
        if self.adaptive:
            self.dt = self.step_limits.first(self.dt, gaps, velocities)
        elif self.step_limits.approach is not None:
            self.bound = self.step_limits.approach.longest(gaps, velocities, MAX_GAP_FRACTION)

    def previous_time_step(self) -> float | None:
        """The step before the coming one [s] when the steps vary (None: equal steps)."""
        if self.adaptive:
            return self.last_step if self.last_step else None
        length = self.step_length()
        return None if not self.last_step or math.isclose(length, self.last_step, rel_tol=1e-9) else self.last_step

    def _next_step(self, velocity: np.ndarray, prediction: Prediction, length: float) -> float:
        """The coming step [s] (StepLimits.after) from the step just made (of `length` [s]), which ends at
        `velocity`, with the spheres' predicted gaps (to the wall and their neighbours: where they are, not where
        the mesh holds them)."""
        gap = nearest_gap(prediction.gaps, self.diameters, self.scene.wall.present)
        step = self.step_limits.after([velocity, *self.history.velocities[:2]], length, self.last_step, gap)
        self.stats.longest_step = max(self.stats.longest_step, step)
        return step

    # -- one step -------------------------------------------------------------------------------
    def next_centers(self, prediction: Prediction) -> tuple[np.ndarray, bool]:
        """(z, held): where the mesh puts the spheres' centres at t_{n+1} [m], the controller's AB2
        prediction or, where it would pass a wall or pair hold, that hold (flow_gaps: also below a held
        sphere), and whether a hold stopped a moving sphere; a held sphere stays put."""
        held = np.array([body.held for body in self.bodies])
        predicted = np.where(held, [body.initial_gap for body in self.bodies], prediction.gaps)
        gaps = flow_gaps(predicted, self.diameters, self.holds, held)
        stopped = (gaps != predicted) & ~held
        centers = np.where(stopped, gaps + self.radii, prediction.centers(self.radii))
        return np.where(held, self.domain.initial_centers, centers), bool(np.any(stopped))

    def linearise(self, prediction: Prediction, cold_start: bool = False) -> FluidForce:
        """Move (or remesh) to the predicted centres and make the flow's step: the forces at the reference
        velocities and the added mass (module docstring, steps 1-4); BDF1 with `cold_start` (the older level then
        weighs 0: the model's call, while a past level holds liquid not moving with a sphere it should follow)."""
        h, settings = self.history, self.settings
        t_next = self.next_time()
        self._short = t_next != self._unclipped_time()  # shortened to end at run.end_time
        center, held = self.next_centers(prediction)
        gap = float(center[0] - self.radii[0])  # sphere 1's, to the wall
        if gap <= 0.0:
            raise RunDiverged(f"the mesh cannot follow the sphere: the step to t = {t_next:.6g} s would put it "
                              f"{-gap:.3g} m into the wall (smallest mesh gap reached "
                              f"{self.stats.min_mesh_gap / self.scene.sphere.diameter:.4g} D)")
        for pair_gap in self.mesh_pair_gaps(center):
            if pair_gap <= 0.0:  # flow_gaps keeps the hold: only with both holds 0
                raise RunDiverged(f"the mesh cannot follow the pair: the step to t = {t_next:.6g} s would put the "
                                  f"spheres {-pair_gap:.3g} m into each other")
            self.stats.min_mesh_pair_gap = min(self.stats.min_mesh_pair_gap, pair_gap)
        quality, remeshed = math.inf, False
        if np.any(center != h["centers"][0]):
            quality = self.motion.quality(center - self.motion.reference_center)
            if quality < settings.min_quality:
                self.remesh(center, quality)
                remeshed = True
        self.stats.held_steps += held
        length = self.step_length()
        self.flow.set_time_step(length, self.previous_time_step(), 1 if cold_start else None)
        self.motion.move_to(center)
        self.motion.set_rates(h.rate("centers", center, self.flow.bdf, length))
        self.stats.min_mesh_gap = min(self.stats.min_mesh_gap, gap)
        reference = h.reference("velocities", self.flow.bdf)
        start = time.perf_counter()
        extrapolated = sum(beta * v for beta, v in zip(self.flow.ext, h.velocities))
        force, slope = self.flow.step(reference, extrapolated_velocity=extrapolated)
        self.stats.factorisation_s += time.perf_counter() - start
        added_mass = -slope / self.flow.c  # M_ij = -(dF_i/dU_j) / c
        if not (np.all(np.isfinite(force)) and np.all(np.isfinite(added_mass))):
            raise FloatingPointError(f"the fluid force became {force} N at t = {t_next:.6g} s")
        self.last_force = (force, added_mass)
        self._pending = (t_next, length, center, gap, reference, force, slope, added_mass, quality, remeshed,
                         prediction)
        self._integrator_start = time.perf_counter()
        return FluidForce(explicit=force, added_mass=added_mass)

    def complete(self, velocities: np.ndarray) -> StepRecord:
        """The step's field for the velocities the spheres reached; t_n <- t_{n+1} and the history's new level."""
        self.stats.integrator_s += time.perf_counter() - self._integrator_start
        t_next, length, center, gap, reference, force, slope, added_mass, quality, remeshed, prediction = self._pending
        velocity = np.array(velocities, dtype=float)  # the flow's own copy of the integrator's
        change = velocity - reference
        self.flow.commit(change)
        if self.adaptive:
            self.dt = self._next_step(velocity, prediction, length)
        self.step += 1
        self.ended_short = self._short
        self.last_step, self.time = t_next - self.time, t_next
        self.history.push(velocities=velocity, centers=center)
        return StepRecord(t_next, gap, force + slope @ change, added_mass,
                          quality if remeshed else self.motion.quality(self.motion.shift), remeshed)

    def hold_steady(self, force: np.ndarray) -> None:
        """The held spheres' steady `force` [N] (no added mass), at the mesh where they start."""
        count = len(self.bodies)
        self.last_force = (force, np.zeros((count, count)))
        centers = np.array(self.domain.initial_centers)
        self.stats.min_mesh_gap = float(centers[0] - self.radii[0])
        self.stats.min_mesh_pair_gap = min(self.mesh_pair_gaps(centers), default=math.inf)

    # -- checkpoints: the mesh's reference centre (remade by gmsh on restart), the flow's history by dof
    # coordinates on the mesh where it is now, the mesh's and the spheres' past, the statistics -----
    def checkpoint_state(self) -> tuple[dict, dict]:
        h = self.history
        self.flow.renew()  # reused factors: the run goes on with fresh ones, as a restart from here does
        arrays = gather_history(self.flow.states)
        stats = asdict(self.tallied())  # with the current mesh's tallies: a restart starts a new mesh's
        state = {"dt": self.cfl_step, "step_length": self.dt, "time": self.time, "last_step": self.last_step,
                 "mesh_center": self.motion.reference_center.tolist(), **h.state(),
                 "kinematics_step": self.step, "last_force": [x.tolist() for x in self.last_force],
                 "statistics": stats}
        return state, arrays

    def restore(self, state: dict, arrays) -> None:
        if not math.isclose(state["dt"], self.cfl_step, rel_tol=1e-12):
            raise CheckpointError(f"the checkpoint was made with dt = {state['dt']:g} s, this scene gives "
                                  f"{self.cfl_step:g} s: the scene was changed")
        mesh_center = body_array(state["mesh_center"])
        if np.any(mesh_center != self.motion.reference_center):  # remeshed: gmsh makes the same mesh again
            self.flow.destroy()
            self.mesh, self.motion, self.flow = self.build_mesh(mesh_center, cache=False)
        self.step = step = state["kinematics_step"]
        self.history = PastLevels(velocities=[body_array(v) for v in state["velocities"]],
                               centers=[body_array(z) for z in state["centers"]])
        self.time = state.get("time", step * self.cfl_step)
        self.last_step = state.get("last_step", self.cfl_step if step else 0.0)
        self.dt = state.get("step_length", self.cfl_step)
        self.motion.move_to(self.history["centers"][0])
        try:
            scatter_history(self.flow.states, arrays, tolerance=1e-6 * self.domain.fine_size)
        except (ValueError, KeyError, CheckpointMismatch) as err:
            raise CheckpointError(f"the checkpoint does not fit this run's mesh: {err}") from None
        statistics = dict(state["statistics"])
        statistics["remeshes"] = [Remesh(**r) for r in statistics["remeshes"]]
        self.stats = Statistics(**statistics)
        count = len(self.bodies)
        force, added_mass = state["last_force"]
        self.last_force = (body_array(force), body_array(added_mass).reshape(count, count))

    # -- field files: the mesh as it is at every snapshot (fem.field_writer) -------------------------
    def open_fields(self, out_dir: Path) -> None:
        path = self.comm.bcast(segment_path(out_dir) if self.comm.rank == 0 else None, root=0)
        self.writer = FieldWriter(self.comm, path)

    def write_fields(self, time_now: float) -> None:
        self.writer.write(self.flow.now, time_now)

    def close_fields(self) -> None:
        if self.writer is not None:
            self.writer.close()

    def destroy(self) -> None:
        if self.flow is not None:
            self.flow.destroy()

    # -- what the summary says --------------------------------------------------------------------
    def sizes(self, steady: bool) -> dict:
        cells = self.mesh.topology.index_map(2).size_global
        return {"cells": cells, "unknowns": self.flow.unknowns, "max_unknowns": self.stats.max_unknowns,
                "dt": None if steady else self.cfl_step, "fine_size": self.domain.fine_size}

    def report(self, steady: bool, loop_seconds: float) -> dict:
        """Cost, remeshing and near-contact details for summary.json [SI]; `loop_seconds` the time loop's."""
        stats = self.tallied()  # with the current mesh's solver tallies
        steps = max(self.step, 1)
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0  # Linux reports kB
        diameter = self.scene.sphere.diameter
        force, added_mass = self.last_force
        displaced = np.array([body.displaced_mass for body in self.bodies])
        between = {}
        if len(self.bodies) > 1:
            # the smallest gap between neighbours over the smallest neighbouring pair's 2a* (equal spheres: exact)
            smallest = min(pair_diameter(a, b) for a, b in zip(self.scene.spheres, self.scene.spheres[1:]))
            between = {"min_mesh_pair_delta": stats.min_mesh_pair_gap / smallest,
                       "holds_m": list(self.holds)}
        return {
            "solver": "steady" if steady else "march",
            "timings_s": {"setup": stats.setup_s, "steps": loop_seconds,
                          "factorise_and_solve": stats.factorisation_s,
                          "integrator": stats.integrator_s, "remesh": stats.remesh_s,
                          "assembly": stats.assembly_s, "factorisation": stats.factorise_s,
                          "solves": stats.solve_s},
            "time_per_step_s": loop_seconds / steps,
            "factorisation": "reuse" if self.reuse else "every-step",
            "factorisations": stats.factorisations,  # of the step matrix (each remesh adds two projections)
            "factorisations_per_step": stats.factorisations / steps,
            "krylov_iterations": stats.krylov_iterations,
            "remesh_count": len(stats.remeshes),
            "remeshes": [asdict(r) for r in stats.remeshes],
            "hold_delta": self.settings.hold_delta,
            "held_steps": stats.held_steps,
            "adaptive_step": self.adaptive,
            "longest_step_s": max(stats.longest_step, self.cfl_step),
            "min_mesh_delta": stats.min_mesh_gap / diameter,
            "last_force_N": per_body(force),
            "added_mass_over_displaced": per_body(added_mass / displaced[:, None]),  # M_ij / (rho V_i), row i
            "peak_memory_bytes": self.comm.allreduce(peak),
            **between,
        }


class MovingMeshModel(FlowModel):
    """What a model on a mesh that follows its spheres hands to its MovingMesh (`self.moving`, made by the
    subclass): the clock, the step, the checkpoint, the fields and the summary's sizes and report.  The ale model
    and the fd moving-mesh model each derive from it and add their flow (MovingMesh's make_flow)."""

    moving: MovingMesh

    def resolved_top(self) -> float:
        return self.moving.resolved_top()

    def build(self, integrator) -> None:
        self.moving.build(integrator.hold_gaps)

    def initial_velocities(self) -> list[np.ndarray]:
        return list(self.moving.history.velocities)

    def start_step(self, gaps: np.ndarray, velocities: np.ndarray) -> None:
        self.moving.start_step(gaps, velocities)

    def time_step(self) -> float:
        return self.moving.step_length()

    def next_time(self) -> float:
        return self.moving.next_time()

    def finished(self, end_time: float) -> bool:
        return self.moving.finished(end_time)

    def previous_time_step(self) -> float | None:
        return self.moving.previous_time_step()

    def linearised_force(self, prediction: Prediction) -> FluidForce:
        return self.moving.linearise(prediction)

    def complete(self, velocities: np.ndarray, time_now: float) -> StepRecord:
        record = self.moving.complete(velocities)
        self.step, self.ended_short = self.moving.step, self.moving.ended_short
        return record

    def checkpoint_state(self) -> tuple[dict, dict]:
        return self.moving.checkpoint_state()

    def restore(self, state: dict, arrays) -> None:
        self.moving.restore(state, arrays)

    def open_outputs(self, out_dir: Path, restart: bool, fields: bool, sides: dict | None = None) -> None:
        if fields:
            self.moving.open_fields(out_dir)

    def write_fields(self, time_now: float) -> None:
        self.moving.write_fields(time_now)

    def close_outputs(self) -> None:
        self.moving.close_fields()

    def destroy(self) -> None:
        self.moving.destroy()

    def sizes(self) -> dict:
        return self.moving.sizes(self.steady)

    def report(self) -> dict:
        """Cost, remeshing and near-contact details for summary.json [SI]."""
        return self.moving.report(self.steady, self.loop_seconds)

