"""The fd model's run: parallel = serial, restart = straight run, divergence handling, fields, light spheres."""
import json
import math

import numpy as np
import pytest
from mpi4py import MPI

from fem_bounce import cli, fields, output, scene
from fem_bounce.errors import RunDiverged
from fem_bounce.run import simulate

TINY = {"numerics.fd.cells_per_diameter": 6, "run.end_time": 0.02}


def run(tmp, name="li2011-case3", comm=MPI.COMM_WORLD, restart=False, **overrides):
    sc = scene.load(name, {**TINY, **overrides})
    return simulate(sc, "fd", comm, tmp, force=not restart, restart=restart, progress=False, plots=False)


@pytest.mark.mpi
def test_two_ranks_give_the_serial_trajectory(shared_tmp):
    """Every rank also runs the same scene alone (COMM_SELF): the trajectories agree to solver precision."""
    comm = MPI.COMM_WORLD
    parallel = run(shared_tmp / "parallel", comm=comm)
    serial = run(shared_tmp / f"serial-{comm.rank}", comm=MPI.COMM_SELF)
    assert parallel["ranks"] == comm.size and serial["ranks"] == 1
    a = output.read_trajectory(shared_tmp / "parallel")
    b = output.read_trajectory(shared_tmp / f"serial-{comm.rank}")
    assert len(a["t"]) == len(b["t"])
    assert np.allclose(a["velocity"], b["velocity"], rtol=1e-7, atol=1e-10)
    assert np.allclose(a["f_sim"], b["f_sim"], rtol=1e-6, atol=1e-9)


@pytest.mark.mpi
def test_restart_continues_to_the_same_result(shared_tmp):
    """Checkpoint every 20 steps; 'kill' after 50 (end_time short), extend the end time, --restart:
    the rows after the last checkpoint are redone and the result equals the straight run's.  The one-shot
    penalty, whose short steps give the run those 50 (a restart across a new mesh: tests/test_restart.py)."""
    comm = MPI.COMM_WORLD
    penalty = {"numerics.fd.mesh": "fixed", "numerics.fd.constraint": "penalty"}
    straight = run(shared_tmp / "straight", **{**penalty, "numerics.fd.checkpoint_every": 20,
                                               "numerics.fd.output_every": 15})
    steps = straight["steps"]
    killed = shared_tmp / "killed"
    short = {**penalty, "numerics.fd.checkpoint_every": 20, "numerics.fd.output_every": 15,
             "run.end_time": TINY["run.end_time"] * 50 / steps}
    run(killed, **short)
    if comm.rank == 0:  # the user continues the same scene: its end time as in the straight run
        text = (killed / "scene.toml").read_text()
        (killed / "scene.toml").write_text(text.replace(f"end_time = {short['run.end_time']!r}",
                                                        f"end_time = {TINY['run.end_time']!r}"))
    comm.barrier()
    assert cli.main(["run", "--restart", str(killed), "--quiet"]) == 0
    comm.barrier()
    a, b = output.read_trajectory(shared_tmp / "straight"), output.read_trajectory(killed)
    assert np.array_equal(a["t"], b["t"])  # no duplicated or missing rows
    assert np.allclose(a["velocity"], b["velocity"], rtol=1e-9, atol=1e-12)
    resumed = json.loads((killed / "summary.json").read_text())
    assert resumed["final"]["gap"] == pytest.approx(straight["final"]["gap"], rel=1e-10)
    # the fields of both segments read back as one series at the straight run's instants
    times = [s.time for s in fields.read_snapshots(killed)]
    assert times == pytest.approx([s.time for s in fields.read_snapshots(shared_tmp / "straight")])


def test_a_diverging_run_stops_clearly_and_keeps_its_checkpoint(tmp_path):
    """A time step far beyond the explicit convection's limit (the one-shot penalty's) blows up: the run
    stops with a message naming the last checkpoint, which is still there, and the summary says 'diverged'."""
    out = tmp_path / "blowup"
    with pytest.raises(RunDiverged, match=r"last checkpoint at step 5"):
        run(out, name="sphere-drag-re200", **{"numerics.fd.mesh": "fixed", "numerics.fd.constraint": "penalty",
                                              "numerics.fd.peak_cfl": 8.0, "numerics.fd.forcing_number": 10.0,
                                              "numerics.fd.checkpoint_every": 5, "run.end_time": 3.0})
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"].startswith("diverged")
    state = json.loads((out / "checkpoint" / "state.json").read_text())
    # the predictor's velocities, newest first, each a list over the bodies (one here)
    assert state["step"] == 5 and [len(level) for level in state["velocities"]] == [1] * len(state["velocities"])
    assert all(math.isfinite(v) for level in state["velocities"] for v in level)


