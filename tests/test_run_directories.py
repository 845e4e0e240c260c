"""The run directory and a study's --out: --force replaces only a run directory and never what the user works in,
one run owns a directory, runs never nest, and an --out the file system cannot give is refused in one line (no
start line before it) with everything around left as it was.  The ODE model in this process; real processes where
two runs at once or another user is the point."""
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest
from mpi4py import MPI

from fem_bounce import cli, output
from helpers import (ODE, as_nobody_or_skip, assert_one_line, messages, refused, refused_same_listing, run_cli, spawn,
                     tree)


# -- --force replaces only a run directory ----------------------------------------------------------------------------


@pytest.mark.parametrize("case,message", [
    ("empty", "--out is empty"),
    ("dot", "is the current directory"),
    ("parent", "is a parent of the current directory"),
    ("home", "is the home directory"),
    ("repository", "is a repository root"),
    ("link to cwd", "is the current directory"),
])
def test_force_never_replaces_what_the_user_works_in(case, message, tmp_path, monkeypatch, capsys):
    """`--out "" --force` and `--out . --force` emptied the current directory (from a checkout's root:
    the checkout); the home directory, a repository root and any spelling of them are refused alike."""
    work, home, repository = tmp_path / "work", tmp_path / "home", tmp_path / "repository"
    for folder in (work, home, repository / ".git"):
        (folder / "sub").mkdir(parents=True)
        (folder / "thesis.tex").write_text("\\chapter{Results}")
        (folder / "sub" / "data.bin").write_bytes(os.urandom(64))
    (tmp_path / "link").symlink_to(work)
    monkeypatch.chdir(work)
    monkeypatch.setenv("HOME", str(home))
    # matplotlib, when first imported by this test, caches its fonts under HOME: keep that outside the tree
    monkeypatch.setenv("MPLCONFIGDIR", str(tmp_path.parent / f"{tmp_path.name}-matplotlib"))
    out = {"empty": "", "dot": ".", "parent": "..", "home": str(home), "repository": str(repository),
           "link to cwd": str(tmp_path / "link")}[case]
    before = tree(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--out", out, "--force")
    assert status == 2
    assert_one_line(lines, "error: ", message)
    assert tree(tmp_path) == before


def test_force_replaces_only_a_marked_run_directory(tmp_path, capsys):
    """--force deleted a directory holding thesis.tex and sub/data.bin; now only a directory holding
    the marker a run writes first (.fem-bounce-run) is replaced."""
    folder = tmp_path / "results"
    (folder / "sub").mkdir(parents=True)
    (folder / "thesis.tex").write_text("\\chapter{Results}")
    (folder / "sub" / "data.bin").write_bytes(os.urandom(64))
    before = tree(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--out", str(folder), "--force")
    assert status == 2
    assert_one_line(lines, "is not a fem-bounce run directory (it has no .fem-bounce-run)")
    assert tree(tmp_path) == before
    run_dir = tmp_path / "run"
    assert cli.main(["run", "li2011-case3", *ODE, "--set", "run.end_time=0.01", "--out", str(run_dir)]) == 0
    assert (run_dir / output.MARKER).is_file()


def test_run_directory_refusals_print_no_start_line(tmp_path, monkeypatch, capsys):
    """Every run-directory refusal printed the start line ("... on 1 rank(s) -> DIR") before its one line."""
    (tmp_path / "results" / "sub").mkdir(parents=True)
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "results", "--force",
            message="results is not a fem-bounce run directory")


# -- an --out that cannot be a run directory --------------------------------------------------------------------------


def test_unwritable_out_gives_one_line(tmp_path):
    """--out where the user may not write (run as another user when the tests run as root)."""
    base = Path(tempfile.mkdtemp(prefix="fem-bounce-ro-"))  # outside pytest's private (0700) tree
    try:
        locked = base / "locked"
        locked.mkdir()
        base.chmod(0o755)
        locked.chmod(0o555)
        out = locked / "run"
        env = {**os.environ, "HOME": str(base)}
        other_user = {}
        if os.geteuid() == 0:  # root may write anywhere: nobody runs it
            other_user = as_nobody_or_skip(base, env)
        before = tree(base)
        process = spawn(["run", "li2011-case3", *ODE, "--out", str(out)], cwd=base, env=env, **other_user)
        _, err = process.communicate(timeout=120)
        assert process.returncode == 2
        assert_one_line(messages(err), f"error: cannot use {out} as a run directory: Permission denied")
        assert tree(base) == before
    finally:
        (base / "locked").chmod(0o755)
        shutil.rmtree(base)


@pytest.mark.parametrize("case,message", [
    ("/proc", "cannot use /proc/fem-bounce-test/run as a run directory: "),
    ("/sys", "cannot use /sys/fem-bounce-test/run as a run directory: "),
    ("regular file", "exists and is not a directory"),
    ("below a regular file", "as a run directory: Not a directory"),
])
def test_out_that_cannot_be_a_directory(case, message, tmp_path, capsys):
    (tmp_path / "notes.txt").write_text("keep")
    out = {"/proc": "/proc/fem-bounce-test/run", "/sys": "/sys/fem-bounce-test/run",
           "regular file": str(tmp_path / "notes.txt"),
           "below a regular file": str(tmp_path / "notes.txt" / "run")}[case]
    before = tree(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--out", out)
    assert status == 2
    assert_one_line(lines, "error: ", message)
    assert tree(tmp_path) == before


@pytest.mark.parametrize("out,message", [
    ("a" * 300, "File name too long"),
    ("loop", "is a loop of symbolic links"),
    ("dangling", "is a symbolic link to nowhere, which does not exist"),
])
def test_out_paths_the_filesystem_refuses_give_one_line(out, message, tmp_path, monkeypatch, capsys):
    """OSError 36 and RuntimeError tracebacks."""
    (tmp_path / "loop").symlink_to(tmp_path / "loop2")
    (tmp_path / "loop2").symlink_to(tmp_path / "loop")
    (tmp_path / "dangling").symlink_to("nowhere")  # said "File exists"
    refused_same_listing(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", out, message=message)


# -- one owner, no nesting --------------------------------------------------------------------------------------------


def test_two_forced_runs_on_one_directory_do_not_mix(tmp_path):
    """Both exited 0 with summary.json from one run and scene.toml from the other."""
    argv = ["run", "li2011-case3", *ODE, "--out", "same", "--force", "--set", "run.bounces=3"]
    first = spawn(argv, tmp_path)
    marker = tmp_path / "same" / output.MARKER
    start = time.monotonic()
    while not marker.is_file() and first.poll() is None and time.monotonic() - start < 120:
        time.sleep(0.01)
    second = spawn(argv + ["--set", "sphere.density=8500"], tmp_path)
    outcomes = [p.wait(timeout=300) for p in (first, second)]
    errors = [p.stderr.read() for p in (first, second)]
    assert sorted(outcomes) == [0, 2], errors
    refusal = errors[outcomes.index(2)]
    assert "is in use by another fem-bounce run" in refusal and "Traceback" not in refusal
    summary = json.loads((tmp_path / "same" / "summary.json").read_text())
    scene_text = (tmp_path / "same" / "scene.toml").read_text()
    assert summary["status"] == "completed"
    assert ("8500" in scene_text) == (summary["scene"]["sphere"]["density"] == 8500)  # one run's files only


def test_no_run_inside_a_run_and_force_keeps_nested_runs(tmp_path, monkeypatch, capsys):
    """--out outer/inner was accepted, and a later --out outer --force deleted it without a word."""
    monkeypatch.chdir(tmp_path)
    assert run_cli(capsys, "run", "li2011-case3", *ODE, "--out", "outer", "--set", "run.bounces=1")[0] == 0
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--out", "outer/inner")
    assert status == 2 and not (tmp_path / "outer" / "inner").exists()
    assert_one_line(lines, "error: outer/inner is inside the run directory")
    (tmp_path / "outer" / "kept" / "run").mkdir(parents=True)
    (tmp_path / "outer" / "kept" / "run" / output.MARKER).write_text(output.MARKER_TEXT)
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--out", "outer", "--force")
    assert status == 2 and (tmp_path / "outer" / "kept" / "run" / output.MARKER).is_file()
    assert_one_line(lines, "holds another run directory", "--force never deletes a run")


# -- a study's --out --------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("place", ["a file", "a run directory", "read-only"])
def test_a_study_out_that_cannot_hold_it_is_refused_first(place, fd_run, tmp_path, monkeypatch, capsys):
    """A read-only --out or a file failed late with "cannot write the output" (no path) and exit 1; a study wrote
    into an existing run directory."""
    argv = ["study", "convergence", "li2011-case3", "--model", "ode", "--levels", "1e-5,1e-6,1e-7"]
    if place == "a file":
        (tmp_path / "notes.txt").write_text("keep")
        refused(capsys, tmp_path, monkeypatch, *argv, "--out", "notes.txt", message="notes.txt exists and is not a "
                "directory")
    elif place == "a run directory":
        shutil.copytree(fd_run, tmp_path / "run")
        refused(capsys, tmp_path, monkeypatch, *argv, "--out", "run", message="run is a run directory or inside one")
    else:
        base = Path(os.path.realpath(tmp_path.parent)) / f"{tmp_path.name}-ro"
        (base / "locked").mkdir(parents=True)
        base.chmod(0o755)
        (base / "locked").chmod(0o555)
        env = {**os.environ, "HOME": str(base)}
        try:
            other = as_nobody_or_skip(base, env) if os.geteuid() == 0 else {}
            before = tree(base)
            done = subprocess.run([sys.executable, "-m", "fem_bounce", *argv, "--out", str(base / "locked" / "s")],
                                  cwd=base, env=env, capture_output=True, text=True, timeout=120, **other)
            assert done.returncode == 2
            assert_one_line(done.stderr.splitlines(), f"error: cannot write the study in {base / 'locked' / 's'}")
            assert tree(base) == before
        finally:
            (base / "locked").chmod(0o755)
            shutil.rmtree(base)


@pytest.mark.mpi
def test_a_study_out_is_refused_on_every_rank(shared_tmp, capsys):
    """Under mpiexec only rank 0 checked a study's --out: it exited 2 while the other ranks went on into the
    study and waited for rank 0 for ever.  (Serial here too.)"""
    notes = shared_tmp / "notes.txt"
    if MPI.COMM_WORLD.rank == 0:
        notes.write_text("keep")
    MPI.COMM_WORLD.barrier()
    status, lines = run_cli(capsys, "study", "convergence", "li2011-case3", "--model", "ode", "--levels",
                            "1e-5,1e-6,1e-7", "--out", str(notes))
    assert status == 2 and notes.read_text() == "keep"
    if MPI.COMM_WORLD.rank == 0:
        assert_one_line(lines, "error: ", "notes.txt exists and is not a directory")
