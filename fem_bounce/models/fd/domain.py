"""From a scene to the fictitious-domain problem: mesh spec, boundary kinds, time step.

The half-plane, its sides and its fine region follow the rules every finite-element model shares
(fem.domain); here the fd model adds its triangle sizes and its time step.
"""
from __future__ import annotations

from dataclasses import dataclass

from ...fem.domain import extent, speed_scale
from ...fem.mesh import Box, HalfPlane
from ...motion import is_stream
from ...scene import Scene


@dataclass(frozen=True)
class Domain:
    spec: HalfPlane
    sides: dict  # WALL/OUTER/TOP -> boundary kind (fem.sides.SIDE_KINDS)
    inflow_speed: float  # [m/s]
    center: float  # z of the sphere centre at t = 0 [m]
    fine_size: float  # [m]


def domain_for(scene: Scene, patch_centers=None) -> Domain:
    """The fd model's half-plane: refined along the whole path, or (numerics.fd.patch) only in the patches
    around the spheres' centres `patch_centers` [m] (patch_boxes)."""
    fd = scene.numerics.fd
    diameter = scene.sphere.diameter
    fine = diameter / fd.cells_per_diameter
    coarse = max(diameter / fd.coarse_cells_per_diameter, fine)
    half_plane = extent(scene, "fd")
    boxes = (half_plane.refined,) if patch_centers is None else patch_boxes(scene, patch_centers, half_plane.height)
    if fd.wall_cells_per_diameter > 0 and not is_stream(scene):  # finer triangles in the gap under the path
        wall_size = diameter / fd.wall_cells_per_diameter
        if wall_size < fine:
            boxes += (Box(r_max=min(fd.wall_radius * diameter, half_plane.radius), z_min=0.0,
                          z_max=min(fd.wall_layer * diameter, half_plane.height), size=wall_size),)
    spec = HalfPlane(radius=half_plane.radius, height=half_plane.height, fine_size=fine, coarse_size=coarse,
                     grading=fd.resolved("grading"), refined=boxes)
    return Domain(spec=spec, sides=half_plane.sides, inflow_speed=half_plane.inflow_speed, center=half_plane.center,
                  fine_size=fine)


def patch_boxes(scene: Scene, centers, height: float) -> tuple[Box, ...]:
    """One fine box per sphere: r <= refined_radius D, z within patch_margin D of the sphere's top and bottom,
    reaching down to the wall once its lower edge is within a margin of it (the gap is then in the patch)."""
    fd = scene.numerics.fd
    boxes = []
    for sphere, center in zip(scene.spheres, centers):
        margin = fd.patch_margin * sphere.diameter
        low = center - sphere.radius - margin
        boxes.append(Box(r_max=fd.refined_radius * sphere.diameter, z_min=0.0 if low < margin else low,
                         z_max=min(center + sphere.radius + margin, height)))
    return tuple(boxes)


def patch_center(scene: Scene, center: float, index: int = 0) -> float:
    """Where a patch around a sphere centred at z = center [m] is centred: on a grid of half the margin, so that
    the same positions make the same (cached) meshes and a restart makes its run's mesh again."""
    spacing = 0.5 * scene.numerics.fd.patch_margin * scene.spheres[index].diameter
    return round(center / spacing) * spacing


PEAK_SPEED_FACTOR = 1.5  # the fastest fluid: 1.5 U at the equator of a sphere in potential flow


def time_step(scene: Scene) -> float:
    """dt = peak_cfl h / (1.5 U) [s], h the fine size, U the speed scale (peak_cfl the Courant number at the peak
    fluid speed 1.5 U); with the penalty constraint
    (numerics.fd.constraint = "penalty") also dt <= forcing_number h^2 / nu.

    The first bound keeps the extrapolated convection stable where the fluid is
    fastest, beside the sphere (with peak_cfl = 0.2 the flow past a sphere at Re = 200 is
    stable, at 0.3 it blows up there within 40 steps).  The second keeps the immersed
    force rho c phi (U - u~), c ~ 1/dt, stronger than viscous diffusion across the
    indicator's band; it binds at low Re, where it sets how rigid the interior is
    (Brenner's drag at delta = 1 comes out 1.4 % low at 0.025, 3.4 % at 0.05, 16 cells per D).
    The implicit constraint holds the interior whatever dt, so it has only the first bound."""
    fd = scene.numerics.fd
    fine = scene.sphere.diameter / fd.cells_per_diameter
    convective = fd.resolved("peak_cfl") * fine / (PEAK_SPEED_FACTOR * speed_scale(scene, "fd"))
    if fd.constraint != "penalty":
        return convective
    return min(convective, fd.forcing_number * fine**2 / scene.liquid.kinematic_viscosity)


def penalty_rate(scene: Scene, size: float | None = None) -> float:
    """c_B = penalty_strength * max(nu / h^2, U / h, c) [1/s] of numerics.fd.constraint = "implicit"
    (penalised.PenalisedFlow), c = 3 / (2 dt), h the size of the triangles the band lies on (`size` [m]; by
    default the fine size), U the speed scale: the friction beats viscous diffusion and convection across a
    cell, and the step's own inertia, by that factor."""
    fd = scene.numerics.fd
    h = scene.sphere.diameter / fd.cells_per_diameter if size is None else size
    rates = (scene.liquid.kinematic_viscosity / h**2, speed_scale(scene, "fd") / h, 1.5 / time_step(scene))
    return fd.penalty_strength * max(rates)
