"""The boundary-fitted ALE model (`--model ale`): the time loop (also the fd model's on its moving mesh:
models/fd/moving.py puts the fd constraint in the spheres, meshed inside, in place of the holes; make_flow).

The N spheres on the axis (bodies.scene_bodies, sphere 1 the lowest) are holes in one mesh, each
with its own mesh extension and unit flow response (motion.py, flow.py); every per-sphere value is
an array over them, the added mass an N x N matrix.  One fluid step of length dt:

1. predict the sphere centres at t_{n+1} (AB2 from the last two velocities); the mesh puts its
   spheres there, placed by flow_model.flow_gaps with the holds below (a held sphere stays put);
2. if the moved mesh would have a triangle of quality below min_quality, remesh around those
   positions and carry the flow over (remesh below), then move the mesh and set its velocity;
3. assemble the step's matrix on the moved mesh; N + 1 solves give the flow for the reference
   velocities U_ref and the response to a unit velocity of each sphere (numerics.ale.factorisation:
   "every-step" factorises the matrix every step; "reuse", the default, solves by flexible GMRES
   preconditioned with the factors of an earlier step and factorises when that pays: flow.py);
4. the variational forces are affine in the new velocities U, F_i = F*_i - c sum_j M_ij (U_j - U_ref,j)
   with M = -(dF_i/dU_j) / c: hand F* and M to the shared BodyIntegrator, which sub-cycles through
   the contacts and blends f_sim with f_thr below delta_sl as every model does;
5. read back U and keep the step's field x_ref + sum_k (U_k - U_ref,k) x_unit,k.

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
(transfer.py), which also keeps the fluid's momentum.  Every new vertex is given the past positions
x - sum_k (z_k^{n+1} - z_k^j) psi_k(x) e_z of the new mesh's own motion law, so the nodal time
derivative and the mesh velocity stay consistent across the remesh.

Held spheres (every body held: motion.mode = "fixed", and fixed upper spheres) are solved for
their steady state directly: steady Navier-Stokes by Newton in a stream (Cd), steady Stokes when
only sphere 1's surface moves (the quasi-steady approach of Brenner's check, defined only at
Re -> 0).  numerics.ale.fixed_solver = "march" time-marches them instead.
"""
from __future__ import annotations

import math
import resource
import time
import dataclasses
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from ...bodies import scene_bodies
from ...fem.functions import CheckpointMismatch, gather_history, scatter_history
from ...fem.mesh import SPHERE_TAGS, check_size, create_mesh
from ...fem.solver import SolverError
from ...errors import RunDiverged
from ...flow_model import FlowModel, flow_gaps, nearest_gap
from ...kinematics import FluidForce, Prediction
from ...output import CheckpointError, body_array, per_body, segment_path
from ...motion import is_stream
from ...scene import pair_diameter
from .domain import AleDomain, domain_for, is_steady, step_limits, time_step
from .fields import MovingFieldWriter
from .flow import SphereFlow
from .motion import MeshMotion
from ...fem.transfer import DivergenceFreeProjection, SerialField, interpolate_from

REMESH_QUANTUM = 1e-6  # [D] a new mesh is made around the spheres' positions rounded to this (AleModel.remesh)


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


