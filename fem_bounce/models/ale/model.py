"""The boundary-fitted ALE model (`--model ale`): the time loop.

One fluid step of length dt (motion.MeshMotion, flow.SphereFlow):

1. predict the sphere centre at t_{n+1} (AB2 from the last two velocities); the mesh puts its
   sphere there, but never closer to the wall than hold_delta D (see below);
2. if the moved mesh would have a triangle of quality below min_quality, remesh around that
   position and carry the flow over (remesh below), then move the mesh and set its velocity;
3. assemble and factorise the step's matrix on the moved mesh; two back-solves give the flow
   for the reference sphere velocity U_ref and the response to a unit velocity;
4. the variational force is affine in the new sphere velocity U, F(U) = F* - m_a c (U - U_ref)
   with m_a = -(dF/dU) / c: hand F* and m_a to the shared SphereIntegrator, which sub-cycles
   through the contact and blends f_sim with f_thr below delta_sl as every model does;
5. read back U and keep the step's field x_ref + (U - U_ref) x_unit.

Near contact.  The gap soon becomes thinner than a step's travel V dt, and thinner than any
mesh one would pay for; below delta_sl the contact model has already handed the force to
f_thr (H = 0.9933 at delta = 0.1, 0.99966 at delta = 0.04).  So the mesh stops following the
sphere at the gap hold_delta D: the flow's sphere stays there, its surface still moving with
the sphere's velocity U (a quasi-steady squeeze, like the Brenner check), while the
integrator carries the real sphere through the contact and back; when it rises above the
hold gap again the mesh follows it.  The f_sim computed at the held gap is wrong by a factor
of order lambda(delta) / lambda(hold_delta), weighted by 1 - H; at the default hold 0.02 D
that is below 1e-4 of f_thr.  With hold_delta = 0 the mesh follows the predicted positions
until a step would put the sphere through the wall (the run then stops, saying how close it
got); in Li's case 3 it reached 0.004-0.007 D at 8-32 cells/D without failing (the gap keeps
min_gap_cells triangles across, and P2 holds the parabolic lubrication profile exactly: the
steady force stays within 1 % of Brenner's down to 0.01 D), overshooting the real sphere,
whose microsecond reversal in the contact no fluid step can see.  Nothing is gained: f_sim
has no weight there.

Remeshing.  gmsh meshes the half-plane around the sphere's new position; the flow's BDF
history is carried over by evaluating each old level on the old mesh where that level lived
and projecting it onto divergence-free fields (transfer.py), which also keeps the fluid's
momentum.  Every new vertex is given the past positions x - (z^{n+1} - z^k) psi(x) e_z of
the new mesh's own motion law, so the nodal time derivative and the mesh velocity stay
consistent across the remesh.

A held sphere (motion.mode = "fixed") is solved for its steady state directly: steady
Navier-Stokes by Newton in a stream (Cd), steady Stokes when only its surface moves (the
quasi-steady approach of Brenner's check, defined only at Re -> 0).  numerics.ale.fixed_solver
= "march" time-marches it instead.
"""
from __future__ import annotations

import csv
import math
import resource
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

from ...fem.mesh import create_mesh
from ...fem.solver import SolverError
from ...errors import RunDiverged
from ...sphere import FluidForce
from ..fd.domain import steps_to
from .domain import AleDomain, domain_for, is_steady, is_stream, time_step
from .fields import MovingFieldWriter
from .flow import SphereFlow
from .motion import MeshMotion
from .transfer import DivergenceFreeProjection, SerialField, interpolate_from

FORCE_COLUMNS = ("t", "mesh_gap", "f_variational", "f_surface", "added_mass", "min_quality", "remeshed")


@dataclass
class Kinematics:
    """The sphere velocities U [m/s] the flow was given and the mesh's sphere centres z [m] at the
    last time levels, newest first; `bdf` are the time scheme's coefficients."""

    bdf: tuple
    velocities: list
    centers: list
    step: int = 0

    def push(self, velocity: float, center: float) -> None:
        self.step += 1
        self.velocities = [velocity] + self.velocities[:-1]
        self.centers = [center] + self.centers[:-1]

    @property
    def reference_velocity(self) -> float:
        """U_ref: dV/dt ~ c (U - U_ref) [m/s]."""
        return -sum(a * v for a, v in zip(self.bdf[1:], self.velocities)) / self.bdf[0]

    def center_rate(self, center: float, dt: float) -> float:
        """The BDF rate of the mesh's sphere centre if it moves to `center` now [m/s]."""
        return (self.bdf[0] * center + sum(a * z for a, z in zip(self.bdf[1:], self.centers))) / dt


