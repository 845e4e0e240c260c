"""The command line: outputs, the file contract, and one clear line for each user error."""
import json
import logging
import os
import re
import shlex
import subprocess
import sys
import warnings

import pytest
from mpi4py import MPI

import fem_bounce as fb
from fem_bounce import cli, library_log, output
from helpers import ODE, ODE_ONE, assert_one_line, refused_same_listing, run_cli

CONTRACT_SUMMARY = {"scene", "model", "impacts", "rebounds", "wall_time_s", "steps", "ranks", "versions", "command"}


@pytest.mark.mpi
def test_run_writes_the_contracted_files(shared_tmp):
    out = shared_tmp / "case3"
    assert cli.main(["run", "li2011-case3", "--model", "ode", "--out", str(out), "--quiet",
                     "--set", "run.bounces=2"]) == 0
    MPI.COMM_WORLD.barrier()
    assert {p.name for p in out.iterdir()} >= {"scene.toml", "trajectory.csv", "summary.json", "trajectory.png",
                                                "velocity_gap.png"}
    summary = json.loads((out / "summary.json").read_text())
    assert CONTRACT_SUMMARY <= set(summary)
    assert summary["ranks"] == 1 and summary["model"] == "ode"  # a serial model runs on rank 0 alone
    assert len(summary["impacts"]) == 2 and len(summary["rebounds"]) == 2
    assert {"time", "impact_speed", "peak_speed", "Re", "St", "min_gap"} <= set(summary["impacts"][0])
    assert {"restitution", "rebound_speed", "apex_gap", "apex_time"} <= set(summary["rebounds"][0])
    trajectory = output.read_trajectory(out)
    assert trajectory["gap"][0] == 0.0152 and trajectory["t"][-1] == pytest.approx(summary["final"]["time"])
    # the resolved scene runs again unchanged
    again = shared_tmp / "again"
    assert cli.main(["run", str(out / "scene.toml"), "--model", "ode", "--out", str(again), "--quiet"]) == 0
    MPI.COMM_WORLD.barrier()
    assert json.loads((again / "summary.json").read_text())["impacts"] == summary["impacts"]


def test_library_output_goes_to_run_log_not_the_terminal(tmp_path, capsys):
    """On a cold form cache ffcx's unclosed C files (ResourceWarning) and the compiler's INFO lines came out
    as fem-bounce warnings between the run's own lines, so a test's one expected line became three."""
    run_dir = tmp_path / "run"
    output.RunDirectory(run_dir).prepare()
    root = logging.getLogger()
    with warnings.catch_warnings(), library_log.library_output():
        warnings.simplefilter("always")
        cli._route_warnings()
        warnings.warn_explicit("unclosed file <libffcx_forms_0.c>", ResourceWarning, "/anywhere/gc.py", 1)
        warnings.warn_explicit("old API", DeprecationWarning, "/usr/lib/python3/dist-packages/ffcx/jit.py", 2)
        warnings.warn("the package's own warning", stacklevel=1)  # reported from this file, not a library's
        level = root.level
        root.setLevel(logging.INFO)  # what distutils does while cffi compiles a form
        logging.info("x86_64-linux-gnu-gcc -c libffcx_forms_0.c")
        root.setLevel(level)
        library_log.LIBRARY_LOG.keep(run_dir, MPI.COMM_SELF)
    assert capsys.readouterr().err.splitlines() == ["fem-bounce: warning: the package's own warning"]
    log = (run_dir / "run.log").read_text()
    for line in ("ResourceWarning: unclosed file <libffcx_forms_0.c>", "ffcx/jit.py:2: DeprecationWarning: old API",
                 "INFO:root:x86_64-linux-gnu-gcc -c libffcx_forms_0.c"):
        assert line in log
    assert library_log.LIBRARY_LOG not in root.handlers  # logging as it was, once the command is over


def test_existing_directory_is_never_silently_replaced(tmp_path, capsys):
    out = tmp_path / "run"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    assert cli.main(["run", "li2011-case1", "--model", "ode", "--out", str(out), "--quiet"]) == 2
    assert "exists and is not empty; pass --force" in capsys.readouterr().err
    assert (out / "keep.txt").read_text() == "precious"
    # --force replaces only a run directory (tests/test_run_directories.py has the other cases)
    assert cli.main(["run", "li2011-case1", "--model", "ode", "--out", str(out), "--quiet", "--force"]) == 2
    assert (out / "keep.txt").read_text() == "precious"
    run_dir = tmp_path / "earlier"
    assert cli.main(["run", "li2011-case1", "--model", "ode", "--out", str(run_dir), "--quiet"]) == 0
    (run_dir / "stale.txt").write_text("from before")
    assert cli.main(["run", "li2011-case1", "--model", "ode", "--out", str(run_dir), "--quiet", "--force"]) == 0
    assert not (run_dir / "stale.txt").exists() and (run_dir / "summary.json").is_file()


