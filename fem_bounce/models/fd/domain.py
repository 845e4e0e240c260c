"""From a scene to the fictitious-domain problem: mesh spec, boundary kinds, time step.

Nothing here is tuned per case: the domain and its refined region follow from the
scene's geometry (the sphere's path from release to the wall, the wake behind it,
the stream for a fixed sphere) and the `[numerics.fd]` settings, all in diameters.

- free / prescribed / fixed without a stream: the wall z = 0 is no-slip; an
  unbounded scene closes with slip (zero normal velocity) at r = R = far_field D
  and at z = Z = top of the path + far_field D, as the paper does; a container is
  no-slip all round.  The fine region covers r <= refined_radius D from the wall
  to wake_length D above the highest sphere top.
- fixed in a stream: uniform inflow through z = 0 (no wall), do-nothing outflow
  at the top, slip at r = R; the fine region runs from refined_radius D upstream
  of the sphere to wake_length D downstream.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from ...fem.mesh import OUTER, TOP, WALL, Box, HalfPlane
from ...scene import Scene, SceneError
from ...sphere import prescribed_velocity


@dataclass(frozen=True)
class Domain:
    spec: HalfPlane
    sides: dict  # WALL/OUTER/TOP -> boundary kind (fluid.SIDE_KINDS)
    inflow_speed: float  # [m/s]
    center: float  # z of the sphere centre at t = 0 [m]
    fine_size: float  # [m]


def is_stream(scene: Scene) -> bool:
    return scene.motion.mode == "fixed" and scene.motion.stream_velocity != 0.0


def domain_for(scene: Scene) -> Domain:
    fd = scene.numerics.fd
    diameter, radius = scene.sphere.diameter, scene.sphere.radius
    fine = diameter / fd.cells_per_diameter
    coarse = max(diameter / fd.coarse_cells_per_diameter, fine)
    center = scene.initial_gap + radius
    band = fd.refined_radius * diameter
    if is_stream(scene):
        refined = Box(r_max=band, z_min=max(center - band, 0.0), z_max=center + radius + fd.wake_length * diameter)
        sides = {WALL: "inflow", OUTER: "slip", TOP: "outflow"}
        if not scene.container.unbounded:
            sides[OUTER] = "no-slip"
        top_of_interest = refined.z_max
    else:
        top_of_interest = scene.initial_gap + diameter + fd.wake_length * diameter
        refined = Box(r_max=band, z_min=0.0, z_max=top_of_interest)
        sides = {WALL: "no-slip", OUTER: "slip", TOP: "slip"}
        if not scene.container.unbounded:
            sides = {WALL: "no-slip", OUTER: "no-slip", TOP: "no-slip"}
    if scene.container.unbounded:
        size_r = fd.far_field * diameter
        size_z = top_of_interest + fd.far_field * diameter
    else:
        size_r, size_z = scene.container.radius, scene.container.height
        refined = Box(r_max=min(refined.r_max, size_r), z_min=refined.z_min, z_max=min(refined.z_max, size_z))
    if size_r < radius + 2.0 * fine:
        raise SceneError(f"numerics.fd: the domain radius {size_r:g} m leaves no fluid beside the sphere")
    boxes = (refined,)
    if fd.wall_cells_per_diameter > 0 and not is_stream(scene):
        wall_size = diameter / fd.wall_cells_per_diameter
        if wall_size < fine:
            boxes += (Box(r_max=min(fd.wall_radius * diameter, size_r), z_min=0.0,
                          z_max=min(fd.wall_layer * diameter, size_z), size=wall_size),)
    spec = HalfPlane(radius=size_r, height=size_z, fine_size=fine, coarse_size=coarse, grading=fd.grading,
                     refined=boxes)
    return Domain(spec=spec, sides=sides, inflow_speed=scene.motion.stream_velocity if is_stream(scene) else 0.0,
                  center=center, fine_size=fine)


def speed_scale(scene: Scene) -> float:
    """The speed that sets the time step [m/s]: the estimated impact speed of a free sphere,
    the largest imposed speed otherwise."""
    motion = scene.motion
    if motion.mode == "free":
        if scene.estimated_impact_speed() <= 0.0:
            raise SceneError(f"sphere.density = {scene.sphere.density:g} kg/m3 equals liquid.density: a neutrally "
                             "buoyant sphere released from rest never moves; make it heavier or lighter")
        return scene.estimated_impact_speed()
    speed = max(abs(motion.velocity), abs(motion.stream_velocity))
    if motion.mode == "prescribed" and motion.series:
        profile = prescribed_velocity(scene)
        samples = [abs(profile(t)[0]) for t in [k * scene.run.end_time / 200 for k in range(201)]]
        speed = max(samples)
    if speed <= 0.0:
        raise SceneError("numerics.fd: a fixed or prescribed sphere needs a nonzero motion.velocity or "
                         "motion.stream_velocity to set the time step")
    return speed


PEAK_SPEED_FACTOR = 1.5  # the fastest fluid: 1.5 U at the equator of a sphere in potential flow


def time_step(scene: Scene) -> float:
    """dt = cfl h / (1.5 U) [s], h the fine size, U the speed scale; with the penalty constraint
    (numerics.fd.constraint = "penalty") also dt <= forcing_number h^2 / nu.

    The first bound keeps the extrapolated convection stable where the fluid is
    fastest, beside the sphere (with cfl = 0.2 the flow past a sphere at Re = 200 is
    stable, at 0.3 it blows up there within 40 steps).  The second keeps the immersed
    force rho c phi (U - u~), c ~ 1/dt, stronger than viscous diffusion across the
    indicator's band; it binds at low Re, where it sets how rigid the interior is
    (Brenner's drag at delta = 1 comes out 1.4 % low at 0.025, 3.4 % at 0.05, 16 cells per D).
    The multiplier constraint holds the interior rigid whatever dt, so it has only the first bound."""
    fd = scene.numerics.fd
    fine = scene.sphere.diameter / fd.cells_per_diameter
    convective = fd.cfl * fine / (PEAK_SPEED_FACTOR * speed_scale(scene))
    if fd.constraint == "multiplier":
        return convective
    return min(convective, fd.forcing_number * fine**2 / scene.liquid.kinematic_viscosity)


def steps_to(end_time: float, dt: float) -> int:
    return max(1, math.ceil(end_time / dt - 1e-9))
