"""The three-dimensional fictitious-domain model (`--model fd3d`): one sphere and a wall, head-on or oblique, as a
FlowModel (fem_bounce.flow_model).

The flow is flow.PenalisedFlow3D on the half box y >= 0: the motion stays in the plane of incidence x-z, so the flow is
symmetric about the plane y = 0 through the path (for the steady wake of a sphere below Re ~210, which the scenes here
are: docs/validation.md section 14).  numerics.fd3d.box = "whole" meshes the whole box instead: the sphere still moves
in the plane (the body integrator's equations are the plane's), and the flow's force across the plane (F_y) and its
torque about the axes in it (T_x, T_z), which the half box holds at zero, are measured at each step (`report`'s
out_of_plane: their peaks, and the velocity across the plane and the spin their impulses would have given the sphere):
the check that the symmetry holds.  A head-on bounce moves the sphere along z only (the rigid mode U_z; the box also
keeps x -> -x, so U_x and Omega_y stay unexcited); an oblique one (Scene.oblique: a tangential velocity, a spin or
gravity's tilt) also along the wall and about y (U_x, Omega_y), its force along the wall and torque handed to the body
integrator's tangential equations (oblique.TangentialMotion) with the whole added mass over the three
(kinematics.PlaneForce).  The box is numerics.fd3d.far_field D wide on each side of the sphere and as high above the
release's top; each new mesh centres it on the sphere along the wall (the liquid beyond the old box taken at rest:
transfer.py).  The wall is no-slip (slip when wall.present is false), the other sides slip, as the axisymmetric models'
unbounded domain.

Two meshes (numerics.fd3d.mesh; mesh.create_box_mesh), fine only in a patch around the sphere and in the gap below:

- "moving" (the default): the sphere's surface is a surface of the mesh (BoxSpec.conforming, its polyhedron's
  volume restored to the sphere's: mesh.restore_ball_volume), the penalty holds the ball's cells whole
  (indicator.ConformingBall: the velocity's kink lies on the cells' faces, where the P2 space has it), and the mesh
  moves with the sphere (motion.MeshMotion3D: the ball and a layer of cells around it rigidly, the rest stretched
  by a harmonic extension), so the step's matrix changes only where the mesh outside deforms: its LU factors
  precondition FGMRES over many steps (flow.PenalisedFlow3D's "reuse", factorised again when the iterations make
  that cheaper: fem.solver.ReusedFactorOperator).  The flow takes the non-conservative ALE form (convection by
  u* - w).  A new mesh is made where the sphere will be when it has moved patch_margin / 2 D from where the mesh
  was made, or the gap under it has halved or doubled, or the motion would bring its worst tetrahedron below half
  the quality of the worst as made (a sphere held near the wall and sliding shears the few cells between its
  rigid layer and the wall: at 6 cells/D they had turned inside out within 0.17 D); surface_refinement makes the
  surface's cells finer;
- "fixed": the sphere moves through the mesh, whose fine shell covers its surface wherever its centre lies within
  patch_margin / 2 D of the patch's centre along z (BoxSpec.travel), and the gap below the lowest of those places;
  a new mesh when the centre strays from the patch (patch centres on a grid of patch_margin / 2 D).  Every step
  factorises (the penalty's place in the matrix moves, so kept factors would not precondition the next step's for
  long: docs/validation.md section 14's solver check).

Either way a restart makes its run's meshes again (gmsh's cache gives them bit for bit), and a new mesh takes the
flow's two BDF levels interpolated onto it (transfer.py: on the moving mesh at the sphere's place at t_n; the points
located once for both) and made discretely divergence-free (fem.transfer.DivergenceFreeProjection by its field
split: a factorisation for each new mesh cost more than the two projections' iterations).

One fluid step of length dt (the run's CoupledStep):

1. place the sphere where the AB2 prediction puts its centre at t_{n+1}, no lower than the contact model's
   hold gap above the wall (flow_model.flow_gaps: below delta_sl the near-wall correction adds what the flow
   misses, as in every resolved model);
2. (moving mesh) move the mesh there, its velocity the BDF rate of the centre.  While the hold stops the flow's sphere
   the mesh is at rest along z and the penalised ball, moving at V, lets liquid through its surface, as the ALE
   reference's held hole does and as the near-wall correction's approach term assumes (docs/physics.md 3.3).  An oblique
   sphere's jet into the gap, swept along the wall, twisted it against the rolling sense, so in an oblique collision the
   mesh velocity along z is the sphere's own while it is held: the liquid then meets a solid sphere approaching through
   a gap frozen at the hold.  That velocity is the step's unknown normal amplitude V, not a prediction of it
   (flow.PenalisedFlow3D's `carried`: its convection, taken about u*, joins V's forcing), so the step stays implicit in
   it: taken from the AB2 prediction, the force along the normal and the wall oscillated from step to step after the
   contact and grew until the run diverged (case 3 at 30 degrees).  Head-on that variant moves case 3's rebound by the
   hold's own uncertainty (docs/validation.md section 14), so a head-on scene keeps the reference's hold;
3. assemble the step's matrix, factorise it (fixed mesh; moving: when the kept factors are stale) and solve for the
   flow affine in the rigid amplitudes, u(s) = x_0 + sum_j s_j x_j, in one pass over the factors;
4. hand the body integrator the force linearised in the accelerations, exactly as the axisymmetric implicit
   constraint does (models/fd/penalised.py): the penalty's reaction plus the rate of the held ball's momentum,
   over the rigid amplitudes s (V along z; oblique: and U, Omega),

       F(s) = rho c_B (I(x_0) + (I(x_j) - G) s) + rho c (B s - J),

   I_i(w) = int phi w . m_i, G_ij = int phi m_i . m_j, B the ball the friction holds (4/3 pi a^3, 8/15 pi a^5 for
   the rotation), J the BDF history of B s; F = F* - M c (s - s_ref) with F* = F(s_ref) and the numerical added
   mass M = -dF/ds / c (`_linearised`);
5. set the step's field for the amplitudes the bodies reached: u = x_0 + sum_j s_j x_j.

Steps of their own length (numerics.fd3d.adaptive_step, flow_model.StepLimits, the fd model's controller): the
variable-step BDF2; short through the collision.  A checkpoint holds the two BDF levels by dof coordinates
(fem.functions), the patch's and the sphere's centres (at t_n and t_{n-1} for the mesh's velocity), and the moving
mesh's factors are renewed at the step after it, so a restart makes the mesh again and continues exactly.
"""
from __future__ import annotations

