"""From a scene to the boundary-fitted problem: the meshed half-plane around the sphere, boundary
kinds, the time step and the gap at which the mesh stops following the sphere.

The domain is the fd model's (fem_bounce.models.fd.domain) with the sphere cut out:

- free / prescribed / fixed without a stream: the wall z = 0 is no-slip; an unbounded
  scene closes with slip at r = R = far_field D and z = Z = top of the path +
  far_field D (as the paper does); a container is no-slip all round.  The fine region
  covers r <= refined_radius D from the wall to wake_length D above the highest sphere
  top, so the mesh moving with the sphere stays fine along its whole path.
- fixed in a stream: uniform inflow through z = 0 (no wall), do-nothing outflow at the
  top, slip at r = R; the fine region runs from refined_radius D upstream of the
  sphere to wake_length D downstream.

Around the sphere the triangles have the fine size on its surface, and in the gap
below it at most (local gap) / min_gap_cells (fem.mesh.SphereHole), so a remeshed gap
is always resolved.  The mesh holds the sphere at hold_delta D above the wall at the
closest (see model.py for why that is harmless below delta_sl).
"""
from __future__ import annotations

from dataclasses import dataclass

from ...fem.mesh import OUTER, TOP, WALL, Box, HalfPlane, SphereHole
from ...scene import Scene, SceneError
from ..fd.domain import is_stream, speed_scale  # the same rules as the fd model


@dataclass(frozen=True)
class AleDomain:
    """Everything but the sphere's position that shapes the mesh [m]."""

    radius: float  # R
    height: float  # Z
    refined: Box
    fine_size: float
    coarse_size: float
    grading: float
    gap_cells: float
    sphere_radius: float
    sides: dict  # WALL/OUTER/TOP -> boundary kind
    inflow_speed: float  # [m/s]
    initial_center: float  # z of the sphere centre at t = 0
    hold_gap: float  # the mesh's sphere stays at least this far above the wall

    def spec(self, center: float) -> HalfPlane:
        """The half-plane with the sphere cut out at z = center."""
        hole = SphereHole(center=center, radius=self.sphere_radius, surface_size=self.fine_size,
                          gap_cells=self.gap_cells)
        return HalfPlane(radius=self.radius, height=self.height, fine_size=self.fine_size,
                         coarse_size=self.coarse_size, grading=self.grading, refined=(self.refined,), hole=hole)

    def mesh_center(self, center: float) -> float:
        """Where the mesh puts a sphere whose centre is at `center` [m]: never below the hold gap."""
        return max(center, self.sphere_radius + self.hold_gap)


def domain_for(scene: Scene) -> AleDomain:
    ale = scene.numerics.ale
    diameter, radius = scene.sphere.diameter, scene.sphere.radius
    fine = diameter / ale.cells_per_diameter
    coarse = max(diameter / ale.coarse_cells_per_diameter, fine)
    center = scene.initial_gap + radius
    band = ale.refined_radius * diameter
    if is_stream(scene):
        refined = Box(r_max=band, z_min=max(center - band, 0.0), z_max=center + radius + ale.wake_length * diameter)
        sides = {WALL: "inflow", OUTER: "slip" if scene.container.unbounded else "no-slip", TOP: "outflow"}
        top_of_interest = refined.z_max
    else:
        top_of_interest = scene.initial_gap + diameter + ale.wake_length * diameter
        refined = Box(r_max=band, z_min=0.0, z_max=top_of_interest)
        sides = {WALL: "no-slip", OUTER: "slip", TOP: "slip"}
        if not scene.container.unbounded:
            sides = {WALL: "no-slip", OUTER: "no-slip", TOP: "no-slip"}
    if scene.container.unbounded:
        size_r, size_z = ale.far_field * diameter, top_of_interest + ale.far_field * diameter
    else:
        size_r, size_z = scene.container.radius, scene.container.height
        refined = Box(r_max=min(refined.r_max, size_r), z_min=refined.z_min, z_max=min(refined.z_max, size_z))
    if size_r < radius + 2.0 * fine:
        raise SceneError(f"numerics.ale: the domain radius {size_r:g} m leaves no fluid beside the sphere")
    if center + radius + 2.0 * fine > size_z:
        raise SceneError(f"numerics.ale: the domain height {size_z:g} m leaves no fluid above the sphere")
    # under the contact model's correction the mesh stops at delta_sl (contact.py); otherwise at hold_delta
    correcting = scene.contact.near_wall == "correction" and scene.motion.mode == "free"
    hold_gap = (scene.contact.delta_sl if correcting else ale.hold_delta) * diameter
    if scene.motion.mode == "fixed" and scene.initial_gap < hold_gap:
        raise SceneError(f"numerics.ale.hold_delta = {ale.hold_delta:g} is above the held sphere's gap "
                         f"{scene.initial_gap / diameter:g} D: lower it")
    return AleDomain(radius=size_r, height=size_z, refined=refined, fine_size=fine, coarse_size=coarse,
                     grading=ale.grading, gap_cells=ale.min_gap_cells, sphere_radius=radius, sides=sides,
                     inflow_speed=scene.motion.stream_velocity if is_stream(scene) else 0.0,
                     initial_center=center, hold_gap=hold_gap)


def time_step(scene: Scene) -> float:
    """dt = cfl * fine size / speed scale [s] (an accuracy limit: convection is implicit)."""
    ale = scene.numerics.ale
    return ale.cfl * scene.sphere.diameter / ale.cells_per_diameter / speed_scale(scene)


def is_steady(scene: Scene) -> bool:
    """A held sphere is solved for its steady state unless the scene asks for time marching."""
    return scene.motion.mode == "fixed" and scene.numerics.ale.fixed_solver == "steady"