@dataclass
class Kinematics:
    """The sphere velocities U [m/s] the flow was given and the mesh's sphere centres z [m] at the
    last time levels, newest first, each an array over the spheres (sphere 1 first), and the time
    t_n [s] they reach after `step` steps, the last of length `last_step` [s] (0 before the first)."""

    velocities: list
    centers: list
    step: int = 0
    time: float = 0.0
    last_step: float = 0.0

    def push(self, velocities: np.ndarray, centers: np.ndarray, time_now: float) -> None:
        self.step += 1
        self.last_step, self.time = time_now - self.time, time_now
        self.velocities = [velocities] + self.velocities[:-1]
        self.centers = [centers] + self.centers[:-1]

    def reference_velocity(self, bdf: tuple) -> np.ndarray:
        """U_ref: dV/dt ~ c (U - U_ref) [m/s], with the coming step's BDF coefficients `bdf`."""
        return -sum(a * v for a, v in zip(bdf[1:], self.velocities)) / bdf[0]

    def center_rate(self, centers: np.ndarray, bdf: tuple, dt: float) -> np.ndarray:
        """The BDF rates of the mesh's sphere centres if they move to `centers` at the end of a step dt [m/s]."""
        return (bdf[0] * centers + sum(a * z for a, z in zip(bdf[1:], self.centers))) / dt


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
    longest_step: float = 0.0  # [s] (numerics.ale.adaptive_step)
    min_mesh_gap: float = math.inf
    max_unknowns: int = 0
    min_mesh_pair_gap: float = math.inf  # the smallest gap between two of the mesh's spheres [m]
    # of the step matrix, over the meshes already left (report() adds the current mesh's)
    factorisations: int = 0
    krylov_iterations: int = 0
    assembly_s: float = 0.0
    factorise_s: float = 0.0
    solve_s: float = 0.0