@pytest.mark.parametrize("argv,message", [
    (["run", "--model", "ode", "--set", "sphere.densty=3"], "unknown key sphere.densty; did you mean sphere.density?"),
    (["run", "--model", "ode", "--set", "liquid.viscosity=-1"],
     "liquid.viscosity = -1.0 Pa s is out of range: allowed in (0, 1e+08] Pa s"),
    (["run", "--model", "ode", "--set", "initial_gap=0"], "initial_gap = 0.0 m is out of range: allowed > 0 m"),
    (["run", "--model", "ode", "--set", "contact.delta_ss=0.3"], "must be smaller than contact.delta_sl"),
    (["run", "--model", "xyz"], "unknown model 'xyz': choose one of ode, fd, ib, ale"),
    (["run", "li2011-case33", "--model", "ode"], "did you mean li2011-case3?"),
    (["run", "--model", "ode", "--set", "nonsense"], "expected key=value"),
    (["scenes", "show"], "scenes show needs a NAME"),
])
def test_user_errors_exit_2_with_one_line(argv, message, capsys):
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("fem-bounce: error: ") and message in err[0]


def test_scene_dump_runs_unchanged_as_a_scene_file(tmp_path, capsys):
    assert cli.main(["scenes", "show", "tencate2002-e4"]) == 0
    path = tmp_path / "e4.toml"
    path.write_text(capsys.readouterr().out)
    out = tmp_path / "e4"
    assert cli.main(["run", str(path), "--model", "ode", "--out", str(out), "--quiet",
                     "--set", "run.end_time=0.3"]) == 0
    assert json.loads((out / "summary.json").read_text())["scene"]["name"] == "tencate2002-e4"


def test_scenes_lists_the_presets(capsys):
    assert cli.main(["scenes"]) == 0
    listing = capsys.readouterr().out
    for name in ("li2011-case1", "li2011-case7", "li2011-table3-steel-85", "tencate2002-e4"):
        assert name in listing


# -- one line, printed once -------------------------------------------------------------------------------------------


def test_empty_model_name_is_refused(tmp_path, monkeypatch, capsys):
    """--model '' ran the default fd model at 24 cells/D."""
    refused_same_listing(capsys, tmp_path, monkeypatch, "run", "li2011-case3", "--model", "", "--quiet", "--out", "r",
                         message="unknown model ''")


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


@pytest.mark.mpi
def test_errors_and_warnings_print_once_under_mpiexec(shared_tmp, capsys):
    """Under mpiexec every error was printed once per rank, and the ode model ran the same integration on
    every rank without a word.  (Serial here too: then there is no warning.)"""
    comm = MPI.COMM_WORLD
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--set", "liquid.viscosity=-1")
    assert status == 2
    if comm.rank == 0:
        assert_one_line(lines, "error: liquid.viscosity = -1.0 Pa s is out of range")
    else:
        assert lines == []
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--set", "run.bounces=1",
                            "--out", str(shared_tmp / "ode"))
    assert status == 0
    if comm.rank == 0 and comm.size > 1:
        assert_one_line(lines, f"warning: the ode model is serial: under mpiexec it runs on rank 0 alone and the "
                               f"other {comm.size - 1} rank(s) wait")
    else:
        assert lines == []


@pytest.mark.parametrize("make", ["missing", "empty", "corrupt summary"])
def test_plots_entry_point_on_a_bad_directory_gives_one_line(make, tmp_path):
    """Six different tracebacks, and exit 0 with no argument."""
    folder = tmp_path / "d"
    if make != "missing":
        folder.mkdir()
    if make == "corrupt summary":
        (folder / "summary.json").write_text("{")
        (folder / "trajectory.csv").write_text("t,gap\n")
    done = subprocess.run([sys.executable, "-m", "fem_bounce.plots", str(folder)], capture_output=True, text=True)
    assert done.returncode == 2 and "Traceback" not in done.stderr
    assert len(done.stderr.splitlines()) == 1 and f"cannot draw {folder}" in done.stderr
    bare = subprocess.run([sys.executable, "-m", "fem_bounce.plots"], capture_output=True, text=True)
    assert bare.returncode == 2 and bare.stderr.startswith("usage: python -m fem_bounce.plots")


def test_plots_speaks_once_under_mpiexec(tmp_path, mpiexec):
    """`mpiexec -n 2 python -m fem_bounce.plots nonexistent` printed its error once per rank."""
    done = subprocess.run([mpiexec, "-n", "2", sys.executable, "-m", "fem_bounce.plots", "nonexistent"], cwd=tmp_path,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 2
    assert len(done.stderr.splitlines()) == 1 and "cannot draw nonexistent" in done.stderr


# -- what the command line prints and draws ---------------------------------------------------------------------------


def test_huge_numbers_print_readably(tmp_path, capsys):
    """Re and St printed with 300 digits for a viscosity of 1e-300."""
    status = cli.main(["run", "li2011-case3", *ODE, "--set", "liquid.viscosity=1e-300", "--set", "run.bounces=1",
                       "--out", str(tmp_path / "run")])
    captured = capsys.readouterr()
    assert status == 0
    printed = captured.out.splitlines() + captured.err.splitlines()
    assert max(len(line) for line in printed) < 250 and any(re.search(r"Re = 5\.\d\de\+300", line) for line in printed)


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
