"""From a scene to the boundary-fitted problem: the meshed half-plane around the sphere, boundary
kinds, the time step and the gap at which the mesh stops following the sphere.

The domain follows the rules every finite-element model shares (fem.domain), with the sphere cut
out; the fine region covers the sphere's whole path, so the mesh moving with it stays fine.

Around the sphere the triangles have the fine size on its surface (numerics.ale.surface_refinement
times finer if asked: the collision's Stokes layer is thinner than a cell), and in the gap
below it at most (local gap) / min_gap_cells (fem.mesh.SphereHole), so a remeshed gap
is always resolved.  The mesh holds the sphere at hold_delta D above the wall at the
closest (see model.py for why that is harmless below delta_sl).

A head-on pair (scene.pair) cuts both spheres out, sphere 1 (the lower) first; the gap between
the two surfaces keeps its triangles across like the gap to the wall, and the mesh holds the
pair gap at hold_delta 2a* at the closest (a* the pair's reduced radius), or at the contact
model's hold when that is larger (model.py).
"""
from __future__ import annotations

import math

from dataclasses import dataclass

import numpy as np

from ...fem.domain import extent, speed_scale
from ...fem.mesh import Box, HalfPlane, SphereHole
from ...scene import Scene, SceneError, pair_diameter


@dataclass(frozen=True)
class AleDomain:
    """Everything but the sphere's position that shapes the mesh [m]."""

    radius: float  # R
    height: float  # Z
    refined: Box
    fine_size: float
    surface_size: float  # of the triangles on the sphere's surface
    coarse_size: float
    grading: float
    gap_cells: float
    radii: tuple  # of the spheres, sphere 1 (the lower) first
    sides: dict  # WALL/OUTER/TOP -> boundary kind
    inflow_speed: float  # [m/s]
    initial_centers: tuple  # z of the sphere centres at t = 0
    hold_gap: float  # the mesh's sphere stays at least this far above the wall
    pair_hold: float = 0.0  # and a pair's upper sphere this far above the lower one (numerics.ale.hold_delta 2a*)

    @property
    def sphere_radius(self) -> float:
        """Sphere 1's radius [m]."""
        return self.radii[0]

    @property
    def initial_center(self) -> float:
        """z of sphere 1's centre at t = 0 [m]."""
        return self.initial_centers[0]

    @property
    def pair(self) -> bool:
        return len(self.radii) > 1

    def spec(self, center) -> HalfPlane:
        """The half-plane with the sphere cut out at z = center (a pair: both, at the centres given) [m]."""
        holes = tuple(SphereHole(center=float(z), radius=a, surface_size=self.surface_size, gap_cells=self.gap_cells)
                      for z, a in zip(np.atleast_1d(center), self.radii))
        shape = dict(radius=self.radius, height=self.height, fine_size=self.fine_size, coarse_size=self.coarse_size,
                     grading=self.grading, refined=(self.refined,))
        # one sphere as `hole`: the meshes (and cache keys) it had before pairs
        return HalfPlane(**shape, holes=holes) if self.pair else HalfPlane(**shape, hole=holes[0])

    def mesh_center(self, center: float) -> float:
        """Where the mesh puts a sphere whose centre is at `center` [m]: never below the hold gap."""
        return max(center, self.sphere_radius + self.hold_gap)


