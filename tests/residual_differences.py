"""Central differences of the body equations' residual, shared by the Jacobian checks (tests/test_jacobian.py,
tests/test_oblique.py)."""
from __future__ import annotations

import numpy as np


def central(integrator, t, y, ydot, column: int, step: float, rates: bool = False) -> np.ndarray:
    """d G / d y_c (or d y'_c with `rates`) of integrator.residual by a central difference."""
    values = ydot if rates else y
    up, down = values.copy(), values.copy()
    up[column] += step
    down[column] -= step
    g_up = integrator.residual(t, *((y, up) if rates else (up, ydot))).copy()
    g_down = integrator.residual(t, *((y, down) if rates else (down, ydot))).copy()
    return (g_up - g_down) / (up[column] - down[column])  # the step as the arithmetic took it