@dataclass
class Remesh:
    """One remeshing: when, why, and what the transfer did to the fluid's momentum [SI]."""

    step: int
    time: float
    gap: float  # of the mesh's sphere, after the move [m]
    quality: float  # the worst triangle had the move been made on the old mesh
    cells: int
    momentum_old: float  # of u^n on the old mesh [kg m/s]
    momentum_interpolated: float  # on the new mesh, straight after interpolation
    momentum_projected: float  # after the divergence-free projection
    sphere_volume_old: float  # of the old mesh's polygonal sphere [m^3]: a closed domain's fluid momentum
    sphere_volume: float  # is -rho V_h U exactly, so it changes by the ratio of these two
    seconds: float


@dataclass
class Statistics:
    remeshes: list = field(default_factory=list)
    factorisation_s: float = 0.0
    integrator_s: float = 0.0
    remesh_s: float = 0.0
    setup_s: float = 0.0
    steps_s: float = 0.0
    held_steps: int = 0
    min_mesh_gap: float = math.inf
    max_unknowns: int = 0


class AleModel:
    name = "ale"
    resolved = True

    def __init__(self, scene, comm):
        self.scene = scene
        self.comm = comm
        self.settings = scene.numerics.ale
        self.domain: AleDomain = domain_for(scene)
        self.steady = is_steady(scene)
        self.dt = time_step(scene)
        self.mesh = self.motion = self.flow = None
        self.stats = Statistics()
        self.last_force = (0.0, 0.0)
        self._force_file = None

    # -- meshes ------------------------------------------------------------------------------
    def build(self, center: float, cache: bool = True) -> tuple:
        """(mesh, motion, flow) with the sphere centred at z = center [m]."""
        scene, domain = self.scene, self.domain
        mesh, _, facet_tags = create_mesh(self.comm, domain.spec(center), cache=cache)
        motion = MeshMotion(mesh, facet_tags, center)
        flow = SphereFlow(mesh, facet_tags, domain.sides, scene.liquid.density, scene.liquid.viscosity, self.dt,
                          motion.velocity, inflow_speed=domain.inflow_speed, order=self.settings.time_order)
        self.stats.max_unknowns = max(self.stats.max_unknowns, flow.unknowns)
        return mesh, motion, flow

    def remesh(self, center: float, quality: float) -> None:
        """Mesh around the sphere centred at `center` [m] and carry the flow's history over."""
        start = time.perf_counter()
        k = self.kinematics
        old_motion, old_flow = self.motion, self.flow
        try:
            mesh, motion, flow = self.build(center, cache=False)
        except Exception as err:  # noqa: BLE001 -- gmsh raises plain Exception; the run ends cleanly
            delta = (center - self.domain.sphere_radius) / self.scene.sphere.diameter
            raise RunDiverged(f"remeshing at gap {delta:.4g} D failed: {err}") from err
        tolerance = 1e-9 * self.scene.sphere.diameter
        momenta = []
        volumes = [self.sphere_volume(old_flow), self.sphere_volume(flow)]
        for level, (old_state, new_state) in enumerate(zip(old_flow.states, flow.states)):
            old_motion.move_to(k.centers[level])
            before = old_flow.momentum(old_state)
            interpolate_from(SerialField(old_state, tolerance), new_state)
            # the new mesh where its own motion law puts it at that time level (if that is a valid mesh)
            motion.move_to(k.centers[level] if motion.quality(k.centers[level] - center) > 0.0 else center)
            interpolated = flow.momentum(new_state)
            flow.set_boundary_values(k.velocities[level])
            projection = DivergenceFreeProjection(flow.W, flow.bcs)
            try:
                projection.project(new_state)
            finally:
                projection.destroy()
            momenta.append((before, interpolated, flow.momentum(new_state)))
        motion.move_to(center)
        old_flow.destroy()
        self.mesh, self.motion, self.flow = mesh, motion, flow
        seconds = time.perf_counter() - start
        self.stats.remesh_s += seconds
        self.stats.remeshes.append(Remesh(
            step=k.step, time=k.step * self.dt, gap=center - self.domain.sphere_radius, quality=quality,
            cells=mesh.topology.index_map(2).size_global, momentum_old=momenta[0][0],
            momentum_interpolated=momenta[0][1], momentum_projected=momenta[0][2], sphere_volume_old=volumes[0],
            sphere_volume=volumes[1], seconds=seconds))

    def resolved_top(self) -> float:
        """The height [m] up to which the mesh is refined: a rising sphere is stopped there."""
        return self.domain.refined.z_max

    def sphere_volume(self, flow: SphereFlow) -> float:
        """The volume of the mesh's polygonal sphere: the domain's cylinder less the liquid [m^3]."""
        return math.pi * self.domain.radius**2 * self.domain.height - flow.fluid_volume()

    # -- one step -------------------------------------------------------------------------------
    def next_center(self, integrator) -> tuple[float, bool]:
        """(z, held): where the mesh puts the sphere at t_{n+1} [m], AB2 from the sphere's velocities, and
        whether the hold gap stopped it there; a fixed sphere stays put."""
        if self.scene.motion.mode == "fixed":
            return self.domain.initial_center, False
        v = self.kinematics.velocities
        mean_velocity = 1.5 * v[0] - 0.5 * v[1] if len(v) > 1 else v[0]
        predicted = self.domain.sphere_radius + integrator.gap + self.dt * mean_velocity
        center = self.domain.mesh_center(predicted)
        return center, center > predicted

    def step(self, integrator) -> None:
        k, settings = self.kinematics, self.settings
        t_next = (k.step + 1) * self.dt
        center, held = self.next_center(integrator)
        gap = center - self.domain.sphere_radius
        if gap <= 0.0:
            raise RunDiverged(f"the mesh cannot follow the sphere: the step to t = {t_next:.6g} s would put it "
                              f"{-gap:.3g} m into the wall (smallest mesh gap reached "
                              f"{self.stats.min_mesh_gap / self.scene.sphere.diameter:.4g} D)")
        quality, remeshed = math.inf, False
        if center != k.centers[0]:
            quality = self.motion.quality(center - self.motion.reference_center)
            if quality < settings.min_quality:
                self.remesh(center, quality)
                remeshed = True
        self.stats.held_steps += held
        self.motion.move_to(center)
        self.motion.rate.value = k.center_rate(center, self.dt)
        self.stats.min_mesh_gap = min(self.stats.min_mesh_gap, gap)
        reference = k.reference_velocity
        start = time.perf_counter()
        force, slope = self.flow.step(reference)
        self.stats.factorisation_s += time.perf_counter() - start
        added_mass = -slope / self.flow.c
        if not (math.isfinite(force) and math.isfinite(added_mass)):
            raise FloatingPointError(f"the fluid force became {force} N at t = {t_next:.6g} s")
        self.last_force = (force, added_mass)
        start = time.perf_counter()
        integrator.advance(t_next, FluidForce(explicit=force, added_mass=added_mass))
        self.stats.integrator_s += time.perf_counter() - start
        velocity = integrator.velocity
        self.flow.commit(velocity - reference)
        k.push(velocity, center)
        self._record_force(t_next, gap, force + slope * (velocity - reference), added_mass,
                           quality if remeshed else self.motion.quality(self.motion.shift), remeshed)

    def _record_force(self, t, gap, force, added_mass, quality, remeshed) -> None:
        surface = self.flow.surface_force()
        if self._force_file is not None:
            self._force_writer.writerow([f"{x:.10g}" for x in (t, gap, force, surface, added_mass, quality)]
                                        + [int(remeshed)])

    # -- the run --------------------------------------------------------------------------------
    def run(self, integrator, progress, out_dir=None, restart=False) -> dict:
        if restart:
            raise RunDiverged("the ale model writes no checkpoints: it cannot --restart")
        start = time.perf_counter()
        scene, domain = self.scene, self.domain
        self.mesh, self.motion, self.flow = self.build(domain.initial_center)
        velocity = scene.motion.velocity if scene.motion.mode != "free" else 0.0
        order = self.settings.time_order
        self.kinematics = Kinematics(self.flow.bdf, [velocity] * order, [domain.initial_center] * order)
        self.flow.set_uniform((0.0, domain.inflow_speed))
        self.stats.setup_s = time.perf_counter() - start
        writer = None
        root = self.comm.rank == 0
        if out_dir is not None and self.settings.output_every:
            writer = MovingFieldWriter(self.comm, Path(out_dir) / "fields-000.xdmf")
        if out_dir is not None and root:
            self._force_file = open(Path(out_dir) / "ale_forces.csv", "w", newline="")
            self._force_writer = csv.writer(self._force_file)
            self._force_writer.writerow(FORCE_COLUMNS)
        try:
            if self.steady:
                self.solve_steady(integrator, progress)
            else:
                self.march(integrator, progress, writer)
            if writer is not None and (self.steady or self.kinematics.step % self.settings.output_every):
                writer.write(self.flow.now, integrator.time)  # the final state too
            return {"steps": self.kinematics.step, "sizes": self.sizes(), "extra": {"ale": self.report()}}
        except (SolverError, FloatingPointError) as err:
            raise RunDiverged(f"{err} (at step {self.kinematics.step})") from err
        finally:
            if writer is not None:
                writer.close()
            if self._force_file is not None:
                self._force_file.close()
            self.flow.destroy()

    def march(self, integrator, progress, writer) -> None:
        n_steps = steps_to(self.scene.run.end_time, self.dt)
        if writer is not None:
            writer.write(self.flow.now, 0.0)
        start = time.perf_counter()
        while self.kinematics.step < n_steps and not integrator.done:
            self.step(integrator)
            progress(integrator.time, self.kinematics.step, integrator.gap, integrator.velocity)
            if writer is not None and self.kinematics.step % self.settings.output_every == 0:
                writer.write(self.flow.now, integrator.time)
        self.stats.steps_s = time.perf_counter() - start

    def solve_steady(self, integrator, progress) -> None:
        """The held sphere's steady state; the integrator then holds it to end_time with that force."""
        start = time.perf_counter()
        force = self.flow.steady(self.scene.motion.velocity, convection=is_stream(self.scene))
        self.stats.factorisation_s += time.perf_counter() - start
        self.last_force = (force, 0.0)
        self.stats.min_mesh_gap = self.domain.initial_center - self.domain.sphere_radius
        integrator.advance(self.scene.run.end_time, FluidForce(explicit=force, added_mass=0.0))
        self.kinematics.step = 1
        self._record_force(integrator.time, self.stats.min_mesh_gap, force, 0.0,
                           self.motion.quality(0.0), False)
        progress(integrator.time, 1, integrator.gap, integrator.velocity, force=True)

    # -- what the summary says --------------------------------------------------------------------
    def sizes(self) -> dict:
        cells = self.mesh.topology.index_map(2).size_global
        return {"cells": cells, "unknowns": self.flow.unknowns, "max_unknowns": self.stats.max_unknowns,
                "dt": None if self.steady else self.dt, "fine_size": self.domain.fine_size}

    def report(self) -> dict:
        """Cost, remeshing and near-contact details for summary.json [SI]."""
        stats = self.stats
        steps = max(self.kinematics.step, 1)
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0  # Linux reports kB
        diameter = self.scene.sphere.diameter
        force, added_mass = self.last_force
        return {
            "solver": "steady" if self.steady else "march",
            "timings_s": {"setup": stats.setup_s, "steps": stats.steps_s, "factorise_and_solve": stats.factorisation_s,
                          "integrator": stats.integrator_s, "remesh": stats.remesh_s},
            "time_per_step_s": stats.steps_s / steps,
            "factorisations_per_step": 1,  # plus two per remesh (the projections)
            "remesh_count": len(stats.remeshes),
            "remeshes": [asdict(r) for r in stats.remeshes],
            "hold_delta": self.settings.hold_delta,
            "held_steps": stats.held_steps,
            "min_mesh_delta": stats.min_mesh_gap / diameter,
            "last_force_N": force,
            "added_mass_over_displaced": added_mass / self.scene.displaced_mass,
            "peak_memory_bytes": self.comm.allreduce(peak),
        }