def domain_for(scene: Scene) -> AleDomain:
    ale = scene.numerics.ale
    diameter, radius = scene.sphere.diameter, scene.sphere.radius
    fine = diameter / ale.cells_per_diameter
    coarse = max(diameter / ale.coarse_cells_per_diameter, fine)
    half_plane = extent(scene, "ale")
    center = half_plane.center
    if center + radius + 2.0 * fine > half_plane.height:
        raise SceneError(f"numerics.ale: the domain height {half_plane.height:g} m leaves no fluid above the sphere")
    # under the contact model's correction the mesh stops at delta_sl (contact.py); otherwise at hold_delta
    correcting = scene.near_wall_law == "correction" and scene.motion.mode == "free"
    hold_gap = (scene.contact.delta_sl if correcting else ale.hold_delta) * diameter
    if scene.motion.mode == "fixed" and scene.initial_gap < hold_gap:
        raise SceneError(f"numerics.ale.hold_delta = {ale.hold_delta:g} is above the held sphere's gap "
                         f"{scene.initial_gap / diameter:g} D: lower it")
    radii = tuple(sphere.radius for sphere in scene.spheres)
    centers = tuple(gap + a for gap, a in zip(scene.initial_gaps, radii))
    pair_hold = 0.0
    if scene.pair:
        # the contact model's holds come from the integrator (model.py); here the ale model's own
        hold_gap = ale.hold_delta * diameter
        pair_hold = ale.hold_delta * pair_diameter(scene.sphere, scene.second_sphere)
        if centers[-1] + radii[-1] + 2.0 * fine > half_plane.height:
            raise SceneError(f"numerics.ale: the domain height {half_plane.height:g} m leaves no fluid above the "
                             "second sphere")
        if scene.second_sphere.mode == "fixed" and scene.motion.mode == "fixed" and scene.second_sphere.gap < pair_hold:
            raise SceneError(f"numerics.ale.hold_delta = {ale.hold_delta:g} is above the held pair's gap: lower it")
    return AleDomain(radius=half_plane.radius, height=half_plane.height, refined=half_plane.refined, fine_size=fine,
                     surface_size=fine / ale.surface_refinement,
                     coarse_size=coarse, grading=ale.grading, gap_cells=ale.min_gap_cells, radii=radii,
                     sides=half_plane.sides, inflow_speed=half_plane.inflow_speed, initial_centers=centers,
                     hold_gap=hold_gap, pair_hold=pair_hold)


def time_step(scene: Scene) -> float:
    """dt = cfl * fine size / speed scale [s] (an accuracy limit: convection is implicit)."""
    ale = scene.numerics.ale
    return ale.cfl * scene.sphere.diameter / ale.cells_per_diameter / speed_scale(scene, "ale")


# An adaptive step (numerics.ale.adaptive_step) is the longest that
GAP_FRACTION = 0.05  # moves the sphere by at most this fraction of its gap (to the wall or its neighbour),
JERK_TOLERANCE = 1e-3  # keeps its velocity's curvature |dA/dt| dt^2 below this fraction of the speed scale,
GROWTH = 1.5  # and is at most this many times the step before (variable-step BDF2 is zero-stable below 2.41)


def next_time_step(scene: Scene, dt: float, gap: float, speed: float, jerk: float) -> float:
    """The coming step [s] after one of length dt [s] that leaves the sphere `gap` [m] from what it may hit,
    at `speed` [m/s], with its acceleration changing at `jerk` [m/s3]: the longest step that GAP_FRACTION,
    JERK_TOLERANCE and GROWTH allow, between min_step_factor and max_step_factor times the cfl step
    (time_step).  The flow meets a collision as a jump of the sphere's velocity, and its answer (the
    rebound's drag and history) is decided in the few steps after: those need short steps, the free fall
    far from the wall long ones; BDF2's local error goes with the third derivative of the motion, the
    jerk, times the step squared."""
    ale = scene.numerics.ale
    base = time_step(scene)
    longest = min(ale.max_step_factor * base, GROWTH * dt)
    if speed > 0.0:
        longest = min(longest, GAP_FRACTION * max(gap, 0.0) / speed)
    if jerk > 0.0:
        longest = min(longest, math.sqrt(JERK_TOLERANCE * speed_scale(scene, "ale") / jerk))
    return max(ale.min_step_factor * base, longest)


def is_steady(scene: Scene) -> bool:
    """A held sphere (a pair: both held) is solved for its steady state unless the scene asks for time
    marching."""
    held = scene.motion.mode == "fixed" and (not scene.pair or scene.second_sphere.mode == "fixed")
    return held and scene.numerics.ale.fixed_solver == "steady"

