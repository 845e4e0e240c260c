"""A full disk and a full stdout: the one line naming the file that could not be written, the trajectory ending in a
whole row, a summary saying why, nothing cached half-written and nothing left behind by a refusal.  A file-size
limit (RLIMIT_FSIZE; Python ignores SIGXFSZ, so writes fail with EFBIG as with ENOSPC) stands in for the full disk,
in a process of its own; a real full tmpfs where the tests may mount one."""
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from fem_bounce import cli
from helpers import FD_TOY, ODE, ODE_ONE, assert_one_line, messages, spawn, whole_rows


def limited(argv: list[str], cwd: Path, limit: int) -> subprocess.CompletedProcess:
    """fem-bounce with every file limited to `limit` bytes (RLIMIT_FSIZE: a full disk; writes fail with EFBIG),
    set after MPI has started (its runtime writes large shared-memory files of its own)."""
    launcher = ("import resource, sys; from mpi4py import MPI; "
                f"resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, resource.RLIM_INFINITY)); "
                f"from fem_bounce.cli import main; sys.exit(main({argv!r}))")
    return subprocess.run([sys.executable, "-c", launcher], cwd=cwd, capture_output=True, text=True, timeout=300)


# -- the run's files --------------------------------------------------------------------------------------------------


def test_disk_full_keeps_whole_rows_and_says_why(tmp_path):
    """A full disk gave two chained tracebacks, no summary.json and a half-written last row.  A file-size
    limit (RLIMIT_FSIZE; Python ignores SIGXFSZ, so writes fail with EFBIG) stands in for the full disk:
    the trajectory write fails mid-run exactly as with ENOSPC.  The limit is set after MPI has started
    (its runtime writes large shared-memory files of its own)."""
    out = tmp_path / "run"
    limit = 150_000  # bytes per file: the trajectory passes it within 0.4 s of model time
    argv = ["run", "li2011-case3", *ODE, "--set", "run.bounces=0", "--set", "run.end_time=5", "--out", str(out)]
    launcher = ("import resource, sys; from mpi4py import MPI; "
                f"resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, resource.RLIM_INFINITY)); "
                f"from fem_bounce.cli import main; sys.exit(main({argv!r}))")
    process = subprocess.run([sys.executable, "-c", launcher], cwd=tmp_path, capture_output=True, text=True,
                             timeout=120)
    assert process.returncode == 1
    assert_one_line(messages(process.stderr), f"error: cannot write {out / 'trajectory.csv'}: File too large")
    rows = whole_rows(out / "trajectory.csv")  # ends in a whole row
    assert 0 < len(rows) and (out / "trajectory.csv").stat().st_size <= limit
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"].startswith("failed: cannot write") and summary["final"]["time"] > rows[-1, 0] - 1e-12
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_really_full_disk_when_a_tmpfs_can_be_mounted(tmp_path):
    """The same on a real full file system (ENOSPC): a 200 kB tmpfs.  Needs the right to mount (root in
    a privileged container); skipped otherwise.  The summary's space is reserved when the run starts."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    disk = tmp_path / "disk"
    disk.mkdir()
    mounted = subprocess.run(["mount", "-t", "tmpfs", "-o", "size=200k", "tmpfs", str(disk)], capture_output=True,
                             text=True)
    if mounted.returncode:
        pytest.skip(f"cannot mount a tmpfs here: {mounted.stderr.strip()}")
    try:
        out = disk / "run"
        process = spawn(["run", "li2011-case3", *ODE, "--set", "run.bounces=0", "--set", "run.end_time=5",
                         "--out", str(out)], cwd=tmp_path)
        _, err = process.communicate(timeout=120)
        assert process.returncode == 1
        assert_one_line(messages(err), f"error: cannot write {out / 'trajectory.csv'}: No space left on device")
        assert len(whole_rows(out / "trajectory.csv")) > 0
        assert json.loads((out / "summary.json").read_text())["status"].startswith("failed: cannot write")
    finally:
        subprocess.run(["umount", str(disk)], check=True)


def test_a_full_disk_at_a_checkpoint_gives_one_line(fd_run, tmp_path):
    """"Exception ignored in ZipFile.__del__" and its traceback came before the right line.  (fd_run has put
    the toy's mesh in the cache: only the checkpoint's 360 kB flow.npz passes the limit.)"""
    out = tmp_path / "run"
    done = limited(["run", *FD_TOY, "--out", str(out)], tmp_path, 150_000)
    assert done.returncode == 1
    assert "Exception ignored" not in done.stderr
    assert_one_line(messages(done.stderr), f"error: cannot write the checkpoint in {out}: File too large")
    assert json.loads((out / "summary.json").read_text())["status"].startswith("failed: cannot write the checkpoint")


def test_no_room_for_the_summary_leaves_nothing(tmp_path):
    """Refused for want of room after the marker and scene.toml were written: the directory stayed."""
    done = limited(["run", "li2011-case3", *ODE, "--out", "r"], tmp_path, 30_000)
    assert done.returncode == 2
    assert_one_line(done.stderr.splitlines(), "error: cannot reserve 64 kB for r/summary.json: File too large")
    assert list(tmp_path.iterdir()) == []


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


# -- the mesh cache and stdout ----------------------------------------------------------------------------------------


def test_a_full_disk_while_meshing_caches_nothing(tmp_path, monkeypatch):
    """A truncated .msh was cached on a full disk and every later run needing it failed ("Could not read
    elements") until the user deleted the cache."""
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "cache"))
    argv = ["run", "li2011-case3", "--model", "ale", "--quiet", "--set", "run.end_time=0.002"]
    done = limited([*argv, "--out", "full"], tmp_path, 100_000)  # its 16 cells/D mesh is 360 kB
    assert done.returncode == 1
    assert_one_line(messages(done.stderr), "error: cannot mesh into ", "is the disk full?")
    assert list((tmp_path / "cache" / "meshes").iterdir()) == []
    assert cli.main([*argv, "--out", str(tmp_path / "room")]) == 0


def test_full_stdout_gives_one_line(tmp_path):
    """OSError 28 traceback after the run when stdout is /dev/full."""
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "fem_bounce", "run", "li2011-case3", *ODE, "--out", "r",
                               "--set", "run.bounces=1"], cwd=tmp_path, stdout=full, stderr=subprocess.PIPE, text=True)
    assert done.returncode == 1 and "Traceback" not in done.stderr and "Exception ignored" not in done.stderr
    assert done.stderr.splitlines()[-1] == "fem-bounce: error: cannot write the output: No space left on device"
