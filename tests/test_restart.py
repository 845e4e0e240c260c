"""Restarts that survive a real kill, for every model that writes checkpoints, with one sphere and (for
the models that run them) a pair: a run in a subprocess is SIGKILLed after a checkpoint (or stopped with
Ctrl-C), continued with --restart, and its summary and trajectory (no row lost or doubled) compared with
an uninterrupted run's.  Toy sizes, seconds each.  The ode model writes no
checkpoints: an interrupted ode run says to run it again (tests/test_interruptions.py).  The states a kill
can leave between a checkpoint's files, and --restart named from inside the run: the end of this file; a restart
that is refused: tests/test_restart_refusals.py."""
import json
import shutil
import signal

import pytest

from fem_bounce import cli, fields
from fem_bounce.models.registry import MODELS
from helpers import ALE_PLAIN_OPTIONS, assert_one_line, assert_same_trajectory, messages, run_cli, spawn, wait_for
from test_ale_pair import FREE_PAIR

CASES = {  # a toy run of each model that writes checkpoints, alone and in a pair
    # the fd defaults (the implicit penalisation on the mesh that moves with the sphere, adaptive steps) through
    # the impact: a new mesh at step 16, so the checkpoint at step 20 is across a remesh and the restart must make
    # that mesh again
    "fd": ["li2011-case3", "--model", "fd", "--set", "numerics.fd.cells_per_diameter=6", "--set", "run.end_time=0.09",
           "--set", "numerics.fd.checkpoint_every=20"],
    # the fixed mesh with its refined patch following the sphere: 4 new meshes in 76 steps before the impact, so the
    # checkpoint at step 60, among the short steps of the approach, is across a remesh and the restart must make
    # that mesh and that step again
    "fd-fixed": ["li2011-case3", "--model", "fd", "--set", "numerics.fd.mesh=fixed", "--set",
                 "numerics.fd.cells_per_diameter=6", "--set", "run.end_time=0.075", "--set",
                 "numerics.fd.checkpoint_every=60"],
    "ib": ["li2011-case3", "--model", "ib", "--set", "numerics.ib.cells_per_diameter=10", "--set", "run.end_time=0.06",
           "--set", "numerics.ib.checkpoint_every=10", "--set", "numerics.ib.output_every=7"],
    # no field snapshots: dolfinx's XDMF/HDF5 file of a SIGKILLed segment can be left unreadable (the ib
    # model's own writer flushes every snapshot; fd and ale fields across a restart: test_fd_model.py)
    # the ale model's adaptive steps (its default) on a surface at the path's size, through the impact: the
    # checkpoint at step 35 after its remesh at step 33 of 153
    "ale": ["li2011-case3", "--model", "ale", "--set", "numerics.ale.cells_per_diameter=6",
            "--set", "numerics.ale.surface_refinement=1", "--set", "run.end_time=0.08",
            "--set", "numerics.ale.checkpoint_every=35"],
    # the pair at the fd defaults (the implicit penalisation on the moving mesh, both spheres filled), 8 cells/D
    "fd-pair": ["yang-hunt2006-pair", "--model", "fd", "--set", "numerics.fd.cells_per_diameter=8",
                "--set", "run.end_time=0.06", "--set", "numerics.fd.checkpoint_every=10"],
    "ale-pair": FREE_PAIR,  # through the collision; its checkpoint after the remesh (tests/test_ale_pair.py)
    # the 3-D model at 4 cells/D with a short patch (0.1 D of travel): 3 new meshes in 18 steps, the checkpoint at
    # step 10 after the first, so the restart must make that mesh again
    "fd3d": ["li2011-case3", "--model", "fd3d", "--set", "numerics.fd3d.cells_per_diameter=4", "--set",
             "numerics.fd3d.surface_refinement=1", "--set",
             "numerics.fd3d.patch_margin=0.2", "--set", "run.end_time=0.03", "--set",
             "numerics.fd3d.checkpoint_every=10"],
    # and oblique (case 3's sphere launched at 30 degrees without gravity, tests/test_oblique.py's scene), to 12 ms:
    # the checkpoint on a new mesh off the axis, the tangential amplitudes' history with it
    "fd3d-oblique": ["li2011-case3", "--model", "fd3d", "--set", "numerics.fd3d.cells_per_diameter=4", "--set",
                     "numerics.fd3d.surface_refinement=1", "--set", "numerics.fd3d.patch_margin=0.2", "--set",
                     "gravity=0", "--set", "initial_gap=0.00475", "--set", "initial_velocity=-0.3377", "--set",
                     "tangential_velocity=0.195", "--set", "contact.friction=0.02", "--set", "run.end_time=0.012",
                     "--set", "numerics.fd3d.checkpoint_every=10"],
}


