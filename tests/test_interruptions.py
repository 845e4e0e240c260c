"""Signals, kills and closed pipes: Ctrl-C and SIGTERM end a run (or a study's planning, or its meshing) promptly
with one line and a summary saying "interrupted", under mpiexec too and while the figures are drawn; a killed run or
study takes its mesher and workers along; a closed pipe ends quietly.  Real processes, since the signal is the
point.  A real SIGKILL (or Ctrl-C) then --restart, for every model that writes checkpoints: tests/test_restart.py."""
import json
import os
import re
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mpi4py import MPI

import fem_bounce as fb
from fem_bounce.fem import mesh as halfplane
from helpers import FD_TOY, ODE, ODE_ONE, assert_one_line, children_of, messages, run_cli, spawn, wait_for, whole_rows


# -- a run stopped by a signal ----------------------------------------------------------------------------------------


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_signal_ends_a_run_with_a_summary(signum, tmp_path):
    """Ctrl-C printed a KeyboardInterrupt traceback, SIGTERM (batch schedulers) ended a run without a
    word; neither left a summary."""
    out = tmp_path / "run"
    process = spawn(["run", "li2011-case3", *ODE, "--set", "run.bounces=0", "--set", "run.end_time=100",
                     "--out", str(out)], cwd=tmp_path)
    wait_for(lambda: (out / "trajectory.csv").is_file() and (out / "trajectory.csv").stat().st_size > 1000, process)
    process.send_signal(signum)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 128 + signum
    name = signal.Signals(signum).name
    assert_one_line(messages(err), f"interrupted by {name} at t = ", "the ode model writes no checkpoints")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and name in summary["stop_reason"]
    whole_rows(out / "trajectory.csv")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_ctrl_c_to_mpiexec_ends_with_a_summary(tmp_path, mpiexec):
    """SIGINT to `mpiexec -n 2` ended the run without a summary.  MPICH's mpiexec passes it on to every rank as
    SIGINT (OpenMPI's as SIGTERM, killing the ranks 1 s later): the ranks stop together after their step."""
    out = tmp_path / "run"
    process = subprocess.Popen(
        [mpiexec, "-n", "2", sys.executable, "-m", "fem_bounce", "run", "li2011-case3", *ODE, "--set",
         "run.bounces=0", "--set", "run.end_time=100", "--out", str(out)],
        cwd=tmp_path, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wait_for(lambda: (out / "trajectory.csv").is_file() and (out / "trajectory.csv").stat().st_size > 1000, process)
    process.send_signal(signal.SIGINT)
    _, err = process.communicate(timeout=60)
    assert process.returncode != 0
    lines = [line for line in messages(err) if line.startswith("fem-bounce: ")]
    assert len([line for line in lines if re.search("interrupted by SIG(INT|TERM)", line)]) == 1, err  # rank 0 only
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["ranks"] == 1  # the serial ode model: rank 0 alone
    whole_rows(out / "trajectory.csv")


def test_sigterm_after_meshing_ends_with_a_summary(tmp_path):
    """gmsh.initialize put the default SIGTERM handler back when the mesh was read: a resolved run then died of
    SIGTERM without a word or a summary (a batch scheduler's stop)."""
    out = tmp_path / "run"
    process = spawn(["run", *FD_TOY, "--set", "run.end_time=1", "--out", str(out)], tmp_path)
    wait_for(lambda: (out / "checkpoint" / "model.txt").is_file(), process)
    process.send_signal(signal.SIGTERM)
    _, err = process.communicate(timeout=60)
    assert process.returncode == 143
    assert_one_line(messages(err), "interrupted by SIGTERM at t = ", "fem-bounce run --restart")
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"


def test_meshing_answers_a_signal(tmp_path):
    """SIGTERM while gmsh meshed killed the run without a word (gmsh reset the handler), or was ignored."""
    env = {**os.environ, "FEM_BOUNCE_CACHE": str(tmp_path / "cache")}
    out = tmp_path / "run"
    process = subprocess.Popen([sys.executable, "-m", "fem_bounce", "run", "li2011-case3", "--model", "ale", "--quiet",
                                "--set", "numerics.ale.cells_per_diameter=128", "--out", str(out)], cwd=tmp_path,
                               env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)

    def mesher() -> list[int]:  # the child that meshes (gmsh, ~5 s at 128 cells/D)
        return children_of(process.pid)

    wait_for(lambda: bool(mesher()), process)
    child = mesher()[0]
    time.sleep(0.5)
    process.send_signal(signal.SIGTERM)
    start = time.monotonic()
    _, err = process.communicate(timeout=60)
    assert time.monotonic() - start < 2.0
    assert process.returncode == 143
    assert_one_line(messages(err), "interrupted by SIGTERM")
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"
    assert not Path(f"/proc/{child}").exists() or "Z" in Path(f"/proc/{child}/stat").read_text().split(")")[-1][:3]
    assert list((tmp_path / "cache" / "meshes").iterdir()) == []


@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_restitution_planning_answers_signals(signum, tmp_path):
    """`fem-bounce restitution --points 2`: its 80-100 s planning ignored Ctrl-C and SIGTERM."""
    process = spawn(["restitution", "--points", "2", "--out", "o"], tmp_path)
    time.sleep(4.0)  # in the planning's ODE runs (~30 s), well past the imports
    assert process.poll() is None
    process.send_signal(signum)
    start = time.monotonic()
    _, err = process.communicate(timeout=60)
    assert time.monotonic() - start < 2.0
    assert process.returncode == 128 + signum
    assert_one_line(messages(err), f"interrupted by {signal.Signals(signum).name}")
    assert list(tmp_path.iterdir()) == []


# -- a kill takes the children along ----------------------------------------------------------------------------------


def gone(pid: int) -> bool:
    """No such process, or a zombie waiting for whoever adopted it."""
    try:
        return Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0] == "Z"
    except OSError:
        return True


