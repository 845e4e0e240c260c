"""How long the resolved models' steps are (never past the end time, never across a collision), the settings that
do not hold the sphere or are read nowhere, and what a restarted run's summary counts.

- A run ends at run.end_time: the last step is shortened (with the variable-step BDF coefficients), on every mesh
  and with fixed or adaptive steps, the one-shot penalty's (its matrix factorised once more) and the ib model's (K
  refactorised) too (before: up to a whole step past it; a held fd sphere's steady state to the end of a whole cfl
  step, 0.67 s for an end time of 0.2 s).
- No adaptive step jumps a collision: every step, the first included and below the step floor, closes at most
  twice gap_fraction of each gap (flow_model.Approach; before: a sphere released from rest has speed 0, so the
  first step, the cfl step, was unbounded, and the floor min_step_factor x cfl step overrode the gap's bound).
- Nor does a fixed step: on the moving meshes (ale's and fd's with adaptive_step = false), on the fixed mesh
  with the implicit constraint and in the ib model (halving dt) a fixed step is shortened where it could close more
  than the gap (Approach.longest at MAX_GAP_FRACTION; never at the defaults); the one-shot penalty, whose factors
  keep one step length, refuses a step longer than flow_model.safe_fixed_step (before: cfl 50 or 20, in range, put
  the whole bounce in one or two steps).
- numerics.fd.penalty_strength below 100 is refused (it no longer holds the sphere); hold_delta where the near-wall
  correction holds every contact, or on the fixed mesh, and penalty_strength with constraint = "penalty" are
  refused naming what to set instead (before: read nowhere, silently).
- After a restart the fixed mesh's summary counts the whole run's remeshes, factorisations and back-solves.

Toy sizes (4 cells/D): a few seconds each on the 2-core machine.
"""
import math
from pathlib import Path

import numpy as np
import pytest

import fem_bounce as fb
from mpi4py import MPI

from fem_bounce.flow_model import Approach, StepLimits, approach_for, safe_fixed_step
from fem_bounce.models.fd.model import FictitiousDomainModel

TOY = {"numerics.fd.cells_per_diameter": 4}
ALE_TOY = {"numerics.ale.cells_per_diameter": 4, "numerics.ale.surface_refinement": 1.0}
IB_TOY = {"numerics.ib.cells_per_diameter": 6}


# -- 1. the end time ------------------------------------------------------------------------------------------------

@pytest.mark.parametrize("model, settings", [
    ("fd", TOY),  # the moving mesh, adaptive steps
    ("fd", {**TOY, "numerics.fd.adaptive_step": False}),  # the moving mesh, fixed steps
    ("fd", {**TOY, "numerics.fd.mesh": "fixed"}),  # the fixed mesh, adaptive steps
    ("fd", {**TOY, "numerics.fd.mesh": "fixed", "numerics.fd.adaptive_step": False}),
    ("fd", {**TOY, "numerics.fd.mesh": "fixed", "numerics.fd.adaptive_step": False,
            "numerics.fd.time_order": 3}),  # its last step BDF2 with the variable-step coefficients
    ("ale", ALE_TOY),  # adaptive steps (the ale default)
    ("ale", {**ALE_TOY, "numerics.ale.adaptive_step": False}),
    ("fd", {**TOY, "numerics.fd.mesh": "fixed", "numerics.fd.constraint": "penalty"}),  # refactorised once for it
])
def test_a_run_ends_at_its_end_time(model, settings):
    """Case 3 to 0.0123 s, within a step of none of the models' grids: the last row is at the end time (before:
    0.0131-0.0157 s, the end of the step that passed it)."""
    result = fb.simulate(fb.load("li2011-case3", {**settings, "run.end_time": 0.0123}), model, plots=False)
    assert result.summary["final"]["time"] == pytest.approx(0.0123, rel=1e-12, abs=0.0)
    assert result.trajectory["t"][-1] == pytest.approx(0.0123, rel=1e-12, abs=0.0)
    assert np.all(np.diff(result.trajectory["t"]) >= 0.0)


def test_a_held_spheres_steady_state_is_held_to_the_end_time():
    """brenner-approach on the fd model (its steady Stokes solve, held to the end): the trajectory ended at
    0.667 s, a whole cfl step, for run.end_time = 0.2 s."""
    result = fb.simulate(fb.load("brenner-approach", TOY), "fd", plots=False)
    assert result.summary["final"]["time"] == pytest.approx(0.2, rel=1e-12)


# -- 2. no step jumps a collision ------------------------------------------------------------------------------------

