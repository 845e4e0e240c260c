"""The bodies on the axis: a scene's spheres, lowest first, each answering its own questions.

Sphere 1 is the scene's [sphere] with its [motion] and initial_gap; the second sphere is [second_sphere]
and every further one an entry of [[further_spheres]] (each with the second_sphere fields: its own
material, the gap between its surface and the one below, its velocity and mode).  The wall, when
wall.present, lies below sphere 1 as a body of infinite radius: it enters only through the contact of
sphere 1 with it (contact.ContactModel).  The integrator (integrator.py), the pair contact models, the
run's safeguards and the models' reports read mass, weight and motion here instead of from the scene's
fields.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Callable

from .motion import prescribed_velocity
from .scene import Scene, Sphere


@dataclass(frozen=True)
class Body:
    """One sphere on the axis: its material, how it moves and where it starts [SI]."""

    index: int  # 0: sphere 1, the lowest
    sphere: Sphere
    mode: str  # "free", "fixed" (held at its initial gap) or "prescribed"
    initial_gap: float  # its lowest point above z = 0 at the start [m]
    launch_velocity: float  # a free body's velocity at the start, positive upward [m/s]
    liquid_density: float  # [kg/m3]
    gravity: float  # its part along the wall's normal [m/s2]
    prescribed: Callable[[float], tuple[float, float]] = field(compare=False, repr=False)  # t -> (V, dV/dt)
    key: str = "sphere"  # the scene table it comes from, for messages

    @property
    def mass(self) -> float:
        """m [kg]."""
        return self.sphere.mass

    @property
    def displaced_mass(self) -> float:
        """m_l: the mass of liquid the sphere displaces [kg]."""
        return self.liquid_density * self.sphere.volume

    @property
    def net_weight(self) -> float:
        """(m - m_l) g, toward the wall (negative for a sphere lighter than the liquid) [N]."""
        return (self.mass - self.displaced_mass) * self.gravity

    @property
    def diameter(self) -> float:
        return self.sphere.diameter

    @property
    def free(self) -> bool:
        """It moves under the liquid, gravity and its contacts."""
        return self.mode == "free"

    @property
    def held(self) -> bool:
        """Fixed at its initial gap (its surface may still move at its velocity: a quasi-steady approach)."""
        return self.mode == "fixed"

    @property
    def start_velocity(self) -> float:
        """Its velocity at t = 0 [m/s]: the launch velocity when free, its motion's (a series' own V(0))
        otherwise."""
        return self.launch_velocity if self.free else self.prescribed(0.0)[0]


def scene_bodies(scene: Scene) -> tuple[Body, ...]:
    """The scene's spheres as bodies, lowest first (module docstring)."""
    # gravity's part along the wall's normal (an inclined wall, scene.gravity_angle: its part along the wall acts
    # on the tangential motion, fem_bounce.oblique)
    liquid, g = scene.liquid.density, scene.gravity * math.cos(math.radians(scene.gravity_angle))
    found = [Body(0, scene.sphere, scene.motion.mode, scene.initial_gap, scene.initial_velocity, liquid, g,
                  prescribed_velocity(scene))]
    gaps = scene.initial_gaps
    for k, sphere in enumerate(scene.spheres[1:], start=1):
        key = "second_sphere" if k == 1 else f"further_spheres[{k - 2}]"
        found.append(Body(k, sphere, sphere.mode, gaps[k], sphere.velocity, liquid, g, _constant_motion(sphere), key))
    return tuple(found)


def _constant_motion(sphere) -> Callable[[float], tuple[float, float]]:
    """An upper sphere's imposed motion: its `velocity`, moving when prescribed, the surface's when fixed
    (held in place with its surface moving, as sphere 1 with motion.mode = "fixed")."""
    return lambda t: (sphere.velocity, 0.0)


def sphere_scene(scene: Scene, k: int) -> Scene:
    """The scene as seen by sphere k alone (0: sphere 1): its material as `sphere`, its initial gap, no
    other sphere.  For the per-sphere theory forces; never run or validated."""
    return dataclasses.replace(scene, sphere=scene.spheres[k], initial_gap=scene.initial_gaps[k], second_sphere=None,
                               further_spheres=())