def arguments(case: str) -> list[str]:
    return [*CASES[case], "--quiet"]


def test_every_model_that_writes_checkpoints_is_tested_here_alone_and_in_a_pair():
    restarting = [name for name, entry in MODELS.items() if entry.restarts]
    expected = {**{name: name for name in restarting},
                **{f"{name}-pair": name for name in restarting if MODELS[name].max_spheres >= 2}}
    cases = {case: argv[argv.index("--model") + 1] for case, argv in CASES.items()}
    assert expected.items() <= cases.items() and set(cases.values()) == set(restarting)


@pytest.fixture(scope="module", params=sorted(CASES))
def straight(request, tmp_path_factory):
    """An uninterrupted toy run of each case: the reference every restart is compared with."""
    out = tmp_path_factory.mktemp(request.param) / "straight"
    assert cli.main(["run", *arguments(request.param), "--out", str(out)]) == 0
    return request.param, out


def assert_same_run(reference, continued) -> None:
    assert_same_trajectory(reference / "trajectory.csv", continued / "trajectory.csv")
    a, b = (json.loads((path / "summary.json").read_text()) for path in (reference, continued))
    assert b["status"] == "completed" and b["steps"] == a["steps"]
    assert b["final"]["gap"] == pytest.approx(a["final"]["gap"], rel=1e-10)
    assert b["final"]["velocity"] == pytest.approx(a["final"]["velocity"], rel=1e-9, abs=1e-12)
    assert [i["impact_speed"] for i in b["impacts"]] == pytest.approx([i["impact_speed"] for i in a["impacts"]])
    assert len(b.get("collisions", [])) == len(a.get("collisions", []))  # a pair's, with the wall or each other
    for collision, again in zip(a.get("collisions", []), b.get("collisions", [])):
        numbers = {key for key, value in collision.items() if isinstance(value, float)}
        assert {key: again[key] for key in numbers} == pytest.approx({key: collision[key] for key in numbers},
                                                                     rel=1e-9, abs=1e-12)
        assert {key: again[key] for key in collision.keys() - numbers} == \
            {key: collision[key] for key in collision.keys() - numbers}
    if list(reference.glob("fields*.xdmf")):  # the field snapshots continue as one series, none doubled
        times = [snapshot.time for snapshot in fields.read_snapshots(continued)]
        assert times == pytest.approx([snapshot.time for snapshot in fields.read_snapshots(reference)])


def started_past_a_checkpoint(case: str, out, cwd):
    """A `fem-bounce run` of the case's toy scene into `out`, returned once it has written a checkpoint."""
    process = spawn(["run", *arguments(case), "--out", str(out)], cwd=cwd)
    wait_for(lambda: (out / "checkpoint" / "model.txt").is_file(), process)
    return process


def test_sigkill_after_a_checkpoint_then_restart_gives_the_uninterrupted_run(straight, tmp_path, capsys):
    case, reference = straight
    killed = tmp_path / "killed"
    process = started_past_a_checkpoint(case, killed, tmp_path)
    process.send_signal(signal.SIGKILL)
    process.communicate()
    assert not (killed / "summary.json").exists(), "the run finished before it was killed"
    if case.startswith("fd3d"):  # the checkpoint is on a new mesh, which the restart must make again
        state = json.loads((killed / "checkpoint" / "state.json").read_text())
        release = [0.0, 0.0, 0.00635 + (0.00475 if case == "fd3d-oblique" else 0.0152)]  # the first mesh's centre
        assert state["flow"]["patch_center"] != pytest.approx(release)
    assert cli.main(["run", "--restart", str(killed), "--quiet"]) == 0
    assert messages(capsys.readouterr().err) == []
    assert_same_run(reference, killed)
    summary = json.loads((killed / "summary.json").read_text())
    segments = summary["wall_time_segments_s"]
    assert len(segments) == 2 and summary["wall_time_s"] == pytest.approx(sum(segments))