import math
import resource
import time
from pathlib import Path

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.io import XDMFFile

from ... import numerics
from ...bodies import scene_bodies
from ...fem.domain import speed_scale
from ...fem.functions import CheckpointMismatch, gather_history, scatter_history
from ...fem.geometry import Cartesian
from ...fem.solver import SolverError
from ...fem.transfer import DivergenceFreeProjection
from ...fem.vertex_fields import VertexFields
from ...flow_model import (FlowModel, StepLimits, approach_for, end_clipped, flow_gaps, mean_velocity, nearest_gap,
                           safe_fixed_step, steps_to)
from ...kinematics import FluidForce, PlaneForce, Prediction
from ...motion import is_free, is_stream
from ...output import CheckpointError, body_array, segment_path
from ...scene import SceneError
from ..fd.domain import PEAK_SPEED_FACTOR
from ..fd.model import History
from .flow import PenalisedFlow3D
from .indicator import ConformingBall, SphereIndicator
from .mesh import BALL, SIDE_X, SIDE_Y, TOP, WALL, BoxSpec, create_box_mesh, restore_ball_volume
from .motion import MeshMotion3D
from .transfer import interpolate_states

HEAD_ON = ("U_z",)  # the rigid mode a head-on bounce moves
OBLIQUE = ("U_z", "U_x", "Omega_y")  # an oblique one's, in the plane of incidence: the normal first
RIGID_LAYER = 2.0  # the moving mesh carries the sphere and this many fine cells around it rigidly
GAP_RATIO = 0.5  # the moving mesh is made again when the gap under the sphere has fallen or grown by this factor
# ... or when its worst tetrahedron would fall below this fraction of the worst of the mesh as made: sliding along the
# wall shears the few cells between the rigid layer and the wall, and held there they had turned inside out
QUALITY_RATIO = 0.5