def test_the_approach_bounds_a_step_from_rest_and_below_the_floor():
    """From rest the speed bounds nothing: the acceleration does, sqrt(2 f g / a); near the wall the bound holds
    below the floor, down to the contact model's gap delta_sl D, where it stops shrinking."""
    scene = fb.load("li2011-case3")
    approach = approach_for(scene)
    a = (1.0 - scene.liquid.density / scene.sphere.density) * scene.gravity
    assert approach.accelerations[0] == pytest.approx(a)
    gap = scene.initial_gap
    assert approach.longest([gap], [0.0], 0.5) == pytest.approx(math.sqrt(2.0 * 0.5 * gap / a))
    assert approach.longest([gap], [-0.4], 0.5) == pytest.approx(0.5 * gap / 0.4)
    contact = scene.contact.delta_sl * scene.sphere.diameter
    assert approach.longest([1e-7], [-0.4], 0.5) == approach.longest([contact], [-0.4], 0.5) > 0.0
    limits = StepLimits(0.1, 0.5, 2.0, 0.4, 0.5, approach)  # a floor of 0.05 s, far above the bound near the wall
    assert limits.next(0.1, 0.2 * gap, 0.4, 0.0) == 0.05  # the floor wins over the gap's heuristic ...
    bounded = limits.first(0.05, [0.2 * gap], [-0.4])
    assert bounded == pytest.approx(0.5 * 0.2 * gap / 0.4)  # ... not over the bound
    assert limits.next(bounded, 0.0, 0.0, 0.0) == pytest.approx(1.5 * bounded)  # and grows back to it


def test_a_pair_closes_at_both_speeds():
    """A pair's gap closes at |V_1| + |V_2| at most: the bound counts both spheres, and their weights."""
    approach = Approach(diameters=(0.01, 0.01), accelerations=(0.0, 0.0), contact_gaps=(0.002, 0.002), wall=False)
    assert approach.longest([0.05, 0.07], [0.3, -0.3], 0.5) == pytest.approx(0.5 * 0.01 / 0.6)
    assert approach.longest([0.05, 0.07], [0.0, 0.0], 0.5) == math.inf  # nothing moves, nothing pulls


@pytest.mark.parametrize("model, settings, least", [
    ("fd", {**TOY, "numerics.fd.peak_cfl": 50.0}, 8),  # before: 1 step, e 0.881, apex 11.3 mm (default 0.790, 4.9 mm)
    ("ale", {**ALE_TOY, "numerics.ale.cfl": 20.0, "numerics.ale.adaptive_step": True}, 40),  # before: 4 steps
])
def test_an_in_range_cfl_does_not_put_the_bounce_in_one_step(model, settings, least):
    """`--set numerics.fd.peak_cfl=50` (in range) took case 3's whole fall, collision and rebound in one step: the
    first step from rest, the cfl step, was unbounded.  Now the approach takes steps that close at most what the
    gap fraction allows, and the rebound is near the default's."""
    result = fb.simulate(fb.load("li2011-case3", {**settings, "run.bounces": 1}), model, plots=False)
    assert result.summary["steps"] >= least
    restitution = result.rebounds[0].restitution
    assert 0.7 < restitution < 0.85  # (the default cfl: 0.790 fd, 0.802 ale)


def test_the_safe_fixed_step_is_half_the_contact_gap_at_the_impact_speed():
    """flow_model.safe_fixed_step: at the contact model's gap delta_sl D and the speed scale U a step closes at most
    that gap (half of it from the speed, half from the net weight); a pair closes at both speeds, over its own gap
    delta_sl 2a* (a* = a / 2 for equal spheres); nothing held closes."""
    case3 = fb.load("li2011-case3")
    contact = case3.contact.delta_sl * case3.sphere.diameter
    assert safe_fixed_step(case3, 0.4) == pytest.approx(0.5 * contact / 0.4)
    pair = fb.load("yang-hunt2006-pair")  # no wall, no gravity: the pair's gap alone
    assert safe_fixed_step(pair, 0.3) == pytest.approx(0.5 * pair.contact.delta_sl * pair.sphere.radius / 0.6)
    assert safe_fixed_step(fb.load("sphere-drag-re100"), 0.1) == math.inf  # a held sphere


