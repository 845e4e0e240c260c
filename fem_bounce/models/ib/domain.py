"""Where the grid goes for a scene: a uniform region around the sphere's whole path,
graded cells out to the far field, and the kind of each boundary.

- bottom z = 0: the wall (no slip), or, for a fixed sphere in a stream, the inflow;
- outer side and top: a closed container's walls, or the paper's slip far field
  (`far_field` diameters beyond the uniform region); a stream leaves through a
  convective outflow at the top.
"""
from __future__ import annotations

import math

from ...motion import is_free, is_held, is_stream, series_speed
from ...scene import Scene
from .grid import INFLOW, OUTFLOW, SLIP, WALL, Boundaries, StaggeredGrid, make_grid


def path_range(scene: Scene) -> tuple[float, float]:
    """(lowest, highest) z the sphere's surface can reach during the run [m]."""
    d, h0, end = scene.sphere.diameter, scene.initial_gap, scene.run.end_time
    if is_held(scene):
        return h0, h0 + d
    if not is_free(scene):  # prescribed
        speed = series_speed(scene) if scene.motion.series else abs(scene.motion.velocity)
        return max(0.0, h0 - speed * end), h0 + d + speed * end
    if scene.sphere.density >= scene.liquid.density:
        return 0.0, h0 + d  # a heavy sphere never climbs above its release height
    rise = scene.terminal_speed() * end  # a light one rises
    top = scene.container.height if scene.container.height else math.inf
    return h0, min(h0 + d + rise, top)


def boundaries(scene: Scene) -> Boundaries:
    stream = scene.motion.stream_velocity if is_stream(scene) else 0.0
    closed = not scene.container.unbounded
    if stream:
        if closed:
            raise ValueError("a stream through a closed container is not supported: use container = \"unbounded\"")
        return Boundaries(bottom=INFLOW, top=OUTFLOW, outer=SLIP, inflow_velocity=stream)
    return Boundaries(bottom=WALL, top=WALL if closed else SLIP, outer=WALL if closed else SLIP)


def build_grid(scene: Scene) -> StaggeredGrid:
    """The graded grid of a scene, its fine spacing h = D / numerics.ib.cells_per_diameter."""
    opts = scene.numerics.ib
    d = scene.sphere.diameter
    h = d / opts.cells_per_diameter
    lo, hi = path_range(scene)
    fine_z = (max(0.0, lo - opts.fine_margin * d), hi + opts.fine_margin * d)
    fine_r = opts.fine_radius * d
    if scene.container.unbounded:
        radius = fine_r + opts.far_field * d
        height = fine_z[1] + opts.far_field * d
    else:
        radius, height = scene.container.radius, scene.container.height
        fine_z = (fine_z[0], min(fine_z[1], height))
        fine_r = min(fine_r, radius)
    return make_grid(h, fine_r, fine_z, radius, height, opts.growth, boundaries(scene))
