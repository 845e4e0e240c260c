"""A --restart that cannot continue its run is refused in one line (no start line before it) and leaves the run
directory byte for byte as it was: a damaged, hand-edited or foreign checkpoint, --out beside --restart, an edited
scene.toml, a lost trajectory.  Each breaks a copy of one toy fd run (the fd_copy fixture, tests/conftest.py).  The
restarts that must succeed: tests/test_restart.py."""
import json
import shutil

import numpy as np
import pytest

from fem_bounce import cli
from helpers import assert_one_line, run_cli, tree


# -- damaged or foreign checkpoints -----------------------------------------------------------------------------------


@pytest.mark.parametrize("damage,message", [
    ("truncated flow.npz", "is unreadable: checkpoint/flow.npz: "),
    ("truncated state.json", "is unreadable: checkpoint/state.json: not valid JSON"),
    ("missing flow.npz", "is unreadable: checkpoint/flow.npz: No such file or directory"),
    ("no checkpoint", "has no checkpoint to restart from"),
    ("model.txt says ode", "names the model 'ode', which writes no checkpoints"),
])
def test_corrupt_or_foreign_checkpoint_changes_nothing(damage, message, fd_copy, capsys):
    """A corrupt checkpoint gave BadZipFile, JSONDecodeError or FileNotFoundError tracebacks; a checkpoint
    naming the ib model was reported as a divergence and got a summary and figures."""
    folder = fd_copy / "checkpoint"
    if damage == "truncated flow.npz":
        data = (folder / "flow.npz").read_bytes()
        (folder / "flow.npz").write_bytes(data[: len(data) // 2])
    elif damage == "truncated state.json":
        text = (folder / "state.json").read_text()
        (folder / "state.json").write_text(text[: len(text) // 2])
    elif damage == "missing flow.npz":
        (folder / "flow.npz").unlink()
    elif damage == "no checkpoint":
        shutil.rmtree(folder)
    else:
        (folder / "model.txt").write_text("ode\n")
    before = tree(fd_copy)
    status, lines = run_cli(capsys, "run", "--restart", str(fd_copy), "--quiet")
    assert status == 2
    assert_one_line(lines, "error: ", message)
    assert tree(fd_copy) == before


@pytest.mark.parametrize("damage,message", [
    ("flow.npz from another mesh", "cannot continue this run: the checkpoint does not fit this run's mesh"),
    ("model.txt says ale", "model.txt names the ale model, but its state was written by the fd model"),
    ("model.txt says ib", "model.txt names the ib model, but its state was written by the fd model"),
    ("step abc", "state.json: step = 'abc' is not a whole number of steps"),
    ("time nan", "state.json: time = nan is not a time >= 0 s"),
    ("y nan", "state.json: integrator.y is not 2 finite numbers"),
    ("y short", "state.json: integrator.y is not 2 finite numbers"),
    ("flow empty", "its state does not fit the fd model (KeyError"),
    ("records garbage", "state.json: integrator.records is not a table of the contacts wall"),
    ("machine garbage", "state.json: integrator.machine is not a table of done"),
    ("negative rows", "holds no whole run record"),
    ("scene garbage", "its scene is not valid TOML"),
])
def test_a_refused_restart_changes_nothing(damage, message, fd_copy, capsys):
    """A damaged or hand-edited checkpoint gave TypeError, KeyError, LinAlgError or TOMLDecodeError tracebacks,
    ran on with a short state, or (a negative row count) doubled rows; a checkpoint that did not fit its mesh or
    named another model cut trajectory.csv by a row before it was refused, and one said "the scene was changed"."""
    folder = fd_copy / "checkpoint"
    state = json.loads((folder / "state.json").read_text())
    integrator = state["integrator"]
    if damage == "flow.npz from another mesh":
        with np.load(folder / "flow.npz") as archive:
            arrays = {name: archive[name][: len(archive[name]) // 2] for name in archive.files}
        np.savez(folder / "flow.npz", **arrays)
    elif damage.startswith("model.txt"):
        (folder / "model.txt").write_text(damage.split()[-1] + "\n")
    else:
        edits = {"step abc": lambda: state.update(step="abc"), "time nan": lambda: state.update(time=float("nan")),
                 "y nan": lambda: integrator["y"].__setitem__(0, float("nan")),
                 "y short": lambda: integrator.update(y=integrator["y"][:1]),
                 "flow empty": lambda: state.update(flow={}),
                 "records garbage": lambda: integrator.update(records="garbage"),
                 "machine garbage": lambda: integrator.update(machine=[1, 2]),
                 "negative rows": lambda: integrator["run"].update(trajectory_rows=-3),
                 "scene garbage": lambda: integrator["run"].update(scene="x = = 1")}
        edits[damage]()
        (folder / "state.json").write_text(json.dumps(state))
    before = tree(fd_copy)
    status = cli.main(["run", "--restart", str(fd_copy), "--quiet"])
    err = capsys.readouterr().err
    assert status == 2
    assert_one_line(err.splitlines(), "error: ", message)  # and no start line before it
    assert tree(fd_copy) == before


@pytest.mark.parametrize("field,value,message", [
    ("_phase", "flying", "machine._phase = 'flying' is not one of approach, rebound"),
    ("in_contact", "yes", "machine.in_contact = 'yes' is not true or false"),
    ("_peak_speed", "fast", "machine._peak_speed = 'fast' is not a finite number"),
])
def test_a_hand_edited_record_in_a_checkpoint_is_refused(field, value, message, fd_copy, capsys):
    """state.json with machine._phase = "flying" or in_contact = "yes" was accepted (then "no impact", or an impact
    at 0.1168 s instead of 0.0701 s)."""
    path = fd_copy / "checkpoint" / "state.json"
    state = json.loads(path.read_text())
    state["integrator"]["records"]["wall"]["machine"][field] = value
    path.write_text(json.dumps(state))
    before = tree(fd_copy)
    status, lines = run_cli(capsys, "run", "--restart", str(fd_copy), "--quiet")
    assert status == 2
    assert_one_line(lines, "error: the checkpoint in", "checkpoint/state.json: integrator.records.wall." + message)
    assert tree(fd_copy) == before


# -- the run directory around the checkpoint --------------------------------------------------------------------------


def test_restart_refuses_out(fd_copy, tmp_path, capsys):
    """--restart DIR --out OTHER ignored --out silently."""
    other = tmp_path / "other"
    before = tree(tmp_path)
    status, lines = run_cli(capsys, "run", "--restart", str(fd_copy), "--out", str(other), "--quiet")
    assert status == 2
    assert_one_line(lines, "error: --restart continues the run in DIR and writes nowhere else: drop --out")
    assert tree(tmp_path) == before


def test_restart_refuses_an_edited_scene(fd_copy, capsys):
    """A restart after editing DIR/scene.toml continued with the new values: a hybrid run."""
    scene = fd_copy / "scene.toml"
    scene.write_text(scene.read_text().replace("density = 7780.0", "density = 8000.0"))
    before = tree(fd_copy)
    status, lines = run_cli(capsys, "run", "--restart", str(fd_copy), "--quiet")
    assert status == 2
    assert_one_line(lines, "scene.toml no longer matches its checkpoint (sphere.density 7780.0 -> 8000.0)")
    assert tree(fd_copy) == before


def test_restart_refuses_a_lost_trajectory(fd_copy, capsys):
    """A restart after deleting trajectory.csv started a new file mid-run without a word."""
    (fd_copy / "trajectory.csv").unlink()
    before = tree(fd_copy)
    status, lines = run_cli(capsys, "run", "--restart", str(fd_copy), "--quiet")
    assert status == 2
    assert_one_line(lines, "trajectory.csv is missing, but the checkpoint continues a trajectory of ")
    assert tree(fd_copy) == before
