"""The integrator's exact Jacobian against differences of its residual (a fast path against a plain
reference): free fall, the lubrication film, a Hertz contact, the paper's spring and the ehd handover, the
other theory choices, a resolved flow's correction and blend, and one, two and three spheres.  Each force
term gives its derivatives beside its value (integrator.ForceTerms); a term added without them fails here."""
from __future__ import annotations

import numpy as np
import pytest
from mpi4py import MPI  # noqa: F401  (loads MPI before PETSc)

from fem_bounce import scene as scenes
from fem_bounce.integrator import BodyIntegrator
from fem_bounce.kinematics import FluidForce
from residual_differences import central

D = 0.0095  # the presets' sphere diameter [m]
FLOW_1 = FluidForce(np.array([0.01]), np.array([[0.002]]))
FLOW_2 = FluidForce(np.array([0.01, -0.02]), np.array([[0.002, 0.0003], [0.0003, 0.002]]))


EPSILON = float(np.finfo(float).eps)
ROUND_OFF_OPERATIONS = 100.0  # a residual entry's round-off, in units of eps times the size of its terms
RELATIVE_STEPS = 10.0 ** np.arange(-5, 0)  # of each unknown's own scale (state_scales)
DIAMETER_STEPS = 10.0 ** np.arange(-8, -3)  # of the smallest sphere's diameter, for the gaps


def state_scales(integrator, y) -> np.ndarray:
    """The size of each unknown: a gap its own (down to 1e-12 m: a contact gap is a few tenths of a
    micrometre), a velocity its own (down to 1e-6 m/s), a history mode 1 (G is linear in the modes)."""
    count = len(integrator.bodies)
    scales = np.maximum(np.abs(y), 1.0)
    scales[0:2 * count:2] = np.maximum(np.abs(y[0:2 * count:2]), 1e-12)
    scales[1:2 * count:2] = np.maximum(np.abs(y[1:2 * count:2]), 1e-6)
    return scales


def differences(integrator, t, y, ydot, shift):
    """(dG/dy + shift dG/dy', its error bound) by differences of the residual, entry by entry.

    One step cannot serve a whole column: a 3e-8 m pair gap moves that pair's film on the scale of the gap
    and a sphere above it on the scale of its diameter, and a step small enough for the first leaves the
    second's change in the residual's last digits (a step of 1e-6 of the gap did).  So each column is
    differenced at a ladder of steps (RELATIVE_STEPS of the unknown, DIAMETER_STEPS for a gap), each a
    Richardson pair (h, h/2): the derivative to O(h^4), with the truncation bound |D(h/2) - D(h)| and a
    round-off bound from the residual's own terms (an entry G_i made of terms of size T_i carries
    ~ eps T_i, T_i = |G_i| + sum_j |dG_i/dy_j| y_j + |dG_i/dy'_j y'_j|, divided by the step).  Each entry
    takes the step whose bound is smallest.  G is linear in y' (one step of 1e-3 of its size)."""
    n, scales = len(y), state_scales(integrator, y)
    gaps = np.zeros(n, dtype=bool)
    gaps[0:2 * len(integrator.bodies):2] = True
    smallest = min(body.diameter for body in integrator.bodies)
    rate_steps = 1e-3 * np.maximum(np.abs(ydot), 1.0)
    by_rates = np.column_stack([central(integrator, t, y, ydot, c, rate_steps[c], rates=True) for c in range(n)])
    ladders = [np.unique(np.r_[RELATIVE_STEPS * scales[c], DIAMETER_STEPS * smallest if gaps[c] else []])
               for c in range(n)]
    pairs = [[(central(integrator, t, y, ydot, c, h), central(integrator, t, y, ydot, c, 0.5 * h)) for h in ladder]
             for c, ladder in enumerate(ladders)]
    # the size of each row's terms, from the differences at each column's smallest step
    first = np.column_stack([pairs[c][0][1] for c in range(n)])
    terms = (np.abs(integrator.residual(t, y, ydot)) + np.abs(first) @ np.abs(y)
             + np.abs(by_rates) @ np.abs(ydot))
    estimate, bound = np.zeros((n, n)), np.full((n, n), np.inf)
    for c in range(n):
        for h, (coarse, fine) in zip(ladders[c], pairs[c]):
            error = np.abs(fine - coarse) + ROUND_OFF_OPERATIONS * EPSILON * terms * 3.0 / h
            better = error < bound[:, c]
            estimate[better, c] = ((4.0 * fine - coarse) / 3.0)[better]
            bound[better, c] = error[better]
    bound += shift * ROUND_OFF_OPERATIONS * EPSILON * terms[:, None] / rate_steps[None, :]
    return estimate + shift * by_rates, bound


def jacobian_mismatch(integrator, t, y, ydot, shift) -> str | None:
    """None when the exact Jacobian agrees with the differences within their error bound, else the worst entry."""
    exact = integrator.jacobian(t, y, ydot, shift)
    estimate, bound = differences(integrator, t, y, ydot, shift)
    allowed = bound + 1e-10 * np.abs(estimate)
    excess = np.abs(exact - estimate) - allowed
    if np.all(excess <= 0.0):
        return None
    worst = np.unravel_index(np.argmax(excess / np.maximum(allowed, 1e-300)), exact.shape)
    return (f"d G[{worst[0]}] / d y[{worst[1]}]: exact {exact[worst]:.9g}, differences {estimate[worst]:.9g} "
            f"+- {allowed[worst]:.3g}")


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
    "pair off its line of centres, film": ("yang-hunt2006-pair", {"second_sphere.tangential_velocity": 0.1,
                                                                  "contact.friction": 0.1},
                                           [0.1, 1e-4], [0.3, -0.1], (), None),
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


def prepared(case: str, integrator_class=BodyIntegrator):
    """(integrator, t, y, y', shift) at the case's state: its gaps and velocities, random history modes and
    rates, its contacts engaged at the given approach speeds."""
    preset, changes, gaps, velocities, engaged, fluid = CASES[case]
    integrator = integrator_class(scenes.load(preset, changes), resolved=fluid is not None)
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
    return integrator, 0.01, y, ydot, 1e3


@pytest.mark.parametrize("case", CASES)
def test_the_exact_jacobian_matches_differences(case):
    integrator, t, y, ydot, shift = prepared(case)
    try:
        mismatch = jacobian_mismatch(integrator, t, y, ydot, shift)
        assert mismatch is None, mismatch
    finally:
        integrator.destroy()


class Forgetful(BodyIntegrator):
    """An integrator whose force terms leave out one kind of derivative (`forgotten`: a ForceTerms list)."""

    forgotten = ""

    def forces(self, t, y):
        terms = super().forces(t, y)
        getattr(terms, self.forgotten).clear()
        return terms


@pytest.mark.parametrize(("case", "forgotten"), [
    ("three, wall and pair hertz", "other_slopes"),  # the contacts' elastic derivatives
    ("three, films", "theory_slopes"),  # drag, pair interaction and history
    ("pair, film", "theory_mass_slopes"),  # the pair's added mass in its gap
    ("resolved, correction", "correction_mass_slopes"),
])
def test_a_missing_derivative_fails_the_check(case, forgotten):
    """The check is not blind: a force term that leaves out its derivatives is caught."""
    integrator, t, y, ydot, shift = prepared(case, type("Planted", (Forgetful,), {"forgotten": forgotten}))
    try:
        assert jacobian_mismatch(integrator, t, y, ydot, shift) is not None
    finally:
        integrator.destroy()