def test_fields_hold_velocity_pressure_and_vorticity(tmp_path):
    run(tmp_path / "f", **{"numerics.fd.output_every": 4})
    snapshots = fields.read_snapshots(tmp_path / "f")
    first, last = snapshots[0], snapshots[-1]
    n = len(first.points)
    assert first.time == 0.0 and last.time > 0.0
    assert first.points.shape == (n, 2) and first.triangles.shape[1] == 3 and first.triangles.max() < n
    assert last.fields["velocity"].shape == (n, 2) and last.fields["pressure"].shape == (n,)
    # the falling sphere: the fluid under it moves down, the vorticity is odd across its path
    assert last.fields["velocity"][:, 1].min() < -0.01
    assert last.fields["vorticity"].max() > 1.0 and last.fields["vorticity"].min() < -1.0
    figure = fields.vorticity_figure(tmp_path / "f", times=[last.time])
    assert figure.stat().st_size > 10_000


@pytest.mark.parametrize("ratio", [1.1, 0.01])
def test_implicit_coupling_is_stable_for_light_spheres(tmp_path, ratio):
    """ten Cate's box with the sphere at `ratio` times the oil's density (0.01: a bubble-like sphere
    rising).  The implicit coupling runs through without oscillating, below the inviscid bound
    (m_l - m_p) g t / (m_p + m_l / 2) that drag and history can only lower, and near the ODE
    model's speed: 0.7-1.1 times it, the low side because at 6 cells per diameter the numerical
    added mass is 0.70 m_l (it tends to 0.5 m_l at first order: 0.56 at 16, 0.53 at 32 cells)."""
    out = tmp_path / "fd"
    summary = run(out, name="tencate2002-e4", **{"sphere.density": 960.0 * ratio, "run.end_time": 0.05})
    assert summary["status"] == "completed"
    trajectory = output.read_trajectory(out)
    accel = np.diff(trajectory["velocity"])
    assert np.all(np.sign(accel[np.abs(accel) > 1e-12]) == np.sign(1.0 - ratio))  # monotonic
    sc = scene.load("tencate2002-e4", {"sphere.density": 960.0 * ratio})
    inviscid = ((sc.displaced_mass - sc.sphere.mass) * sc.gravity * summary["final"]["time"]
                / (sc.sphere.mass + 0.5 * sc.displaced_mass))
    assert 0.0 < summary["final"]["velocity"] / inviscid < 1.0
    ode = simulate(sc.replace(**{"run.end_time": 0.05}), "ode", MPI.COMM_SELF, None, progress=False)
    assert 0.7 < summary["final"]["velocity"] / ode["final"]["velocity"] < 1.1


def test_explicit_coupling_fails_for_a_light_sphere(tmp_path):
    """The contrast, on the fixed mesh: the lagged force (no added mass in the sphere equation) diverges at density
    ratio 0.1, where the implicit coupling is smooth: within milliseconds the sphere moves many times
    faster than the inviscid bound allows, and the run stops on the energy gain.  (At ratio 0.3 the
    sphere reaches the box's lid, where every run now stops, before the lagged coupling fails.)  The classical
    lagged force is held through each step (numerics.ode.flow_force = "end"); taken linearly from the step before's,
    the average of two lagged forces, this run did not diverge within its 20 ms."""
    with pytest.raises(RunDiverged, match="gained energy it cannot have.*coupling = \"explicit\" fails"):
        run(tmp_path / "x", name="tencate2002-e4", **{"sphere.density": 960.0 * 0.1, "run.end_time": 0.02,
                                                     "numerics.fd.coupling": "explicit", "numerics.fd.mesh": "fixed",
                                                     "numerics.ode.flow_force": "end"})
