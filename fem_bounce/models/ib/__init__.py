"""The immersed-boundary model (the paper's method, section 2.1): see model.py.

grid (staggered axisymmetric grid), domain (where the grid goes for a scene),
operators (radially weighted finite volumes), delta (regularised delta,
interpolation and spreading), body (Lagrangian points), solver (one projection
step with implicit forces), snapshots (field output), model (time loop and
coupling to the shared sphere integrator).
"""
from .model import ImmersedBoundaryModel

__all__ = ["ImmersedBoundaryModel"]