def test_a_killed_run_takes_its_mesher_along_and_a_later_run_clears_its_leftovers(tmp_path, monkeypatch):
    """SIGKILL while gmsh meshed a large ale mesh in its child left the child meshing on as an orphan (it asked to
    die with its parent only after its imports) and its .partial.msh in the cache for ever."""
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "cache"))
    process = spawn(["run", "li2011-case3", "--model", "ale", "--quiet", "--set", "numerics.ale.cells_per_diameter=100",
                     "--out", "run"], tmp_path)
    wait_for(lambda: bool(children_of(process.pid, "fem_bounce.fem.mesh")), process)
    mesher = children_of(process.pid, "fem_bounce.fem.mesh")[0]
    process.kill()
    process.communicate()
    try:
        deadline = time.monotonic() + 5.0
        while not gone(mesher) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert gone(mesher)
    finally:
        if not gone(mesher):
            os.kill(mesher, signal.SIGKILL)
    meshes = tmp_path / "cache" / "meshes"
    dead, alive = meshes / f".halfplane-0.{process.pid}.partial.msh", meshes / f".halfplane-1.{os.getpid()}.partial.msh"
    for path in (dead, dead.with_name(dead.name + ".sha256"), alive):
        path.write_text("half a mesh")  # the killed run's (its process id is free now) and a live one's
    halfplane.create_mesh(MPI.COMM_SELF, halfplane.HalfPlane(radius=0.05, height=0.1, fine_size=0.01,
                                                              coarse_size=0.02, grading=0.2))
    assert sorted(p.name for p in meshes.glob(".*")) == [alive.name]


def test_study_workers_die_with_the_study(tmp_path):
    """A restitution sweep killed by SIGKILL left its two workers running on (50 s and more)."""
    study = spawn(["restitution", "--points", "4", "--jobs", "2", "--out", "sweep"], tmp_path)
    workers: list[int] = []
    start = time.monotonic()
    while len(workers) < 2 and time.monotonic() - start < 120 and study.poll() is None:
        workers = children_of(study.pid, "spawn_main")
        time.sleep(0.2)
    assert len(workers) == 2, "the study did not start its workers"
    study.kill()
    study.wait()
    deadline = time.monotonic() + 20
    while time.monotonic() < deadline and any(Path(f"/proc/{pid}").exists() and
                                              "Z" not in _state(pid) for pid in workers):
        time.sleep(0.2)
    assert not [pid for pid in workers if Path(f"/proc/{pid}").exists() and "Z" not in _state(pid)]


def _state(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except OSError:
        return "Z"


# -- while the figures are drawn --------------------------------------------------------------------------------------


def test_a_signal_while_the_figures_are_drawn_counts(tmp_path, monkeypatch, capsys):
    """One SIGTERM (or SIGINT) while `fem-bounce run` drew its figures only set the stop flag, which nothing read
    any more: exit 0, status completed."""
    from fem_bounce import plots

    draw_run = plots.draw_run

    def signalled(*args):
        os.kill(os.getpid(), signal.SIGTERM)  # Interrupts (cli.main) takes it: a flag, and the drawing goes on
        return draw_run(*args)

    monkeypatch.setattr(plots, "draw_run", signalled)
    out = tmp_path / "run"
    status, lines = run_cli(capsys, "run", *ODE_ONE, "--out", str(out))
    assert status == 128 + signal.SIGTERM
    assert_one_line(lines, "interrupted by SIGTERM while drawing the figures")
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"


def test_ctrl_c_while_drawing_records_an_interruption(tmp_path, monkeypatch):
    """Ctrl-C while fb.simulate drew its figures escaped as a bare KeyboardInterrupt, and summary.json said
    "completed" with the figures missing."""
    from fem_bounce import plots

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(plots, "draw_run", interrupted)
    out = tmp_path / "run"
    with pytest.raises(fb.RunInterrupted, match="while drawing the figures") as caught:
        fb.simulate(fb.load("li2011-case3", {"run.bounces": 1}), "ode", out=out)
    assert caught.value.signum == signal.SIGINT
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"


# -- a closed pipe ----------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("argv", [["scenes"], ["run", *ODE_ONE, "--out", "run"]])
def test_a_closed_pipe_ends_quietly(argv, tmp_path):
    """`fem-bounce scenes | head -1`, `fem-bounce run ... 2>&1 | head -1`: PETSc's handler caught SIGPIPE, printed
    7 PETSC ERROR lines and aborted (exit 15).  The reader here goes before (scenes) or after (run) the first line."""
    process = subprocess.Popen([sys.executable, "-m", "fem_bounce", *argv], cwd=tmp_path, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT if argv[0] == "run" else subprocess.PIPE)
    if argv[0] == "run":
        assert process.stdout.readline().startswith(b"fem-bounce: li2011-case3 with the ode model")
    process.stdout.close()
    err = process.stderr.read().decode() if process.stderr else ""
    assert process.wait(timeout=120) == 0 and err == ""
    if argv[0] == "run":
        assert json.loads((tmp_path / "run" / "summary.json").read_text())["status"] == "completed"
