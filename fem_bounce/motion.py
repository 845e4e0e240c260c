"""How the sphere moves (scene [motion]), in one place: free (it falls and bounces), fixed (held at its
initial gap, its surface moving at `velocity`, possibly in a stream entering through z = 0) or
prescribed (it moves with `velocity`, or along the (t, velocity) CSV `series`).

The flow models, their domains, the contact model and the studies ask these questions here (or of
bodies.Body) instead of each branching on motion.mode.
"""
from __future__ import annotations

from typing import Callable

from .scene import Scene, read_series


def is_free(scene: Scene) -> bool:
    return scene.motion.mode == "free"


def is_held(scene: Scene) -> bool:
    """Fixed at its initial gap (its surface may still move: a quasi-steady approach)."""
    return scene.motion.mode == "fixed"


def is_stream(scene: Scene) -> bool:
    """A held sphere in a stream entering through z = 0 (no wall there)."""
    return is_held(scene) and scene.motion.stream_velocity != 0.0


def follows_series(scene: Scene) -> bool:
    """Prescribed along the (t, velocity) CSV motion.series (not at a constant motion.velocity)."""
    return scene.motion.mode == "prescribed" and bool(scene.motion.series)


def series_speed(scene: Scene) -> float:
    """The largest speed in a prescribed motion's series [m/s] (0 without one)."""
    if not follows_series(scene):
        return 0.0
    return max(abs(v) for v in read_series(scene.motion.series)[1])


def prescribed_velocity(scene: Scene) -> Callable[[float], tuple[float, float]]:
    """t -> (V [m/s], dV/dt [m/s2]) for fixed and prescribed motion."""
    motion = scene.motion
    if not follows_series(scene):
        return lambda t: (motion.velocity, 0.0)
    from scipy.interpolate import CubicSpline

    spline = CubicSpline(*read_series(motion.series))
    derivative = spline.derivative()
    return lambda t: (float(spline(t)), float(derivative(t)))
