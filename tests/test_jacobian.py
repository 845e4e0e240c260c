"""The integrator's exact Jacobian against differences of its residual (a fast path against a plain
reference): free fall, the lubrication film, a Hertz contact, the paper's spring and the ehd handover, the
other theory choices, a resolved flow's correction and blend, and one, two and three spheres.  Each force
term gives its derivatives beside its value (integrator.ForceTerms); a term added without them fails here."""
from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI  # noqa: F401  (loads MPI before PETSc)

from fem_bounce import scene as scenes
from fem_bounce.integrator import BodyIntegrator, FluidForce

D = 0.0095  # the presets' sphere diameter [m]
FLOW_1 = FluidForce(np.array([0.01]), np.array([[0.002]]))
FLOW_2 = FluidForce(np.array([0.01, -0.02]), np.array([[0.002, 0.0003], [0.0003, 0.002]]))


def differences(integrator, t, y, ydot, shift, scale):
    """dG/dy + shift dG/dy' by central differences, column by column, with steps `scale` times the
    state's own size in the gaps (down to 1e-12 m: a contact gap is a few tenths of a micrometre) and the
    velocities; G is linear in y' and in the history modes, whose steps are large (no round-off)."""
    count, n = len(integrator.bodies), len(y)
    jac = np.zeros((n, n))
    for c in range(n):
        if c >= 2 * count:
            state_step = 1e-3 * max(abs(y[c]), 1.0)
        else:
            state_step = scale * max(abs(y[c]), 1e-12 if c % 2 == 0 else 1e-6)
        for values, weight, step in ((y, 1.0, state_step), (ydot, shift, 1e-3 * max(abs(ydot[c]), 1.0))):
            up, down = values.copy(), values.copy()
            up[c] += step
            down[c] -= step
            pair = ((up, ydot), (down, ydot)) if values is y else ((y, up), (y, down))
            jac[:, c] += weight * (integrator.residual(t, *pair[0]).copy()
                                   - integrator.residual(t, *pair[1]).copy()) / (2.0 * step)
    return jac


