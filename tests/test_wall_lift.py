"""The lift and the torque of a sphere sliding along a wall (fem_bounce.wall_lift): the packaged tables read back,
their ends, and their action on an oblique collision in the reduced model."""
from __future__ import annotations

import math

import pytest
from mpi4py import MPI

from fem_bounce import losses, reference
from fem_bounce.run import simulate
from fem_bounce.wall_lift import TABLE, TORQUE_TABLE, WallLift, WallTorque
from fem_bounce.wall_tangential import wall_tangential_resistance
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


def test_the_torque_table_less_the_stokes_coupling_is_read_back_and_turns_with_the_sliding():
    """WallTorque: at the table's points C_T less 32 c_yx / Re (the Stokes film's coupling, wall_tangential), T ~
    U |U| (odd in U), and dT/dU the interpolation's own slope (a difference across 1e-4 of U, well inside a
    segment)."""
    torque = WallTorque(D, RHO, MU)
    a = 0.5 * D
    for row in reference.table(TORQUE_TABLE):
        coupling = -wall_tangential_resistance(1.0, 1.0, row["gap_over_a"])[0][1, 0] / (8.0 * math.pi)
        assert torque.coefficient(row["Re"], row["gap_over_a"] * a) == pytest.approx(
            row["C_T"] - 32.0 * coupling / row["Re"], rel=1e-9, abs=1e-12)
    speed, gap = 0.4, 0.3 * a
    value, _, slope = torque.torque_slopes(gap, speed)
    assert torque.torque_slopes(gap, -speed)[0] == pytest.approx(-value, rel=1e-12)
    step = 1e-4 * speed
    difference = (torque.torque_slopes(gap, speed + step)[0] - torque.torque_slopes(gap, speed - step)[0]) / (2 * step)
    assert difference == pytest.approx(slope, rel=1e-3)
    assert torque.torque_slopes(gap, 0.0) == (0.0, 0.0, 0.0)


def test_the_finite_re_torque_slows_the_spin_after_the_bounce(tmp_path):
    """Case 3's sphere at 60 degrees: the sliding sphere's torque at Re ~100 works against the rolling sense, so
    the spin after the bounce is lower with it, the normal motion is the same, and the loss audit balances."""
    scene = case3_oblique(60.0)
    found = {}
    for setting in ("off", "steady"):
        summary = simulate(scene.replace(**{"contact.wall_torque": setting}), "ode", MPI.COMM_SELF,
                           tmp_path / setting, progress=False, plots=False)
        found[setting] = summary["oblique_impacts"][0]["outer"]
        assert abs(summary["impacts"][0]["losses"]["imbalance"]) < losses.AUDIT_TOLERANCE
    assert found["steady"]["spin_out"] < found["off"]["spin_out"]
    assert found["steady"]["normal_speed_in"] == pytest.approx(found["off"]["normal_speed_in"], rel=1e-6)
