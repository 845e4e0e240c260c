"""Round four of bad input (issue 43, part A), one test per finding: the exit status, the one line naming the
culprit, nothing written or left behind by a refusal, and no Python, C++ or PETSc error text.  The ODE model in
this process wherever the finding is not about a process; real processes where a pipe, a signal, a kill, a
deleted working directory or a locale is the point."""
import json
import os
import shlex
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from mpi4py import MPI

import fem_bounce as fb
from fem_bounce import cachedir, cli
from fem_bounce.fem import mesh as halfplane
from test_bad_input import ODE, assert_one_line, children_of, messages, run_cli, spawn, tree, wait_for
from test_bad_input_3 import limited, refused

ODE_ONE = ["li2011-case3", *ODE, "--set", "run.bounces=1"]


# -- tracebacks -------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("overrides", [{"contact.cavitation_pressure": -1e-300},
                                       {"liquid.ambient_pressure": 1e-320, "liquid.vapour_pressure": 0.0}])
def test_a_tension_below_the_films_scale_is_the_film_that_holds_none(overrides):
    """A tension of 1e-300 Pa (or an ambient pressure of 1e-320 Pa over no vapour pressure) overflowed 1 / s^2 in
    the tension relief: "ValueError: cannot convert float NaN to integer" after trajectory.csv was written.  It is
    the limit of a liquid that holds no tension."""
    scene = fb.load("li2011-case3", {"run.bounces": 1})
    tiny = fb.simulate(scene.replace(**overrides), "ode")
    none = fb.simulate(scene.replace(**{"contact.cavitation_pressure": 0.0}), "ode")
    assert tiny.status == "completed"
    assert tiny.rebounds[0].restitution == pytest.approx(none.rebounds[0].restitution, rel=1e-6)


@pytest.mark.parametrize("entry", [{"quantities": [1]}, {"error": True}])
def test_an_accuracy_record_of_wrong_types_names_its_file(entry, tmp_path, monkeypatch, capsys):
    """A record entry with "quantities": [1] or a bool "error" gave a TypeError on `run --accuracy 10%`."""
    pick = {"model": "ode", "setting": {"numerics.ode.rtol": 1e-3}, "error": 0.05, "quantities": ["impact_speed"],
            **entry}
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "accuracy_recommendations.json").write_text(json.dumps({"li2011-case3": {"10%": pick}}))
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", "--accuracy", "10%", "--quiet",
            message="results/accuracy_recommendations.json (the accuracy record `--accuracy` reads")



def test_scenes_show_writes_utf8_whatever_the_locale(tmp_path):
    """`LC_ALL=C ... fem-bounce scenes show FILE > out.toml` with an em dash in the description: UnicodeEncodeError
    (stdout took the C locale's ASCII)."""
    fb.save(fb.load("li2011-case3").replace(description="steel \u2014 glass"), tmp_path / "dash.toml")
    env = {**os.environ, "LC_ALL": "C", "LANG": "C", "PYTHONUTF8": "0", "PYTHONCOERCECLOCALE": "0"}
    with open(tmp_path / "out.toml", "wb") as out:
        done = subprocess.run([sys.executable, "-m", "fem_bounce", "scenes", "show", "dash.toml"], cwd=tmp_path,
                              env=env, stdout=out, stderr=subprocess.PIPE, text=True, timeout=120)
    assert done.returncode == 0 and done.stderr == ""
    assert fb.load(tmp_path / "out.toml").description == "steel \u2014 glass"


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