@pytest.mark.parametrize("model, settings, least", [
    ("ale", {**ALE_TOY, "numerics.ale.cfl": 20.0, "numerics.ale.adaptive_step": False}, 8),  # before: 2 steps, e 0.875
    ("fd", {**TOY, "numerics.fd.peak_cfl": 50.0, "numerics.fd.adaptive_step": False}, 8),  # before: 1 step, e 0.881
    ("fd", {**TOY, "numerics.fd.peak_cfl": 50.0, "numerics.fd.adaptive_step": False, "numerics.fd.mesh": "fixed"},
     8),  # before: 1 step, e 0.886
    ("ib", {**IB_TOY, "numerics.ib.cfl": 2.0, "numerics.ib.max_cfl": 5.0}, 35),  # before: 19 steps, e 0.872
])
def test_a_large_cfl_with_fixed_steps_no_longer_jumps_the_collision(model, settings, least):
    """Fixed steps had no gap bound: ale's cfl 20 (fixed steps, its default then) took case 3's fall, collision and
    rebound in 2 steps, fd's cfl 50 with adaptive_step = false in 1 (e 0.875-0.886 against 0.79-0.80 at the
    defaults).  Where the moving mesh, the implicit constraint or the ib model can shorten a step they now do,
    where it could close more than the gap (Approach.longest at MAX_GAP_FRACTION; measured: 10-11 steps, e
    0.828-0.835; ib with its measured-CFL halving pushed out of the way, max_cfl 5: 42 steps, e 0.861 against
    0.850 at its default cfl; 0.855 and 0.848 with the flow's force held at each step's end value, the rectangle
    rule of numerics.ode.flow_force = "end").  The bound lies below every jumped collision's 0.872."""
    result = fb.simulate(fb.load("li2011-case3", {**settings, "run.bounces": 1}), model, plots=False)
    assert result.summary["steps"] >= least
    assert 0.75 < result.rebounds[0].restitution < 0.865


def test_a_one_shot_penalty_step_that_could_jump_a_collision_is_refused(tmp_path):
    """The one-shot penalty keeps its factors for one step length, so its steps are not shortened near the wall:
    cfl 5 at 4 cells/D (in range; its step then set by forcing_number, 0.00338 s) ran 25 steps to e 0.846.  Refused
    before anything is written, with the largest cfl and forcing_number this scene allows (a step at the impact speed
    scale carrying the sphere at most half across delta_sl D: 0.00196 s) and the alternative; the default cfl 0.2
    and cfl 0.5 pass."""
    penalty = {**TOY, "numerics.fd.mesh": "fixed", "numerics.fd.constraint": "penalty"}
    with pytest.raises(fb.SceneError, match=r"numerics.fd.peak_cfl = 5 with forcing_number = 0.025 .* fixed step "
                                            r"0.00338 s, longer than the 0.00196 s this scene allows .* "
                                            r"numerics.fd.peak_cfl up to 0.6, or forcing_number up to 0.0145; or set "
                                            r"numerics.fd.constraint = \"implicit\""):
        fb.simulate(fb.load("li2011-case3", {**penalty, "numerics.fd.peak_cfl": 5.0}), "fd", out=tmp_path / "run",
                    plots=False)
    assert not (tmp_path / "run").exists()
    FictitiousDomainModel(fb.load("li2011-case3", {**penalty, "numerics.fd.peak_cfl": 0.5}), MPI.COMM_WORLD)


@pytest.mark.parametrize("model, settings", [
    ("ib", {**IB_TOY, "numerics.ib.checkpoint_every": 3}),
    ("fd", {**TOY, "numerics.fd.mesh": "fixed", "numerics.fd.constraint": "penalty", "numerics.fd.patch": False,
            "numerics.fd.checkpoint_every": 3}),
])
def test_a_run_continued_past_a_shortened_last_step_is_the_longer_run(tmp_path, model, settings):
    """The ib model's and the one-shot penalty's last step is shortened to end at run.end_time (a new K, a new
    matrix; before: they ended at the end of the step that passed it, the ib model by up to a step of 1.3 ms here)
    and writes no checkpoint: a run to 0.03 s continued to 0.05 s goes on from the checkpoint before it, on whole
    steps, as the run to 0.05 s did.  (The ib step is at most end_time / 20: these end times leave it the cfl's.)"""
    whole = fb.simulate(fb.load("li2011-case3", {**settings, "run.end_time": 0.05}), model, plots=False)
    first = fb.simulate(fb.load("li2011-case3", {**settings, "run.end_time": 0.03}), model, out=tmp_path / "run",
                        plots=False)
    assert first.summary["final"]["time"] == pytest.approx(0.03, rel=1e-12, abs=0.0)
    assert first.trajectory["t"][-1] == pytest.approx(0.03, rel=1e-12, abs=0.0)
    assert first.summary["steps"] < whole.summary["steps"]
    toml = Path(tmp_path / "run" / "scene.toml")
    toml.write_text(toml.read_text().replace("end_time = 0.03", "end_time = 0.05"))
    resumed = fb.resume(tmp_path / "run", plots=False)
    assert resumed.summary["final"]["time"] == pytest.approx(0.05, rel=1e-12)
    assert resumed.summary["steps"] == whole.summary["steps"]
    assert resumed.trajectory["velocity"][-1] == pytest.approx(whole.trajectory["velocity"][-1], rel=1e-9)


