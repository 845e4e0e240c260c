"""The rules that turn a scene into the meridian half-plane every finite-element model meshes (fd and ale
alike): which sides are walls, slip, inflow or outflow; how far the domain reaches; where the mesh is fine;
the speed that sets the time step.  Nothing is tuned per case: everything follows from the scene's geometry
(the sphere's path from release to the wall, the wake behind it, the stream for a fixed sphere) and the
model's `[numerics.*]` settings (refined_radius, wake_length, far_field), all in diameters.

- free / prescribed / fixed without a stream: the wall z = 0 is no-slip (slip when wall.present is false);
  an unbounded scene closes with slip (zero normal velocity) at r = R = far_field D and at
  z = Z = top of the path + far_field D, as the paper does; a container is no-slip all round.  The fine
  region covers r <= refined_radius D from the wall to wake_length D above the highest sphere top.
- fixed in a stream: uniform inflow through z = 0 (no wall), do-nothing outflow at the top, slip at r = R
  (no-slip in a container); the fine region runs from refined_radius D upstream of the sphere to
  wake_length D downstream.
"""
from __future__ import annotations

from dataclasses import dataclass

from ..motion import follows_series, is_free, is_stream, prescribed_velocity
from ..scene import Scene, SceneError
from .mesh import OUTER, TOP, WALL, Box


@dataclass(frozen=True)
class Extent:
    """The half-plane r <= radius, 0 <= z <= height [m], its fine region and its sides."""

    radius: float
    height: float
    refined: Box
    sides: dict  # WALL/OUTER/TOP -> boundary kind (fem.sides.SIDE_KINDS)
    inflow_speed: float  # [m/s]
    center: float  # z of the sphere centre at t = 0 [m]


def extent(scene: Scene, model: str) -> Extent:
    """The half-plane of the scene for the model whose `[numerics.model]` gives refined_radius,
    wake_length, far_field and cells_per_diameter."""
    settings = getattr(scene.numerics, model)
    diameter, radius = scene.sphere.diameter, scene.sphere.radius
    fine = diameter / settings.cells_per_diameter
    center = scene.initial_gap + radius
    band = settings.refined_radius * diameter
    if is_stream(scene):
        refined = Box(r_max=band, z_min=max(center - band, 0.0),
                      z_max=center + radius + settings.wake_length * diameter)
        sides = {WALL: "inflow", OUTER: "slip" if scene.container.unbounded else "no-slip", TOP: "outflow"}
        top_of_interest = refined.z_max
    else:
        # a pair: the fine region spans both spheres (the first sphere's D sets the cells); without the
        # wall z = 0 is a slip side below the pair and the fine region starts wake_length D under it
        widest = max(sphere.diameter for sphere in scene.spheres)
        band = settings.refined_radius * widest
        top_of_interest = scene.initial_gaps[-1] + scene.spheres[-1].diameter + settings.wake_length * widest
        bottom = 0.0 if scene.wall.present else max(scene.initial_gap - settings.wake_length * widest, 0.0)
        refined = Box(r_max=band, z_min=bottom, z_max=top_of_interest)
        floor = "no-slip" if scene.wall.present else "slip"
        sides = {WALL: floor, OUTER: "slip", TOP: "slip"}
        if not scene.container.unbounded:
            sides = {WALL: floor, OUTER: "no-slip", TOP: "no-slip"}
    if scene.container.unbounded:
        size_r = settings.far_field * diameter
        size_z = top_of_interest + settings.far_field * diameter
    else:
        size_r, size_z = scene.container.radius, scene.container.height
        refined = Box(r_max=min(refined.r_max, size_r), z_min=refined.z_min, z_max=min(refined.z_max, size_z))
    keys = ["sphere", *(["second_sphere"] if scene.pair else []),
            *(f"further_spheres[{k}]" for k in range(len(scene.further_spheres)))]
    for key, sphere in zip(keys, scene.spheres):
        if size_r < sphere.radius + 2.0 * fine:
            where = ("container.radius" if not scene.container.unbounded
                     else f"numerics.{model}.far_field = {settings.far_field:g} D of sphere 1")
            raise SceneError(f"{key}.diameter = {sphere.diameter:g} m does not fit in the {model} model's domain: its "
                             f"radius {size_r:.4g} m ({where}) leaves no fluid beside it; allowed below "
                             f"{2.0 * (size_r - 2.0 * fine):.4g} m")
    return Extent(radius=size_r, height=size_z, refined=refined, sides=sides,
                  inflow_speed=scene.motion.stream_velocity if is_stream(scene) else 0.0, center=center)


def speed_scale(scene: Scene, model: str = "fd") -> float:
    """The speed that sets the time step [m/s]: the estimated impact speed of a free sphere,
    the largest imposed speed otherwise."""
    motion, free = scene.motion, is_free(scene)
    if scene.pair:  # the fastest of sphere 1's fall or imposed speed and the upper spheres' starts
        own = scene.estimated_impact_speed() if free else abs(motion.velocity)
        return max(own, *(abs(sphere.velocity) for sphere in scene.spheres[1:]))
    if free:  # above zero: Scene.validate refuses a neutrally buoyant free sphere
        return scene.estimated_impact_speed()
    speed = max(abs(motion.velocity), abs(motion.stream_velocity))
    if follows_series(scene):
        profile = prescribed_velocity(scene)
        samples = [abs(profile(t)[0]) for t in [k * scene.run.end_time / 200 for k in range(201)]]
        speed = max(samples)
    if speed <= 0.0:
        raise SceneError(f"numerics.{model}: a fixed or prescribed sphere needs a nonzero motion.velocity or "
                         "motion.stream_velocity to set the time step")
    return speed