def test_a_deleted_working_directory_is_refused_in_one_line(tmp_path):
    """Run from a working directory that was deleted: PETSC ERROR lines ("Error in getcwd()") and a petsc4py
    traceback."""
    (tmp_path / "gone").mkdir()
    command = shlex.join([sys.executable, "-m", "fem_bounce", "run", *ODE_ONE])
    process = subprocess.Popen(["sh", "-c", f"cd gone && rmdir ../gone && exec {command}"], cwd=tmp_path,
                               stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    out, err = process.communicate(timeout=120)
    assert process.returncode == 2 and out == ""
    assert_one_line(err.splitlines(), "error: the working directory cannot be used (No such file or directory")

# -- signals ----------------------------------------------------------------------------------------------------


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



# -- caches and environment -------------------------------------------------------------------------------------


def test_a_cache_inside_a_run_directory_is_refused(tmp_path, monkeypatch, capsys):
    """FEM_BOUNCE_CACHE=<a run directory> fem-bounce compare ...: blamed --out and left a lock file in the run."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", *ODE_ONE, "--out", "r"]) == 0
    capsys.readouterr()
    before = tree(tmp_path)
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "r"))
    status, lines = run_cli(capsys, "compare", "li2011-case3", "--models", "ode", "--quiet", "--out", "c")
    assert status == 2
    assert_one_line(lines, f"error: fem_bounce's cache {tmp_path / 'r'} is inside the run directory",
                    "set FEM_BOUNCE_CACHE")
    assert tree(tmp_path) == before


def test_a_relative_xdg_cache_home_is_ignored(tmp_path, monkeypatch):
    """XDG_CACHE_HOME=rel put the cache in the working directory; the XDG rule: a relative path is invalid."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.delenv("FEM_BOUNCE_CACHE", raising=False)
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    monkeypatch.setenv("XDG_CACHE_HOME", "rel")
    assert cachedir.folder("runs") == tmp_path / "home" / ".cache" / "fem_bounce" / "runs"
    assert not (tmp_path / "rel").exists()


@pytest.mark.parametrize("argv,limit,status,message", [
    (["run", *ODE_ONE, "--out", "r"], 1000, 2, "error: cannot write r/scene.toml: File too large"),
    (["compare", "li2011-case3", "--models", "ode", "--quiet", "--out", "c"], 100_000, 1,
     "error: cannot make the study cache's run of li2011-case3 with the ode model in "),
])
def test_a_full_disk_leaves_nothing_and_names_no_removed_folder(argv, limit, status, message, tmp_path, monkeypatch):
    """On a full disk a refused run left .fem-bounce-run (and compare its --out with it), and a study-cache run's
    message said "outputs kept in .../.KEY.partial", a folder removed right after."""
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "cache"))
    work = tmp_path / "work"
    work.mkdir()
    done = limited(argv, work, limit)
    assert done.returncode == status
    assert_one_line(messages(done.stderr), message, "File too large")
    assert ".partial" not in done.stderr
    assert list(work.iterdir()) == [] and list((tmp_path / "cache" / "runs").glob(".*.partial")) == []


# -- fast to the prompt -------------------------------------------------------------------------------------------


def test_no_plots_draws_nothing(tmp_path, monkeypatch, capsys):
    """`fem-bounce run` spent ~3 s of its 5.4 s to the prompt drawing three figures, with no way to skip them
    (compare likewise drew every run's and its own)."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "cache"))
    status, lines = run_cli(capsys, "run", *ODE_ONE, "--no-plots", "--out", "r")
    assert status == 0 and lines == []
    status, lines = run_cli(capsys, "compare", "li2011-case3", "--models", "ode", "--quiet", "--no-plots",
                            "--set", "run.bounces=1", "--out", "c")
    assert status == 0 and lines == []
    assert (tmp_path / "r" / "summary.json").is_file() and (tmp_path / "c" / "comparison.csv").is_file()
    assert list(tmp_path.rglob("*.png")) == []


# -- minor ------------------------------------------------------------------------------------------------------


def test_api_flags_and_paths_are_checked(tmp_path, monkeypatch):
    """fb.simulate(..., plots="no") drew the figures, and fb.resume("") was taken as "." where out="" is refused."""
    monkeypatch.chdir(tmp_path)
    scene = fb.load("li2011-case3", {"run.bounces": 1})
    with pytest.raises(fb.OutputError, match="plots = 'no' must be True or False"):
        fb.simulate(scene, out="r", plots="no")
    with pytest.raises(fb.OutputError, match="run_dir is empty"):
        fb.resume("")
    assert list(tmp_path.iterdir()) == []


def test_plots_speaks_once_under_mpiexec(tmp_path, mpiexec):
    """`mpiexec -n 2 python -m fem_bounce.plots nonexistent` printed its error once per rank."""
    done = subprocess.run([mpiexec, "-n", "2", sys.executable, "-m", "fem_bounce.plots", "nonexistent"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert len(done.stderr.splitlines()) == 1 and "cannot draw nonexistent" in done.stderr