class AleModel(FlowModel):
    name = "ale"
    resolved = True
    divergences = (SolverError,)
    fields_at_end = True

    def __init__(self, scene, comm):
        super().__init__(scene, comm)
        self.writer: MovingFieldWriter | None = None
        self.domain: AleDomain = domain_for(scene, self.name)
        check_size(self.domain.spec(self.domain.initial_centers), f"numerics.{self.name}")
        self.steady = is_steady(scene)
        self.dt = self.cfl_step = time_step(scene)  # the coming step; the shortest (adaptive_step) [s]
        self.step_limits = step_limits(scene)
        self.adaptive = self.settings.adaptive_step  # steps of their own length (StepLimits)
        self.mesh = self.motion = self.flow = None
        self.stats = Statistics()
        self.bodies = scene_bodies(scene)
        count = len(self.bodies)
        self.sphere_tags = SPHERE_TAGS[:count]
        self.diameters = np.array([body.diameter for body in self.bodies])
        self.radii = np.array(self.domain.radii)
        self.holds = self.domain.holds  # the contact model's where it holds the flow (build)
        self.last_force = (np.zeros(count), np.zeros((count, count)))  # F* [N] and the added mass [kg]
        self._forces = None  # rank 0's writer of ale_forces.csv (run.py owns it: a side file)

    # -- meshes ------------------------------------------------------------------------------
    def build_mesh(self, centers: np.ndarray, cache: bool = True) -> tuple:
        """(mesh, motion, flow) with the spheres centred at z = centers [m]."""
        mesh, _, facet_tags = create_mesh(self.comm, self.domain.spec(centers), cache=cache)
        motion = MeshMotion(mesh, facet_tags, centers, sphere_tags=self.sphere_tags)
        flow = self.make_flow(mesh, facet_tags, motion, centers)
        self.stats.max_unknowns = max(self.stats.max_unknowns, flow.unknowns)
        return mesh, motion, flow

    def make_flow(self, mesh, facet_tags, motion: MeshMotion, centers: np.ndarray):
        """The flow on a new mesh around the spheres centred at `centers` [m]: no-slip on their surfaces."""
        scene, domain, ale = self.scene, self.domain, self.settings
        return SphereFlow(mesh, facet_tags, domain.sides, scene.liquid.density, scene.liquid.viscosity, self.dt,
                          motion.velocity, inflow_speed=domain.inflow_speed, order=ale.time_order,
                          sphere_tags=self.sphere_tags, factorisation=ale.factorisation,
                          reuse_iterations=ale.reuse_iterations, krylov_rtol=ale.krylov_rtol,
                          factorisation_cost=ale.factorisation_cost)

    @property
    def reuses_factors(self) -> bool:
        """The step's matrix is solved with an earlier step's factors (numerics.ale.factorisation = "reuse")."""
        return self.settings.factorisation == "reuse"

    def _with_tallies(self, stats: Statistics, flow: SphereFlow) -> None:
        """Add a flow's (a mesh's) solver counts and times to `stats`: the run's before the flow is dropped."""
        for key in ("factorisations", "krylov_iterations", "assembly_s", "factorise_s", "solve_s"):
            setattr(stats, key, getattr(stats, key) + getattr(flow, key))

    def remesh(self, center: np.ndarray, quality: float) -> None:
        """Mesh around the spheres centred at `center` [m] and carry the flow's history over.

        gmsh meshes the spheres at `center` rounded to REMESH_QUANTUM D (the new mesh then moves to `center`):
        its triangles change with the last bits of its input, and those differ between a serial run and one on
        2 ranks (1e-13 m in case 3), whose new meshes then differed by two triangles and their answers by 1e-5."""
        start = time.perf_counter()
        k = self.kinematics
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
        reuse = self.reuses_factors
        projection = None
        try:
            for level, (old_state, new_state) in enumerate(zip(old_flow.states, flow.states)):
                old_motion.move_to(k.centers[level])
                before = old_flow.momentum(old_state)
                # the new mesh where its own motion law puts it at that time level (if that is a valid mesh), and
                # only then the old field sampled at its nodes: sampled where the new mesh was built (at t_n+1),
                # each level's field came out shifted against its sphere by the step's travel (0.05 D at the fd
                # default; case 3's fall lost 2 % of its speed over three new meshes at delta_sl 0.1)
                motion.move_to(k.centers[level] if motion.quality(k.centers[level] - at) > 0.0 else center)
                interpolate_from(SerialField(old_state, tolerance), new_state)
                interpolated = flow.momentum(new_state)
                flow.set_boundary_values(k.velocities[level])
                if projection is None:
                    projection = DivergenceFreeProjection(flow.W, flow.bcs, reuse=reuse,
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
            step=k.step, time=k.time, gap=float(center[0] - self.radii[0]), quality=quality,
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

    def sphere_volume(self, flow: SphereFlow) -> float:
        """The volume of the mesh's polygonal sphere: the domain's cylinder less the liquid [m^3]."""
        return math.pi * self.domain.radius**2 * self.domain.height - flow.fluid_volume()

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

    # -- the FlowModel interface ------------------------------------------------------------------
    def build(self, integrator) -> None:
        start = time.perf_counter()
        domain = self.domain
        order = self.settings.time_order
        # under its near-wall correction the contact model's holds (delta_sl D1, delta_sl 2a*): it adds the
        # lubrication the flow misses below them; elsewhere (a hold of 0) the ale model's own hold_delta
        self.holds = tuple(contact or own for own, contact in zip(self.holds, integrator.hold_gaps))
        centers = np.array(domain.initial_centers)
        self.mesh, self.motion, self.flow = self.build_mesh(centers)
        velocities = np.array([body.start_velocity for body in self.bodies])  # as the integrator's
        self.kinematics = Kinematics([velocities.copy() for _ in range(order)], [centers.copy() for _ in range(order)])
        self.flow.set_uniform((0.0, domain.inflow_speed))
        self.stats.setup_s = time.perf_counter() - start

    def initial_velocities(self) -> list[np.ndarray]:
        return list(self.kinematics.velocities)

    def next_time(self) -> float:
        if self.adaptive:
            return self.kinematics.time + self.dt
        return super().next_time()  # (n + 1) dt, as every constant-step model

    def finished(self, end_time: float) -> bool:
        if self.adaptive:
            return self.kinematics.time >= end_time - 1e-9 * self.cfl_step
        return super().finished(end_time)

    def previous_time_step(self) -> float | None:
        k = self.kinematics
        return k.last_step if self.adaptive and k.last_step else None

    def linearised_force(self, prediction: Prediction) -> FluidForce:
        k, settings = self.kinematics, self.settings
        t_next = self.next_time()
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
        if np.any(center != k.centers[0]):
            quality = self.motion.quality(center - self.motion.reference_center)
            if quality < settings.min_quality:
                self.remesh(center, quality)
                remeshed = True
        self.stats.held_steps += held
        self.flow.set_time_step(self.dt, self.previous_time_step())
        self.motion.move_to(center)
        self.motion.set_rates(k.center_rate(center, self.flow.bdf, self.dt))
        self.stats.min_mesh_gap = min(self.stats.min_mesh_gap, gap)
        reference = k.reference_velocity(self.flow.bdf)
        start = time.perf_counter()
        extrapolated = sum(beta * v for beta, v in zip(self.flow.ext, k.velocities))
        force, slope = self.flow.step(reference, extrapolated_velocity=extrapolated)
        self.stats.factorisation_s += time.perf_counter() - start
        added_mass = -slope / self.flow.c  # M_ij = -(dF_i/dU_j) / c
        if not (np.all(np.isfinite(force)) and np.all(np.isfinite(added_mass))):
            raise FloatingPointError(f"the fluid force became {force} N at t = {t_next:.6g} s")
        self.last_force = (force, added_mass)
        self._pending = (t_next, center, gap, reference, force, slope, added_mass, quality, remeshed, prediction)
        self._integrator_start = time.perf_counter()
        return FluidForce(explicit=force, added_mass=added_mass)

    def complete(self, velocities: np.ndarray, time_now: float) -> None:
        self.stats.integrator_s += time.perf_counter() - self._integrator_start
        t_next, center, gap, reference, force, slope, added_mass, quality, remeshed, prediction = self._pending
        velocity = np.array(velocities, dtype=float)  # the flow's own copy of the integrator's
        change = velocity - reference
        self.flow.commit(change)
        if self.adaptive:
            self.dt = self._next_step(velocity, prediction)
        self.kinematics.push(velocity, center, t_next)
        self.step = self.kinematics.step
        self._record_force(t_next, gap, force + slope @ change, added_mass,
                           quality if remeshed else self.motion.quality(self.motion.shift), remeshed)

    def _next_step(self, velocity: np.ndarray, prediction: Prediction) -> float:
        """The coming step [s] (domain.step_limits) from the step just made, which ends at `velocity`, with
        the spheres' predicted nearest gap (to the wall or a neighbour: where they are, not where the mesh
        holds them)."""
        k = self.kinematics
        gap = nearest_gap(prediction.gaps, self.diameters, self.scene.wall.present)
        step = self.step_limits.after([velocity, *k.velocities[:2]], self.dt, k.last_step, gap)
        self.stats.longest_step = max(self.stats.longest_step, step)
        return step

    def _record_force(self, t, gap, force, added_mass, quality, remeshed) -> None:
        surface = self.flow.surface_force()  # collective: every rank, though rank 0 alone writes
        if self._forces is None:
            return
        values = [t, gap, *self.mesh_pair_gaps(self.kinematics.centers[0]), *np.ravel(force), *np.ravel(surface),
                  *np.ravel(added_mass), quality, int(remeshed)]
        self._forces(dict(zip(self._forces.columns, values)))

    def steady_force(self) -> FluidForce:
        """The held spheres' steady state (SphereFlow.steady), held from the start to the end time: each
        surface at its body's velocity (motion.velocity, second_sphere.velocity)."""
        start = time.perf_counter()
        surfaces = np.array([body.start_velocity for body in self.bodies])
        force = self.flow.steady(surfaces, convection=is_stream(self.scene))
        self.stats.factorisation_s += time.perf_counter() - start
        count = len(self.bodies)
        self.last_force = (force, np.zeros((count, count)))
        centers = np.array(self.domain.initial_centers)
        self.stats.min_mesh_gap = float(centers[0] - self.radii[0])
        self.stats.min_mesh_pair_gap = min(self.mesh_pair_gaps(centers), default=math.inf)
        return FluidForce(*self.last_force)

    def complete_steady(self, time_now: float) -> None:
        self.kinematics.step = self.step = 1
        force, no_added_mass = self.last_force
        self._record_force(time_now, self.stats.min_mesh_gap, force, no_added_mass,
                           self.motion.quality(self.motion.shift), False)

    # -- checkpoints: the mesh's reference centre (remade by gmsh on restart), the flow's history by dof
    # coordinates on the mesh where it is now, the mesh's and the sphere's past, the statistics -----
    def checkpoint_state(self) -> tuple[dict, dict]:
        k = self.kinematics
        self.flow.renew()  # reused factors: the run goes on with fresh ones, as a restart from here does
        arrays = gather_history(self.flow.states)
        stats = dataclasses.replace(self.stats)  # with the current mesh's tallies: a restart starts a new mesh's
        self._with_tallies(stats, self.flow)
        stats = asdict(stats)
        state = {"dt": self.cfl_step, "step_length": self.dt, "time": k.time, "last_step": k.last_step,
                 "mesh_center": self.motion.reference_center.tolist(),
                 "velocities": [v.tolist() for v in k.velocities], "centers": [z.tolist() for z in k.centers],
                 "kinematics_step": k.step, "last_force": [x.tolist() for x in self.last_force],
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
        step = state["kinematics_step"]
        k = self.kinematics = Kinematics([body_array(v) for v in state["velocities"]],
                                         [body_array(z) for z in state["centers"]], step=step,
                                         time=state.get("time", step * self.cfl_step),
                                         last_step=state.get("last_step", self.cfl_step if step else 0.0))
        self.dt = state.get("step_length", self.cfl_step)
        self.motion.move_to(k.centers[0])
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

    # -- outputs ----------------------------------------------------------------------------------
    def side_files(self) -> dict[str, tuple]:
        return {"ale_forces.csv": force_columns(len(self.diameters))}

    def open_outputs(self, out_dir: Path, restart: bool, fields: bool, sides: dict | None = None) -> None:
        if fields:
            path = self.comm.bcast(segment_path(out_dir) if self.comm.rank == 0 else None, root=0)
            self.writer = MovingFieldWriter(self.comm, path)
        self._forces = (sides or {}).get("ale_forces.csv")

    def write_fields(self, time_now: float) -> None:
        self.writer.write(self.flow.now, time_now)

    def close_outputs(self) -> None:
        if self.writer is not None:
            self.writer.close()

    def destroy(self) -> None:
        if self.flow is not None:
            self.flow.destroy()

    # -- what the summary says --------------------------------------------------------------------
    def sizes(self) -> dict:
        cells = self.mesh.topology.index_map(2).size_global
        return {"cells": cells, "unknowns": self.flow.unknowns, "max_unknowns": self.stats.max_unknowns,
                "dt": None if self.steady else self.cfl_step, "fine_size": self.domain.fine_size}

    def report(self) -> dict:
        """Cost, remeshing and near-contact details for summary.json [SI]."""
        stats = dataclasses.replace(self.stats)  # with the current mesh's solver tallies
        self._with_tallies(stats, self.flow)
        steps = max(self.kinematics.step, 1)
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
            "solver": "steady" if self.steady else "march",
            "timings_s": {"setup": stats.setup_s, "steps": self.loop_seconds,
                          "factorise_and_solve": stats.factorisation_s,
                          "integrator": stats.integrator_s, "remesh": stats.remesh_s,
                          "assembly": stats.assembly_s, "factorisation": stats.factorise_s,
                          "solves": stats.solve_s},
            "time_per_step_s": self.loop_seconds / steps,
            "factorisation": "reuse" if self.reuses_factors else "every-step",
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

