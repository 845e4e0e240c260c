"""The fd model on a mesh that moves with the spheres (numerics.fd.mesh = "moving").

The moving mesh the ale model also uses (models/moving_mesh.py: the harmonic extension that carries the mesh with
the spheres, a new mesh when a triangle degrades, the holds near contact, the BDF history carried onto a new mesh,
the checkpoints), owned here as the ale model owns its own, with the fd model's sphere: not a hole with a no-slip
surface but liquid, meshed inside the sphere's surface (a curve of the mesh: fem.mesh.SphereHole filled) and held
rigid by the implicit Brinkman friction of penalised.PenalisedFlow (Angot, Bruneau & Fabrie 1999); the force on
the sphere is the friction's reaction plus the rate of change of the held liquid's momentum (Uhlmann 2005, eq. 12).

Why: on a fixed mesh the sphere's surface crosses the triangles, and the velocity's kink there is
resolved only as the whole fine region is refined (case 3's first apex -5 % at 24 cells/D,
docs/validation.md section 12).  Here the surface is a curve of the mesh, and the mesh moves rigidly
inside it (the extension is 1 there), so the indicator's band stays on the same triangles with the same
values, placed once per mesh.  The flow takes the ale model's non-conservative ALE form: convection by
u* - w, w the mesh velocity (models/ale/flow.py).
"""
from __future__ import annotations

from dataclasses import fields

import numpy as np
import ufl

from ...fem.domain import speed_scale
from ...fem.mesh import SPHERE_TAGS
from ...fem.mesh_motion import MeshMotion
from ...fem.solver import SolverError
from ...flow_model import StepLimits, approach_for
from ...kinematics import FluidForce, Prediction
from ...scene import SceneError
from ..moving_mesh import MovingMesh, MovingMeshModel, checked_domain, first_step
from ..unread import FIXED_MESH_ONLY, correction_holds_every_contact, refuse_unread
from .domain import penalty_rate, time_step
from .immersed import ImmersedBodies
from .penalised import PenalisedFlow


class MovingPenalisedFlow(PenalisedFlow):
    """PenalisedFlow on a mesh a MeshMotion moves (mesh_velocity: its UFL velocity), driven as the ale model
    drives its SphereFlow: `step` gives the forces at the reference velocities and their slopes, `commit` the
    field for the velocities the spheres reached."""

    def __init__(self, mesh, facet_tags, sides, density, viscosity, dt, penalty_rate, mesh_velocity, **options):
        self.mesh_velocity = mesh_velocity
        super().__init__(mesh, facet_tags, sides, density, viscosity, dt, penalty_rate, **options)
        self.reference = None  # U_ref of the step being made [m/s]
        self.krylov_iterations = 0  # factorised every step (the moving mesh's tallies ask: moving_mesh.TALLIES)

    def convecting(self, extrapolated):
        return extrapolated - self.mesh_velocity

    def step(self, reference_velocity, extrapolated_velocity=None):
        """(F(U_ref) [N], dF/dU [N s/m]) of the step, as models/ale/flow.SphereFlow.step."""
        self.reference = np.asarray(reference_velocity, dtype=float)
        linear = self.linearise(self.ball_momentum_history(), self.reference)
        return linear.explicit, -self.c * linear.added_mass

    def ball_momentum_history(self) -> np.ndarray:
        """J_i: the BDF history of the held balls' momenta / rho [m^4/s], B_i times the mean velocity of the
        liquid in ball i at each past level (I_i(u^k) / V_i; the ball B_i moves rigidly with the mesh), as Uhlmann's
        (2005) eq. 12 takes the liquid inside as it is.  While that liquid moves with its sphere this is
        B_i U_ref,i (the history before); where it does not, the penalty's work on it is not the sphere's: a sphere
        launched into liquid at rest (its inside at rest: charged to the sphere, that liquid's momentum took 6 % of
        the launch speed), and each new mesh, whose transfer (interpolated, made divergence-free) moves the inside
        a little (0.03-0.24 % of the displaced liquid's momentum at 6 cells/D, tests/test_fd_moving.py)."""
        levels = self.inside_velocities()
        return -self.bodies.ball_volumes * sum(a * v for a, v in zip(self.bdf[1:], levels)) / self.bdf[0]

    def inside_velocities(self) -> list[np.ndarray]:
        """The mean velocity of the liquid in each ball, I_i(u^k) / V_i [m/s], at each past level, newest first."""
        return [self.bodies.interiors(state.x.petsc_vec) / self.bodies.volumes for state in self.states]

    def commit(self, velocity_change) -> None:
        """The step's field for the velocities U_ref + velocity_change becomes u^n."""
        super().commit(self.field(self.reference + np.asarray(velocity_change, dtype=float), self.work))

    def set_boundary_values(self, sphere_velocity, inflow=None) -> None:
        """Nothing: the spheres are no boundary, and an inflow keeps its value."""

    def renew(self) -> None:
        """Nothing: the matrix is factorised every step."""

    def momentum(self, state) -> float:
        """The liquid's axial momentum rho int u_z dV, the spheres' insides included [kg m/s]."""
        return self.geometry.integrate(self.geometry.weighted(self.density * ufl.split(state)[0][1]))

    def surface_force(self) -> np.ndarray:
        return np.full(len(self.bodies.spheres), np.nan)  # no surface to integrate over

    def destroy(self) -> None:
        if self.bodies is not None:
            self.bodies.destroy()
        super().destroy()


