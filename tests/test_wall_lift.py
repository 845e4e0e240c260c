"""The lift of a sphere sliding along a wall (fem_bounce.wall_lift): the packaged table read back, its ends, and its
action on an oblique collision's normal motion in the reduced model."""
from __future__ import annotations

import math

import pytest
from mpi4py import MPI

from fem_bounce import losses, reference
from fem_bounce.run import simulate
from fem_bounce.wall_lift import TABLE, WallLift
from test_oblique import case3_oblique

D, RHO, MU = 0.0095, 1203.0, 0.0502  # case 3's sphere and liquid


def test_the_table_is_read_back_at_its_points_and_ends_at_twice_its_largest_gap():
    lift = WallLift(D, RHO, MU)
    a = 0.5 * D
    rows = reference.table(TABLE)
    for row in rows:
        assert lift.coefficient(row["Re"], row["gap_over_a"] * a) == pytest.approx(row["C_L"], rel=1e-12)
    largest = max(row["gap_over_a"] for row in rows)
    assert lift.coefficient(100.0, 2.0 * largest * a) == 0.0
    at_largest = lift.coefficient(100.0, largest * a)
    assert lift.coefficient(100.0, 1.5 * largest * a) == pytest.approx(0.5 * at_largest, rel=1e-12)
    assert lift.force(0.1 * a, 0.0) == 0.0
    # away from the wall, and the force of the coefficient at the speed's Re
    speed = 0.4
    reynolds = RHO * speed * D / MU
    assert lift.force(0.3 * a, speed) == pytest.approx(
        0.5 * RHO * speed**2 * math.pi * a**2 * lift.coefficient(reynolds, 0.3 * a), rel=1e-12)
    assert lift.force(0.3 * a, speed) > 0.0
    assert lift.force(0.3 * a, -speed) == pytest.approx(lift.force(0.3 * a, speed), rel=1e-12)


def test_the_lift_slows_the_approach_and_raises_the_rebound(tmp_path):
    """Case 3's sphere at 60 degrees: the lift pushes it off the wall, on the way in and out; the normal motion
    without it is the head-on one's (test_oblique), and the loss audit balances with it."""
    scene = case3_oblique(60.0)
    found = {}
    for setting in ("off", "steady"):
        summary = simulate(scene.replace(**{"contact.lift": setting}), "ode", MPI.COMM_SELF, tmp_path / setting,
                           progress=False, plots=False)
        found[setting] = summary["oblique_impacts"][0]["outer"]
        audit = summary["impacts"][0]["losses"]
        assert abs(audit["imbalance"]) < losses.AUDIT_TOLERANCE
        if setting == "steady":
            assert sum(audit["impulse"]["lift"]) > 0.0
        else:
            assert "lift" not in audit["impulse"]
    assert found["steady"]["normal_speed_in"] < found["off"]["normal_speed_in"]
    assert found["steady"]["normal_restitution"] > found["off"]["normal_restitution"]
