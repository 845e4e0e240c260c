"""From a scene to the boundary-fitted problem: the meshed half-plane around the spheres, boundary
kinds, the time step and the gaps at which the mesh stops following the spheres.

The domain follows the rules every finite-element model shares (fem.domain), with every sphere on
the axis cut out, sphere 1 (the lowest) first; the fine region covers the spheres' whole path, so the
mesh moving with them stays fine.

Around each sphere the triangles have the fine size on its surface (numerics.ale.surface_refinement
times finer if asked: the collision's Stokes layer is thinner than a cell), and in the gap below it
(to the wall or to the sphere beneath) at most (local gap) / min_gap_cells (fem.mesh.SphereHole), so
a remeshed gap is always resolved.  The mesh holds sphere 1 at hold_delta D above the wall and each
neighbouring pair's gap at hold_delta 2a* (a* their reduced radius) at the closest, or at the contact
model's holds under its near-wall correction (model.py says why that is harmless below delta_sl).

The fd model's moving mesh (models/fd/moving.py) is this domain from numerics.fd, its spheres filled.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ...bodies import scene_bodies
from ...fem.domain import extent, speed_scale
from ...fem.mesh import Box, HalfPlane, SphereHole
from ...flow_model import StepLimits
from ...scene import Scene, SceneError, pair_diameter


@dataclass(frozen=True)
class AleDomain:
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
    # numerics.ale.hold_delta as gaps: sphere 1's above the wall (hold_delta D1), then each neighbouring
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


def domain_for(scene: Scene, model: str = "ale") -> AleDomain:
    """The moving mesh's domain from `[numerics.model]` (the ale model's, or the fd model's with mesh = "moving",
    whose spheres are filled)."""
    ale = getattr(scene.numerics, model)
    diameter = scene.sphere.diameter
    fine = diameter / ale.cells_per_diameter
    coarse = max(diameter / ale.coarse_cells_per_diameter, fine)
    half_plane = extent(scene, model)
    bodies = scene_bodies(scene)
    radii = tuple(body.sphere.radius for body in bodies)
    centers = tuple(gap + a for gap, a in zip(scene.initial_gaps, radii))
    if centers[-1] + radii[-1] + 2.0 * fine > half_plane.height:
        raise SceneError(f"numerics.{model}: the domain height {half_plane.height:g} m leaves no fluid above "
                         f"{bodies[-1].key}")
    holds = (ale.hold_delta * diameter,
             *(ale.hold_delta * pair_diameter(lower.sphere, upper.sphere) for lower, upper in zip(bodies, bodies[1:])))
    if bodies[0].held and bodies[0].initial_gap < holds[0]:
        raise SceneError(f"numerics.{model}.hold_delta = {ale.hold_delta:g} is above the held sphere's gap "
                         f"{scene.initial_gap / diameter:g} D: lower it")
    for lower, upper, hold in zip(bodies, bodies[1:], holds[1:]):
        if lower.held and upper.held and upper.sphere.gap < hold:
            raise SceneError(f"numerics.{model}.hold_delta = {ale.hold_delta:g} is above the gap "
                             f"{upper.sphere.gap:g} m between the held {lower.key} and {upper.key}: lower it")
    grading = ale.resolved("grading") if model == "fd" else ale.grading  # fd: unset is the moving mesh's own
    return AleDomain(radius=half_plane.radius, height=half_plane.height, refined=half_plane.refined, fine_size=fine,
                     surface_size=fine / ale.surface_refinement,
                     coarse_size=coarse, grading=grading, gap_cells=ale.min_gap_cells, radii=radii,
                     sides=half_plane.sides, inflow_speed=half_plane.inflow_speed, initial_centers=centers,
                     holds=holds, filled=model == "fd")


def time_step(scene: Scene) -> float:
    """dt = cfl * fine size / speed scale [s] (an accuracy limit: convection is implicit)."""
    ale = scene.numerics.ale
    return ale.cfl * scene.sphere.diameter / ale.cells_per_diameter / speed_scale(scene, "ale")


def step_limits(scene: Scene) -> StepLimits:
    """The adaptive step's bounds (numerics.ale.adaptive_step; flow_model.StepLimits): each step between
    min_step_factor and max_step_factor times the cfl step, closing at most GAP_FRACTION of the gap."""
    ale = scene.numerics.ale
    return StepLimits(time_step(scene), ale.min_step_factor, ale.max_step_factor, speed_scale(scene, "ale"))


def is_steady(scene: Scene) -> bool:
    """Held spheres (every one held) are solved for their steady state unless the scene asks for time
    marching."""
    return all(body.held for body in scene_bodies(scene)) and scene.numerics.ale.fixed_solver == "steady"