def test_ctrl_c_leaves_a_run_directory_that_restarts(straight, tmp_path, capsys):
    case, reference = straight
    out = tmp_path / "run"
    process = started_past_a_checkpoint(case, out, tmp_path)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 130
    assert_one_line(messages(err), "interrupted by SIGINT", f"with: fem-bounce run --restart {out}")
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"
    assert cli.main(["run", "--restart", str(out), "--quiet"]) == 0
    assert_same_run(reference, out)


def test_an_ale_checkpoint_from_before_issue_25_with_one_spheres_values_as_numbers_resumes(tmp_path, capsys):
    """The ale model wrote one sphere's mesh centre, velocities, centres and last force as numbers before
    they became arrays over the bodies: such a checkpoint still resumes to the uninterrupted run."""
    reference = tmp_path / "straight"
    assert cli.main(["run", *arguments("ale"), "--out", str(reference)]) == 0
    killed = tmp_path / "killed"
    process = started_past_a_checkpoint("ale", killed, tmp_path)
    process.send_signal(signal.SIGKILL)
    process.communicate()
    path = killed / "checkpoint" / "state.json"
    state = json.loads(path.read_text())
    flow = state["flow"]
    flow["mesh_center"] = flow["mesh_center"][0]
    for key in ("velocities", "centers"):
        flow[key] = [level[0] for level in flow[key]]
    force, added_mass = flow["last_force"]
    flow["last_force"] = [force[0], added_mass[0][0]]
    path.write_text(json.dumps(state))
    assert cli.main(["run", "--restart", str(killed), "--quiet"]) == 0
    assert messages(capsys.readouterr().err) == []
    assert_same_run(reference, killed)


# -- states a kill can leave, and a run named from inside it ----------------------------------------------------------

# the ale model at 4 cells/D through one bounce, with its side file ale_forces.csv
ALE_TOY = ["li2011-case3", "--model", "ale", "--quiet", "--set", "numerics.ale.cells_per_diameter=4",
           *ALE_PLAIN_OPTIONS, "--set", "run.bounces=1", "--set", "numerics.ale.checkpoint_every=10"]


def test_a_side_file_is_restored_with_the_trajectory(tmp_path):
    """ale_forces.csv was empty at the kill (buffered) and ended 11 rows short after the restart."""
    straight, killed = tmp_path / "straight", tmp_path / "KA"
    assert cli.main(["run", *ALE_TOY, "--out", str(straight)]) == 0
    process = spawn(["run", *ALE_TOY, "--out", str(killed)], tmp_path)
    wait_for(lambda: (killed / "checkpoint" / "model.txt").is_file(), process)
    process.kill()
    process.wait()
    assert cli.main(["run", "--restart", str(killed), "--quiet"]) == 0
    for name in ("ale_forces.csv", "trajectory.csv"):
        assert (killed / name).read_text() == (straight / name).read_text(), name


def test_kill_between_the_checkpoint_renames_restarts(fd_run, fd_copy, capsys):
    """A kill between the checkpoint's two renames left 'no checkpoint to restart from' with two whole
    copies on disk.  Here: the new copy still checkpoint.partial, the previous one checkpoint.old, and
    the trajectory ending in a half-written row."""
    (fd_copy / "checkpoint").rename(fd_copy / "checkpoint.partial")
    shutil.copytree(fd_copy / "checkpoint.partial", fd_copy / "checkpoint.old")
    with open(fd_copy / "trajectory.csv", "a") as stream:
        stream.write("0.0301,0.00")
    status, lines = run_cli(capsys, "run", "--restart", str(fd_copy), "--quiet")
    assert status == 0 and lines == []
    assert_same_trajectory(fd_run / "trajectory.csv", fd_copy / "trajectory.csv")
    assert sorted(p.name for p in fd_copy.glob("checkpoint*")) == ["checkpoint"]


def test_restart_from_inside_the_run_directory(fd_run, fd_copy, monkeypatch, capsys):
    """`--restart .` from inside the run directory said "choose another --out", an option --restart does not take."""
    monkeypatch.chdir(fd_copy)
    status, lines = run_cli(capsys, "run", "--restart", ".", "--quiet")
    assert status == 0 and lines == []
    assert (fd_copy / "trajectory.csv").read_text() == (fd_run / "trajectory.csv").read_text()