CASES = {  # preset, scene changes, gaps (h_1, s_1, ...) [m], velocities [m/s], contacts engaged (index, speed)
    "free fall": ("li2011-case3", {}, [0.5 * D], [-0.3], (), None),
    "film approaching": ("li2011-case3", {}, [1e-5], [-0.3], (), None),
    "film separating": ("li2011-case3", {}, [1e-5], [0.2], (), None),  # the tension limit: the film cavitates
    "film separating, no tension": ("li2011-case3", {"contact.cavitation_pressure": 0.0}, [1e-5], [0.2], (), None),
    "resolved, correction, separating": ("li2011-case3", {}, [1e-5], [0.2], (), FLOW_1),
    "hertz, film fading": ("li2011-case3", {}, [1.5e-7], [-0.3], [(0, 0.35)], None),
    "hertz, overlapping": ("li2011-case3", {}, [-3e-6], [0.2], [(0, 0.35)], None),
    "hertz, history paused": ("li2011-case3", {"contact.history_across_contact": "pause"}, [-3e-6], [0.2],
                              [(0, 0.35)], None),
    "paper's spring": ("li2011-case3", {"contact.model": "li2011"}, [1e-4], [-0.3], [(0, 0.35)], None),
    "ehd, above h0": ("li2011-case3", {"contact.model": "ehd"}, [3e-5], [-0.3], (), None),
    "exact image sum, multiplied drag, drag-scaled history": (
        "li2011-case3", {"contact.added_mass": "exact", "contact.inertial_factor": "schiller-naumann",
                         "contact.history_wall_factor": "drag-scaled"}, [2e-4], [-0.3], (), None),
    "drag-scaled history in hertz": ("li2011-case3", {"contact.history_wall_factor": "drag-scaled"}, [1.5e-7],
                                     [-0.3], [(0, 0.35)], None),
    "screened drag, free fall": ("li2011-case3", {"contact.inertial_factor": "screened"}, [0.5 * D], [-0.3], (), None),
    "screened drag, slow (all inertia taken)": ("li2011-case3", {"contact.inertial_factor": "screened"}, [0.2 * D],
                                                [-0.01], (), None),
    "screened drag, film separating": ("li2011-case3", {"contact.inertial_factor": "screened"}, [1e-5], [0.2], (),
                                       None),
    "simple wall drag": ("li2011-case3", {"contact.wall_drag": "simple"}, [1e-3], [-0.3], (), None),
    "prescribed": ("li2011-case3", {"motion.mode": "prescribed", "motion.velocity": -0.1}, [1e-3], [-0.1], (),
                   None),
    "resolved, correction": ("li2011-case3", {}, [1e-3], [-0.3], (), FLOW_1),
    "resolved, paper's blend": ("li2011-case3", {"contact.near_wall": "blend"}, [1.7e-3], [-0.3], (), FLOW_1),
    "pair, film": ("yang-hunt2006-pair", {}, [0.1, 1e-4], [0.3, -0.1], (), None),
    "pair, film separating": ("yang-hunt2006-pair", {}, [0.1, 1e-5], [-0.1, 0.2], (), None),
    "pair resolved, film separating": ("yang-hunt2006-pair", {}, [0.1, 1e-5], [-0.1, 0.2], (), FLOW_2),
    "pair, hertz": ("yang-hunt2006-pair", {}, [0.1, 2e-7], [0.3, -0.1], [(0, 0.3)], None),
    "pair and wall, films, drag-scaled history": (
        "pair-settling-wall", {"contact.history_wall_factor": "drag-scaled"}, [2e-4, 3e-5], [-0.2, -0.25], (), None),
    "pair and wall, wall hertz": ("pair-settling-wall", {}, [1e-7, 3e-5], [0.1, -0.25], [(1, 0.2)], None),
    "pair and wall, resolved": ("pair-settling-wall", {}, [2e-4, 1e-3], [-0.2, -0.25], (), FLOW_2),
    "three, films": ("three-spheres-wall", {}, [2e-4, 3e-5, 1e-3], [-0.2, -0.25, -0.1], (), None),
    "three, drag-scaled history": ("three-spheres-wall", {"contact.history_wall_factor": "drag-scaled"},
                                   [2e-4, 3e-5, 1e-3], [-0.2, -0.25, -0.1], (), None),
    "three, wall and pair hertz": ("three-spheres-wall", {}, [1e-7, 3e-8, 1e-3], [0.05, -0.25, -0.1],
                                   [(0, 0.2), (2, 0.2)], None),
}


@pytest.mark.parametrize("case", CASES)
def test_the_exact_jacobian_matches_differences(case):
    preset, changes, gaps, velocities, engaged, fluid = CASES[case]
    integrator = BodyIntegrator(scenes.load(preset, changes), resolved=fluid is not None)
    try:
        if fluid is not None:
            integrator.fluid = fluid
        count = len(integrator.bodies)
        rng = np.random.default_rng(7)
        y = np.array(integrator.y.array_r)
        y[0:2 * count:2], y[1:2 * count:2] = gaps, velocities
        y[2 * count:] = 1e-3 * rng.normal(size=len(y) - 2 * count)  # history modes
        ydot = rng.normal(size=len(y))
        for index, speed in engaged:
            contact = integrator.contacts[index]
            contact.record.contact_crossing(y[contact.gap_index], -speed)
        shift, t = 1e3, 0.01
        exact = integrator.jacobian(t, y, ydot, shift)
        fine, coarse = (differences(integrator, t, y, ydot, shift, scale) for scale in (1e-6, 4e-6))
        # the differences' own error: their change between the two steps (round-off grows as the step
        # falls, truncation as it grows); a missing derivative is far larger than both
        row_scale = np.abs(fine).max(axis=1, keepdims=True)
        allowed = 1e-7 * np.abs(fine) + 1e-9 * row_scale + 10.0 * np.abs(fine - coarse)
        worst = np.unravel_index(np.argmax(np.abs(exact - fine) - allowed), exact.shape)
        assert np.all(np.abs(exact - fine) <= allowed), (
            f"d G[{worst[0]}] / d y[{worst[1]}]: exact {exact[worst]:.9g}, differences {fine[worst]:.9g}")
    finally:
        integrator.destroy()