class FieldWriter3D:
    """The velocity, pressure and vorticity component omega_y = du_x/dz - du_z/dx (normal to the symmetry plane y = 0,
    the plane of the motion) of a Taylor-Hood state as P1 fields at the vertices, one XDMF time series per mesh
    (dolfinx's parallel writer; the fields are fem.vertex_fields', omega_y the lumped-mass L2 projection of the P2
    velocity's curl, each vertex the volume-weighted mean around it).
    On a moving mesh (`motion`) the file holds the mesh as it was made and each snapshot its displacement
    (mesh_displacement: ParaView's Warp By Vector puts the mesh where it was)."""

    def __init__(self, comm, mesh, W, path: Path, motion: MeshMotion3D | None = None):
        self.motion = motion
        self.fields = VertexFields(W, vorticity=lambda u: u[0].dx(2) - u[2].dx(0), vorticity_name="vorticity_y")
        where = mesh.geometry.x.copy()  # the mesh where the sphere is now
        if motion is not None:
            self.displacement = fem.Function(self.fields.velocity.function_space, name="mesh_displacement")
            mesh.geometry.x[:] = motion.reference  # the file's mesh as made
        self.file = XDMFFile(comm, str(path), "w")
        self.file.write_mesh(mesh)
        mesh.geometry.x[:] = where

    def write(self, state: fem.Function, t: float) -> None:
        self.fields.update(state)
        written = list(self.fields.functions)
        if self.motion is not None:  # psi s at the vertices (the P1 spaces share their layout)
            self.displacement.x.array[:] = np.outer(self.motion.psi.x.array, self.motion.shift).ravel()
            written.append(self.displacement)
        for function in written:
            self.file.write_function(function, t)

    def close(self) -> None:
        if self.file is not None:
            self.file.close()
            self.file = None