def test_a_gap_fraction_above_a_half_is_refused():
    """At gap_fraction f a step closes at most 2 f of the gap (Approach): above 0.5 it could reach the contact."""
    with pytest.raises(fb.SceneError, match=r"numerics.fd.gap_fraction = 0.8 is out of range: allowed in "
                                            r"\[0.001, 0.5\]"):
        fb.load("li2011-case3", {"numerics.fd.gap_fraction": 0.8})


# -- 6, 7. settings that do not hold the sphere, or do nothing -------------------------------------------------------

def test_a_penalty_too_weak_to_hold_the_sphere_is_refused():
    """penalty_strength 1 or 10 (in range) diverged with "use a smaller cfl" (numerics.fd.peak_cfl), which did not
    help: the friction no longer holds the sphere (at 10 it gains energy; at 20 V_i is 4 % and e 14 % off at 4
    cells/D)."""
    with pytest.raises(fb.SceneError, match=r"numerics.fd.penalty_strength = 10.0 is out of range: allowed in "
                                            r"\[100, 1e\+08\]"):
        fb.load("li2011-case3", {"numerics.fd.penalty_strength": 10})


@pytest.mark.parametrize("settings, message", [
    ({"numerics.fd.hold_delta": 0.05},
     r"numerics.fd.hold_delta = 0.05 has no effect here: the near-wall correction .* contact.delta_sl"),
    ({"numerics.fd.hold_delta": 0.05, "numerics.fd.mesh": "fixed"},
     r"numerics.fd.hold_delta = 0.05 shapes the moving mesh only"),
    ({"numerics.fd.penalty_strength": 1e4, "numerics.fd.constraint": "penalty", "numerics.fd.mesh": "fixed"},
     r"numerics.fd.penalty_strength = 10000 sets the implicit constraint's friction; constraint = \"penalty\" .* "
     r"numerics.fd.forcing_number"),
])
def test_a_setting_read_nowhere_is_refused(tmp_path, settings, message):
    """summary.json reported hold_delta 0.05 beside min_mesh_delta 0.2 (the correction's hold): the value was read
    nowhere; so was penalty_strength with the one-shot penalty.  Refused before anything is written."""
    with pytest.raises(fb.SceneError, match=message):
        fb.simulate(fb.load("li2011-case3", {**TOY, **settings}), "fd", out=tmp_path / "run", plots=False)
    assert not (tmp_path / "run").exists()


def test_hold_delta_is_read_where_the_mesh_holds_the_sphere_itself():
    """With contact.near_wall = "blend" the moving mesh holds the sphere at hold_delta D: admitted."""
    scene = fb.load("li2011-case3", {**TOY, "numerics.fd.hold_delta": 0.05, "contact.near_wall": "blend",
                                     "run.end_time": 0.002})
    assert fb.simulate(scene, "fd", plots=False).status == "completed"


# -- 8. a restarted run's counts -------------------------------------------------------------------------------------

@pytest.mark.parametrize("adaptive", [True, False])
def test_a_restarted_fixed_mesh_counts_the_whole_run(tmp_path, adaptive):
    """The fixed mesh's remeshes, factorisations and back-solves after a restart counted the last segment only
    (usage.md: a restarted run leaves every file as an uninterrupted one).  A run to 0.045 s against one to 0.025 s
    continued to 0.045 s from its checkpoint (patches a fifth of a diameter: new meshes in both segments); with
    fixed steps the restart also continues their clock."""
    settings = {**TOY, "numerics.fd.mesh": "fixed", "numerics.fd.patch_margin": 0.2,
                "numerics.fd.checkpoint_every": 4, "numerics.fd.adaptive_step": adaptive}
    whole = fb.simulate(fb.load("li2011-case3", {**settings, "run.end_time": 0.045}), "fd", plots=False)
    first = fb.simulate(fb.load("li2011-case3", {**settings, "run.end_time": 0.025}), "fd", out=tmp_path / "run",
                        plots=False)
    assert first.summary["fd"]["remeshes"] > 0
    toml = Path(tmp_path / "run" / "scene.toml")
    toml.write_text(toml.read_text().replace("end_time = 0.025", "end_time = 0.045"))
    resumed = fb.resume(tmp_path / "run", plots=False)
    for key in ("remeshes", "factorisations", "back_solves", "back_solves_per_step"):
        assert resumed.summary["fd"][key] == whole.summary["fd"][key], key
    assert resumed.summary["fd"]["remesh_s"] > first.summary["fd"]["remesh_s"] * 0.5
    assert resumed.summary["steps"] == whole.summary["steps"]
    assert resumed.summary["final"]["time"] == pytest.approx(0.045, rel=1e-12)
    assert resumed.trajectory["velocity"][-1] == pytest.approx(whole.trajectory["velocity"][-1], rel=1e-9)
