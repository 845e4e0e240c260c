"""The ale model's time step, the bounds of its adaptive steps and when held spheres are solved steady.

Its mesh, the half-plane around the spheres with every sphere on the axis cut out (and the gaps at which it
stops following them), is the moving mesh's domain (models/moving_mesh.py: MovingMeshDomain, domain_for).
"""
from __future__ import annotations

from ...bodies import scene_bodies
from ...fem.domain import speed_scale
from ...flow_model import StepLimits, approach_for
from ...scene import Scene


def time_step(scene: Scene) -> float:
    """dt = cfl * fine size / speed scale [s] (an accuracy limit: convection is implicit)."""
    ale = scene.numerics.ale
    return ale.cfl * scene.sphere.diameter / ale.cells_per_diameter / speed_scale(scene, "ale")


def step_limits(scene: Scene) -> StepLimits:
    """The adaptive step's bounds (numerics.ale.adaptive_step; flow_model.StepLimits): each step between
    min_step_factor and max_step_factor times the cfl step, closing at most GAP_FRACTION of the gap (and never
    more than twice that, from rest and below the floor too: flow_model.Approach)."""
    ale = scene.numerics.ale
    return StepLimits(time_step(scene), ale.min_step_factor, ale.max_step_factor, speed_scale(scene, "ale"),
                      approach=approach_for(scene))


def is_steady(scene: Scene) -> bool:
    """Held spheres (every one held) are solved for their steady state unless the scene asks for time
    marching."""
    return all(body.held for body in scene_bodies(scene)) and scene.numerics.ale.fixed_solver == "steady"