class MovingFictitiousDomainModel(MovingMeshModel):
    """`--model fd` with numerics.fd.mesh = "moving": the fd model's settings, time step and constraint on the
    mesh that follows the spheres (moving_mesh.MovingMesh, as the ale model's)."""

    name = "fd"
    resolved = True
    divergences = (SolverError,)
    fields_at_end = True
    steady = False  # held spheres march (their steady Stokes state: the fixed mesh, models/fd/__init__.py)

    def __init__(self, scene, comm):
        if len(scene.spheres) > len(SPHERE_TAGS):
            raise SceneError(f'numerics.fd.mesh = "moving" runs at most {len(SPHERE_TAGS)} spheres (one mesh tag '
                             f'each), this scene has {len(scene.spheres)}: use numerics.fd.mesh = "fixed"')
        super().__init__(scene, comm)
        domain = checked_domain(scene, self.name)
        fd = self.settings
        if fd.constraint != "implicit":
            raise SceneError(f'numerics.fd.constraint = "{fd.constraint}" runs on a fixed mesh only: set '
                             'numerics.fd.mesh = "fixed" (it keeps its factors; the moving mesh changes the matrix '
                             'every step)')
        defaults = {f.name: f.default for f in fields(fd)}
        for name in FIXED_MESH_ONLY:
            value = getattr(fd, name)
            if value != defaults[name]:
                shown = str(value).lower() if isinstance(value, bool) else value
                raise SceneError(f"numerics.fd.{name} = {shown} shapes the fixed mesh only; the moving mesh refines "
                                 "each sphere's surface (surface_refinement) and ends the band on it: unset it, or "
                                 'set numerics.fd.mesh = "fixed"')
        if fd.hold_delta != defaults["hold_delta"] and correction_holds_every_contact(scene):
            raise SceneError(f"numerics.fd.hold_delta = {fd.hold_delta:g} has no effect here: the near-wall correction "
                             f"(contact.near_wall = \"{scene.contact.near_wall}\", resolved \"correction\") holds each "
                             "sphere at the contact model's gap contact.delta_sl D (delta_sl 2a* for a pair) instead: "
                             "unset it, and set contact.delta_sl to move the hold (or contact.near_wall = \"blend\" "
                             "for the mesh to hold at hold_delta)")
        refuse_unread(scene, "fd")  # the other settings this mesh reads nowhere (models/unread.py)
        cfl_step = time_step(scene)
        adaptive = fd.resolved("adaptive_step")
        limits = StepLimits(cfl_step, fd.min_step_factor, fd.max_step_factor, speed_scale(scene, "fd"), fd.gap_fraction,
                            approach_for(scene))
        self.penalty_rate = penalty_rate(scene, domain.surface_size)  # on the surface's triangles
        self.moving = MovingMesh(scene, comm, fd, domain, self.make_flow, self.sphere_volume, cfl_step=cfl_step,
                                 step_limits=limits, adaptive=adaptive,
                                 first_step=first_step(scene, cfl_step, limits, adaptive))

    def make_flow(self, mesh, facet_tags, motion: MeshMotion, centers, dt: float) -> MovingPenalisedFlow:
        """The penalised flow on a new mesh, its spheres' indicators placed once: the mesh moves rigidly inside them."""
        scene, domain, fd = self.scene, self.moving.domain, self.settings
        flow = MovingPenalisedFlow(mesh, facet_tags, domain.sides, scene.liquid.density, scene.liquid.viscosity,
                                   dt, self.penalty_rate, motion.velocity, inflow_speed=domain.inflow_speed,
                                   order=fd.time_order)
        centers = [float(z) for z in np.atleast_1d(centers)]
        radii = list(self.moving.radii)
        flow.place(ImmersedBodies(flow, radii, radii, fd.interface_width * domain.surface_size, centers), centers)
        return flow

    def sphere_volume(self, flow: MovingPenalisedFlow) -> float:
        """The spheres' indicator volumes together [m^3] (the remeshes' record)."""
        return float(np.sum(flow.bodies.volumes))

    def linearised_force(self, prediction: Prediction) -> FluidForce:
        """The moving mesh's step, BDF1 while a past level in the BDF formula holds the liquid inside a sphere not
        moving with it (inside_lags): that liquid jumps to the sphere's velocity in the first step, and BDF2 across
        the jump rings (a launch kept too much of its speed: tests/test_fd_moving.py).  numerics.fd.coupling =
        "explicit" hands the integrator no added mass (the lagged coupling, for comparison: unstable for light
        spheres)."""
        moving = self.moving
        force = moving.linearise(prediction, cold_start=moving.step < self.settings.time_order and self.inside_lags())
        if self.settings.coupling == "implicit":
            return force
        return FluidForce(explicit=force.explicit, added_mass=np.zeros_like(force.added_mass))

    def inside_lags(self) -> bool:
        """Whether the liquid inside a sphere did not move with it at one of the flow's past levels (its mean
        velocity off the sphere's by more than 1e-3 of either): the start of a sphere launched into liquid at rest,
        or held in a stream, until the levels from before its inside was set moving have left the BDF formula."""
        return any(np.any(np.abs(inside - velocities) > 1e-3 * (np.abs(inside) + np.abs(velocities)))
                   for inside, velocities in zip(self.moving.flow.inside_velocities(),
                                                 self.moving.history.velocities))

    # -- what the summary says --------------------------------------------------------------------
    def report(self) -> dict:
        return {**super().report(), "mesh": "moving",
                "constraint": self.settings.constraint, "penalty_rate_per_s": self.penalty_rate}