class FictitiousDomain3DModel(FlowModel):
    name = "fd3d"
    resolved = True
    divergences = (SolverError,)

    def __init__(self, scene, comm):
        super().__init__(scene, comm)
        self._check_scene(scene)
        s, sphere = self.settings, scene.sphere
        self.bodies = scene_bodies(scene)
        self.diameter, self.radius = sphere.diameter, sphere.radius
        self.fine_size = self.diameter / s.cells_per_diameter
        self.moving = s.mesh == "moving"
        self.mirrored = s.box == "half"
        # the whole box's loads across the plane of incidence: peaks, impulses and the impulses' peaks (_measure...)
        self.out_of_plane = {"force": 0.0, "torque": 0.0, "impulse": np.zeros(3), "drift": np.zeros(3)}
        self.surface_size = self.fine_size / (s.surface_refinement if self.moving else 1.0)
        self.coarse_size = max(self.diameter / s.coarse_cells_per_diameter, self.fine_size)
        self.travel = 0.5 * s.patch_margin * self.diameter  # the patch covers the centre within this of its own
        self.half_width = s.far_field * self.diameter
        self.height = scene.initial_gap + self.diameter + self.travel + s.far_field * self.diameter
        speed = speed_scale(scene, "fd3d")
        self.dt = self.cfl_step = s.peak_cfl * self.fine_size / (PEAK_SPEED_FACTOR * speed)
        nu = scene.liquid.kinematic_viscosity
        self.penalty_rate = s.penalty_strength * max(nu / self.surface_size**2, speed / self.surface_size,
                                                     1.5 / self.cfl_step)
        self.adaptive = s.adaptive_step
        safe = safe_fixed_step(scene, speed)
        if not self.adaptive and self.cfl_step > safe * (1.0 + 1e-9):  # fixed steps are never shortened
            raise SceneError(f"numerics.fd3d.peak_cfl = {s.peak_cfl:g} with adaptive_step = false makes a fixed step "
                             f"of {self.cfl_step:.3g} s, longer than the {safe:.3g} s this scene allows (a step at the "
                             f"impact speed scale, {speed:.3g} m/s, carrying the sphere at most half across the "
                             "contact model's gap delta_sl D): it could jump a collision.  Allowed for this scene: "
                             "numerics.fd3d.peak_cfl up to "
                             f"{safe * PEAK_SPEED_FACTOR * speed / self.fine_size:.3g}, or "
                             "adaptive_step = true (its steps are bounded by the gaps)")
        self.step_limits = StepLimits(self.cfl_step, s.min_step_factor, s.max_step_factor, speed, s.gap_fraction,
                                      approach_for(scene))
        self.time, self.last_step = 0.0, 0.0  # t_n and the step that reached it (adaptive steps) [s]
        self.step_range = [math.inf, 0.0]
        self.sides = {WALL: "no-slip" if scene.wall.present else "slip", TOP: "slip", SIDE_X: "slip",
                      SIDE_Y: "slip"}
        self.motion: MeshMotion3D | None = None
        self.flow: PenalisedFlow3D | None = None
        self.fields: FieldWriter3D | None = None
        self.remeshes, self.remesh_s = 0, 0.0
        # the moving mesh: new meshes made because the motion sheared the old one (QUALITY_RATIO), and the worst
        # tetrahedron of the meshes the steps were taken on over that of each mesh as made
        self.sheared_remeshes, self.worst_quality = 0, 1.0
        self.retired = {"factorisations": 0, "factorise_s": 0.0, "solve_s": 0.0, "assembly_s": 0.0,
                        "krylov_iterations": 0}
        self.timings = {"setup": 0.0, "steps": 0.0, "integrator": 0.0}
        self.last_force: FluidForce | None = None
        self.mode_names = OBLIQUE if scene.oblique else HEAD_ON
        self.cross_coupling = 0.0  # an oblique step's largest normal-tangential added mass over the diagonal's

    def _check_scene(self, scene) -> None:
        """What the 3-D model does not run, refused before the run writes anything."""
        if len(scene.spheres) > 1:
            raise SceneError("the fd3d model runs one sphere: remove [second_sphere] and [[further_spheres]]")
        if scene.oblique and scene.numerics.fd3d.mesh == "fixed":
            raise SceneError('the fd3d model\'s fixed mesh follows a sphere along z only: an oblique collision '
                             '(tangential_velocity, spin or gravity_angle) needs numerics.fd3d.mesh = "moving"')
        if not is_free(scene) or is_stream(scene):
            raise SceneError('the fd3d model runs a free sphere (motion.mode = "free") without a stream')
        s, defaults = scene.numerics.fd3d, numerics.Fd3dNumerics()
        if s.mesh == "fixed" and s.surface_refinement != defaults.surface_refinement:
            raise SceneError("numerics.fd3d.surface_refinement refines the moving mesh only: unset it, or set "
                             'numerics.fd3d.mesh = "moving"')
        if s.mesh == "moving" and s.interface_width != defaults.interface_width:
            raise SceneError("numerics.fd3d.interface_width shapes the fixed mesh's band only; the moving mesh holds "
                             'the ball\'s cells whole: unset it, or set numerics.fd3d.mesh = "fixed"')
        if not scene.container.unbounded:
            raise SceneError('the fd3d model meshes a box, not a cylindrical container: give container = "unbounded"')

    # -- set-up ---------------------------------------------------------------------------
    def build(self, integrator) -> None:
        """The patch's mesh around the release, the liquid at rest, the indicator where the sphere starts."""
        start = time.perf_counter()
        self.hold = float(integrator.hold_gaps[0])
        self.bodies_now = integrator  # an oblique collision's motion along the wall: BodyIntegrator.along
        center = np.array([0.0, 0.0, self.bodies[0].initial_gap + self.radius])
        self.placed = [center, center]  # the flow's sphere centre at t_n and t_{n-1} [m]
        self.patch = self.patch_center(center)
        self._make_flow(center)
        along = integrator.along
        amplitudes = np.array([self.bodies[0].start_velocity, *([] if along is None else along[1:])])
        # the rigid amplitudes over mode_names (V; with U and Omega), the ball's liquid at rest
        self.history = History(self.flow.bdf, [amplitudes] * 2, [np.zeros(len(amplitudes))] * 2)
        self.timings["setup"] = time.perf_counter() - start

    def patch_center(self, center) -> np.ndarray:
        """The patch's centre [m] for a sphere centred at `center` [m] (a 3-vector, y = 0).  Fixed mesh (the
        sphere on the axis x = 0): z on a grid of the patch's travel, and no lower than puts the lowest place it
        covers at the flow's hold above the wall (or a fine cell).  Moving mesh: the centre rounded to 1e-4 D (so
        that gmsh never meshes on a tie in the last bits of its input), z no lower than the hold."""
        x, _, z = center
        if self.moving:
            quantum = 1e-4 * self.diameter
            return np.array([round(x / quantum) * quantum, 0.0,
                             max(round(z / quantum) * quantum, self.radius + max(self.hold, 0.05 * self.fine_size))])
        grid = round(z / self.travel) * self.travel
        return np.array([0.0, 0.0, max(grid, self.radius + max(self.hold, self.fine_size) + self.travel)])

    def spec(self) -> BoxSpec:
        s = self.settings
        return BoxSpec(half_width=self.half_width, height=self.height,
                       center=(float(self.patch[0]), 0.0, float(self.patch[2])),
                       radius=self.radius, surface_size=self.surface_size, coarse_size=self.coarse_size,
                       gap_size=None if self.surface_size == self.fine_size else self.fine_size,
                       grading=s.grading, gap_cells=s.gap_cells, mirrored=self.mirrored,
                       travel=0.0 if self.moving else self.travel, conforming=self.moving,
                       box_center=float(self.patch[0]))

    def _make_flow(self, center) -> None:
        """The patch's mesh, its penalised flow at rest and the indicator at `center` [m] (a 3-vector; the moving
        mesh moved there from the patch's centre)."""
        liquid, s = self.scene.liquid, self.settings
        spec = self.spec()
        self.mesh, cell_tags, facet_tags = create_box_mesh(self.comm, spec)
        if self.moving:  # the ball's cells, held whole, carried rigidly with the sphere
            self.ball_scale = restore_ball_volume(self.mesh, cell_tags, spec)
            rigid = self.radius + RIGID_LAYER * self.surface_size
            self.motion = MeshMotion3D(self.mesh, facet_tags, spec.center, rigid)
            self.made_quality = self.motion.quality(np.zeros(3))
            self.motion.move_to(center)
            velocity, solver = self.motion.velocity, "reuse"
            # an oblique collision's hold: the mesh moves along z with the sphere's normal amplitude (module docstring)
            carried = ("U_z", self.motion.psi * ufl.as_vector((0.0, 0.0, 1.0))) if self.scene.oblique else None
            sphere = ConformingBall(self.mesh, cell_tags.find(BALL), self.radius, self.surface_size, center)
        else:
            velocity, solver, carried = None, "direct", None
            sphere = SphereIndicator(self.mesh, self.radius, s.interface_width * self.fine_size, center)
        geometry = Cartesian(self.mesh, mirrored=self.mirrored)
        self.flow = PenalisedFlow3D(geometry, facet_tags, self.sides, liquid.density, liquid.viscosity, sphere,
                                    self.penalty_rate, prefix="fd3d_", moving=self.mode_names, step_solver=solver,
                                    mesh_velocity=velocity, carried=carried)
        self.flow.set_time_step(self.dt)
        self.modes = [self.flow.geometry.mode_names.index(name) for name in self.mode_names]

    def strays(self, center) -> bool:
        """Whether the sphere centred at `center` [m] (a 3-vector) needs a new patch (module docstring)."""
        travelled = math.hypot(center[0] - self.patch[0], center[2] - self.patch[2]) > self.travel * (1.0 + 1e-9)
        if travelled or not self.moving:
            return travelled
        ratio = (center[2] - self.radius) / (self.patch[2] - self.radius)
        quality = self.motion.quality(center - self.motion.reference_center) / self.made_quality
        if quality < QUALITY_RATIO:
            self.sheared_remeshes += 1
            return True
        self.worst_quality = min(self.worst_quality, quality)
        return not GAP_RATIO <= ratio <= 1.0 / GAP_RATIO

    def follow(self, center) -> None:
        """A new patch's mesh when the sphere's centre `center` [m] has left the patch, the flow's BDF levels
        carried over (interpolated, then made discretely divergence-free)."""
        if not self.strays(center):
            return
        start = time.perf_counter()
        old = self.flow
        self.patch = self.patch_center(center)
        self._make_flow(self.placed[0])  # a moving mesh where the fields are, at t_n
        projection = DivergenceFreeProjection(self.flow.W, self.flow.bcs, prefix="fd3d_projection_",
                                              solver="fieldsplit", geometry=self.flow.geometry)
        try:
            interpolate_states(old.states, self.flow.states, padding=1e-6 * self.fine_size)
            for state in self.flow.states:
                projection.project(state)
        finally:
            projection.destroy()
        self._retire(old)
        if self.fields is not None:  # the snapshots go on in a file on the new mesh
            self.fields.close()
            self._open_fields()
        self.remeshes += 1
        self.remesh_s += time.perf_counter() - start

    def _retire(self, flow: PenalisedFlow3D) -> None:
        self.retired["factorisations"] += flow.factorisations
        self.retired["krylov_iterations"] += self._iterations(flow)
        for key in ("factorise_s", "solve_s", "assembly_s"):
            self.retired[key] += getattr(flow, key)
        flow.destroy()

    @staticmethod
    def _iterations(flow: PenalisedFlow3D) -> int:
        """FGMRES iterations of a flow's steps (0 when it factorises every step)."""
        return getattr(flow.step_operator, "iterations", 0)

    def initial_velocities(self) -> list[np.ndarray]:
        return [v[:1] for v in self.history.velocities]  # the normal velocity's levels

    def previous_time_step(self) -> float | None:
        return self.last_step if self.adaptive and self.last_step else None

    # adaptive steps: bounded where they start by the gaps they may close (StepLimits.first); fixed ones of dt, no
    # longer than safe_fixed_step (__init__); the last step of either shortened to end at run.end_time
    # (flow_model.end_clipped) through the variable-step BDF2
    def start_step(self, gaps: np.ndarray, velocities: np.ndarray) -> None:
        if self.adaptive:
            self.dt = self.step_limits.first(self.dt, gaps, velocities)

    def next_time(self) -> float:
        if self.adaptive:
            return end_clipped(self.time + self.dt, self.scene.run.end_time, self.cfl_step)
        return end_clipped((self.step + 1) * self.dt, self.scene.run.end_time, self.dt)

    def step_length(self) -> float:
        """The coming step's length [s]: dt, or what is left of it before the end time."""
        if self.adaptive:
            return self.next_time() - self.time
        t_next = self.next_time()
        return self.dt if t_next == (self.step + 1) * self.dt else t_next - self.step * self.dt

    def time_step(self) -> float:
        return self.step_length()

    def finished(self, end_time: float) -> bool:
        if self.adaptive:
            return self.time >= end_time - 1e-9 * self.cfl_step
        return self.step >= steps_to(end_time, self.dt)

    def resolved_top(self) -> float:
        """A diameter below the box's top [m]: a rising sphere is stopped there."""
        return self.height - self.diameter

    # -- one step -------------------------------------------------------------------------
    def predicted_center(self, prediction: Prediction) -> np.ndarray:
        """The flow's sphere centre at t_{n+1} [m]: as predicted (along the wall too, by the same AB2 rule), no
        lower than the hold gap above the wall."""
        z = float(flow_gaps(prediction.gaps, [self.diameter], (self.hold,))[0]) + self.radius
        along = self.bodies_now.along
        if along is None:
            return np.array([0.0, 0.0, z])
        slide = mean_velocity([v[1] for v in self.history.velocities], prediction.dt, self.previous_time_step())
        return np.array([along[0] + prediction.dt * slide, 0.0, z])

    def linearised_force(self, prediction: Prediction) -> FluidForce:
        center = self.predicted_center(prediction)
        self.follow(center)
        flow, history = self.flow, self.history
        previous = self.previous_time_step() or (None if self.adaptive else self.dt)  # fixed: dt before the last
        length = self._length = self.step_length()
        flow.set_time_step(length, 2, length / previous if previous else 1.0)
        history.bdf = flow.bdf
        self._gap = nearest_gap(prediction.gaps, [self.diameter], self.scene.wall.present)
        if self.moving:  # the mesh to the sphere's place at t_{n+1}, its velocity the BDF rate of the centre ...
            self.motion.move_to(center)
            b = flow.bdf
            rate = (b[0] * center + b[1] * self.placed[0] + b[2] * self.placed[1]) / length
            held = self.scene.oblique and center[2] > float(prediction.gaps[0]) + self.radius  # (module docstring)
            if held:  # the mesh's velocity along z is the sphere's own, implicit in the step (flow's `carried`)
                rate[2] = 0.0
            flow.carrying = held
            self.motion.set_rate(rate)
        flow.sphere.place(center)
        self._center = center
        response = self._response = flow.step()
        self.last_force = self._linearised(response, flow.c)
        self._integrator_start = time.perf_counter()
        return self.last_force

    def _linearised(self, response, c: float) -> FluidForce:
        """The force over the rigid amplitudes s (V; with U and Omega), F(s) = rho c_B (I(x_0) + (I(x_j) - G) s)
        + rho c (B s - J), as F* - M c (s - s_ref) with M = -dF/ds / c: the normal force to the normal row, and (an
        oblique collision) the force along the wall and the torque with the whole M (kinematics.PlaneForce)."""
        k, rho, history = self.modes, self.scene.liquid.density, self.history
        ball = response.ball_mass[np.ix_(k, k)]
        derivative = response.resistance[np.ix_(k, k)] + rho * c * ball  # dF/ds [kg/s, kg m/s, kg m^2/s]
        reference = history.reference_velocity
        if len(k) == 1:
            explicit = (response.penalty * response.constant[k] + derivative[0, 0] * reference
                        - rho * c * history.momentum_history)
        else:
            explicit = (response.penalty * response.constant[k] + derivative @ reference
                        - rho * c * history.momentum_history)
            scale = np.sqrt(np.abs(np.diag(derivative)))
            across = np.abs(derivative[0, 1:]) + np.abs(derivative[1:, 0])
            self.cross_coupling = max(self.cross_coupling, float(np.max(across / (scale[0] * scale[1:]))))
        mass = -derivative / c
        if not (np.all(np.isfinite(explicit)) and np.all(np.isfinite(mass))):
            raise FloatingPointError(f"the fluid force became {explicit} N at t = {self.next_time():.6g} s")
        self._ball = np.diag(ball)
        plane = PlaneForce(explicit=explicit[1:], mass=mass) if len(k) > 1 else None
        return FluidForce(explicit=np.asarray(explicit[:1], dtype=float), added_mass=mass[:1, :1], plane=plane)

    def complete(self, velocities: np.ndarray, time_now: float) -> None:
        self.timings["integrator"] += time.perf_counter() - self._integrator_start
        velocities = np.array(velocities, dtype=float)
        along = self.bodies_now.along
        moved = np.array([velocities[0], *([] if along is None else along[1:])])  # over mode_names
        amplitudes = np.zeros(len(self.flow.modes))
        amplitudes[self.modes] = moved
        self.flow.commit(amplitudes)
        if not self.mirrored:
            self._measure_out_of_plane(amplitudes)
        if not math.isfinite(self.flow.states[0].x.petsc_vec.norm()):
            raise FloatingPointError(f"the flow field became non-finite at t = {self.next_time():.6g} s")
        self.ended_short = self._length < self.dt * (1.0 - 1e-12)
        if self.adaptive:
            # the steps follow the normal motion (the approach to the wall, its jerk)
            dt, levels = self._length, [velocities, *(v[:1] for v in self.history.velocities[:2])]
            self.step_range = [min(self.step_range[0], dt), max(self.step_range[1], dt)]
            self.dt = self.step_limits.after(levels, dt, self.last_step, self._gap)
            self.time, self.last_step = self.time + dt, dt
        self.history.push(moved, moved * self._ball)  # the held ball's momentum and angular momentum / rho
        self.placed = [self._center, self.placed[0]]
        self.step += 1

    def _measure_out_of_plane(self, amplitudes: np.ndarray) -> None:
        """The whole box: the step's force across the plane of incidence F_y [N] and torque about the axes in it
        (T_x, T_z) [N m] (the penalty's reaction; the held ball's momentum has no such part), kept at their peaks and
        summed over the steps as impulses [N s, N m s]."""
        loads = self._response.penalty_force(amplitudes)
        names = self.flow.geometry.mode_names
        across = np.array([loads[names.index(name)] for name in ("U_y", "Omega_x", "Omega_z")])
        found = self.out_of_plane
        found["force"] = max(found["force"], abs(float(across[0])))
        found["torque"] = max(found["torque"], float(np.hypot(*across[1:])))
        found["impulse"] += self._length * across
        found["drift"] = np.maximum(found["drift"], np.abs(found["impulse"]))

    # -- checkpoints and fields -------------------------------------------------------------
    def checkpoint_state(self) -> tuple[dict, dict]:
        """The flow's two BDF levels by dof coordinates (gathered on rank 0), the patch's and the sphere's centres,
        the sphere's velocities and held momenta, and the adaptive step's state."""
        steps = {"time": self.time, "step_length": self.dt, "last_step": self.last_step,
                 "step_range": self.step_range} if self.adaptive else {}
        if self.moving and self.flow.step_operator is not None:
            self.flow.step_operator.stale = True  # fresh factors at the next step, as a restart from here has
        return ({"dt": self.cfl_step, **steps, **self.history.state(), "patch_center": self.patch.tolist(),
                 "placed_centers": [center.tolist() for center in self.placed]}, gather_history(self.flow.states))

    def restore(self, state: dict, arrays) -> None:
        if not math.isclose(state["dt"], self.cfl_step, rel_tol=1e-12):
            raise CheckpointError(f"the checkpoint was made with dt = {state['dt']:g} s, this scene gives "
                                  f"{self.cfl_step:g} s: the scene was changed")
        try:
            if self.adaptive:
                self.time, self.dt, self.last_step = (float(state[key]) for key in ("time", "step_length",
                                                                                    "last_step"))
                self.step_range = [float(value) for value in state["step_range"]]
            patch = np.array(state["patch_center"], dtype=float).reshape(3)
            self.placed = [np.array(center, dtype=float).reshape(3) for center in state["placed_centers"]]
        except (KeyError, TypeError, ValueError):
            raise CheckpointError("the checkpoint lacks the fd3d model's patch or adaptive step (patch_center, "
                                  "placed_centers, time, step_length): the scene was changed") from None
        placed = self.placed[0]  # the flow's sphere at t_n
        if not np.array_equal(patch, self.patch):  # the sphere had moved on: that patch's mesh again
            self._retire(self.flow)
            self.patch = patch
            self._make_flow(placed)
        elif self.moving:
            self.motion.move_to(placed)
        self.flow.sphere.place(placed)
        try:
            scatter_history(self.flow.states, arrays, tolerance=1e-6 * self.fine_size)
        except (ValueError, KeyError, CheckpointMismatch) as err:
            raise CheckpointError(f"the checkpoint does not fit this run's mesh: {err}") from None
        velocities, interiors = ([body_array(v) for v in state[key]] for key in ("velocities", "interiors"))
        if any(len(v) != len(self.mode_names) for v in velocities):
            raise CheckpointError(f"the checkpoint's sphere moves in {len(velocities[0])} rigid modes, this scene's "
                                  f"in {len(self.mode_names)} ({', '.join(self.mode_names)}): the scene was changed")
        self.history = History(self.flow.bdf, velocities, interiors)

    def open_outputs(self, out_dir: Path, restart: bool, fields: bool, sides: dict | None = None) -> None:
        if fields:
            self.fields_dir = out_dir
            self._open_fields()

    def _open_fields(self) -> None:
        path = self.comm.bcast(segment_path(self.fields_dir) if self.comm.rank == 0 else None, root=0)
        self.fields = FieldWriter3D(self.comm, self.mesh, self.flow.W, path, self.motion if self.moving else None)

    def write_fields(self, time_now: float) -> None:
        self.fields.write(self.flow.states[0], time_now)

    def close_outputs(self) -> None:
        if self.fields is not None:
            self.fields.close()

    # -- what the summary says ----------------------------------------------------------------
    def sizes(self) -> dict:
        cells = self.mesh.topology.index_map(3).size_global
        return {"cells": cells, "unknowns": self.flow.unknowns, "dt": self.cfl_step, "fine_size": self.fine_size}

    def report(self) -> dict:
        """Cost and discretisation details for summary.json."""
        self.timings["steps"] = self.loop_seconds
        steps = max(self.steps_this_run, 1)
        flow = self.flow
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024.0  # Linux reports kB
        operator = flow.step_operator
        last = self.last_force
        slip = None
        if operator is not None:
            amplitudes = np.zeros(len(flow.modes))
            amplitudes[self.modes] = self.history.velocity
            slip = flow.interior_slip(flow.states[0], amplitudes, self.radius - flow.sphere.width)
        return {
            "timings_s": self.timings,
            "time_per_step_s": self.timings["steps"] / steps,
            "factorisations": flow.factorisations + self.retired["factorisations"],
            "assembly_s": flow.assembly_s + self.retired["assembly_s"],
            "factorise_s": flow.factorise_s + self.retired["factorise_s"],
            "solve_s": flow.solve_s + self.retired["solve_s"],
            "krylov_iterations": self._iterations(flow) + self.retired["krylov_iterations"],
            "peak_memory_bytes": self.comm.allreduce(peak),  # sum over ranks of each rank's peak RSS
            "factorisation_memory_bytes": operator.factor_memory() if operator is not None else None,
            "mesh_key": self.spec().key(),
            "remeshes": self.remeshes,
            **({"sheared_remeshes": self.sheared_remeshes, "worst_quality_over_made": self.worst_quality}
               if self.moving else {}),
            "remesh_s": self.remesh_s,
            "penalty_rate_per_s": self.penalty_rate,
            **({"ball_radius_scale": self.ball_scale} if self.moving else {}),
            "interior_slip_m_s": slip,
            "added_mass_over_displaced": (float(last.added_mass[0, 0] / self.bodies[0].displaced_mass)
                                          if last is not None else None),
            **({"tangential_added_mass_over_displaced": float(last.plane.mass[1, 1] / self.bodies[0].displaced_mass),
                "cross_coupling": self.cross_coupling} if last is not None and last.plane is not None else {}),
            **({"shortest_step_s": self.step_range[0], "longest_step_s": self.step_range[1]} if self.adaptive
               and self.step_range[1] else {}),
            **({} if self.mirrored else {"out_of_plane": self._out_of_plane_report()}),
        }

    def _out_of_plane_report(self) -> dict:
        """The whole box's symmetry check (this run's steps): the peak force across the plane of incidence and torque
        about the axes in it, and what their impulses would have given the sphere had it been free to leave the
        plane: the largest velocity across it [m/s] (over its mass with the free sphere's added mass) and spin about
        those axes [1/s] (over its moment of inertia), to read against its in-plane velocity and spin."""
        found, body = self.out_of_plane, self.bodies[0]
        mass, inertia = body.mass + 0.5 * body.displaced_mass, 0.4 * body.mass * self.radius**2
        return {"peak_force_n": found["force"], "peak_torque_n_m": found["torque"],
                "velocity_across_m_s": float(found["drift"][0] / mass),
                "spin_across_1_s": float(np.hypot(*found["drift"][1:]) / inertia)}

    def destroy(self) -> None:
        if self.flow is not None:
            self.flow.destroy()
