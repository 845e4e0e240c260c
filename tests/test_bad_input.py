"""What a user types that went wrong before issue 15, one test per finding: each asserts the exit
status, the one line printed and that the files around were left as they were.

Cheapest first: the ODE model in this process wherever the finding is not model-specific; the fd
model at toy size (6 cells/D) where checkpoints are the point; a real subprocess where a signal, a
kill, a file-size limit, another user or mpiexec is the point.
"""
import csv
import hashlib
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

from fem_bounce import cli, output

ODE = ["--model", "ode", "--quiet"]
# the one-shot penalty along the path of a fixed mesh: its short steps give the checkpoints these tests break (60 of
# 65 steps)
FD_TOY = ["li2011-case3", "--model", "fd", "--quiet", "--set", "numerics.fd.cells_per_diameter=6",
          "--set", "run.end_time=0.03", "--set", "numerics.fd.checkpoint_every=10", "--set", "numerics.fd.mesh=fixed",
          "--set", "numerics.fd.constraint=penalty", "--set", "numerics.fd.patch=false"]


# -- helpers ---------------------------------------------------------------------------------------


def tree(root: Path) -> dict:
    """Every path under root with its content's hash (directories: None): what 'left as it was' means."""
    found = {}
    for path in sorted(Path(root).rglob("*")):
        key = str(path.relative_to(root))
        if path.is_symlink():
            found[key] = "-> " + os.readlink(path)
        elif path.is_dir():
            found[key] = None
        else:
            found[key] = hashlib.sha256(path.read_bytes()).hexdigest()
    return found


def messages(err: str) -> list[str]:
    """fem-bounce's lines, without the start line ('... on 1 rank(s) -> DIR').  (What ffcx says on its first
    compile of a form goes to run.log, so these lines do not depend on the machine's form cache.)"""
    assert "Traceback" not in err, err
    return [line for line in err.splitlines() if line.startswith("fem-bounce: ") and " rank(s) -> " not in line]


def run_cli(capsys, *argv) -> tuple[int, list[str]]:
    status = cli.main(list(argv))
    return status, messages(capsys.readouterr().err)


def assert_one_line(lines: list[str], *fragments: str) -> None:
    assert len(lines) == 1, lines
    assert lines[0].startswith("fem-bounce: ") and "Traceback" not in lines[0], lines
    for fragment in fragments:
        assert fragment in lines[0], (fragment, lines[0])


def spawn(argv: list[str], cwd: Path, **kwargs) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "fem_bounce", *argv], cwd=cwd, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, **kwargs)


def children_of(pid: int, command: str = "") -> list[int]:
    """The processes whose parent is `pid` and whose command line holds `command`, from /proc (as pgrep -P -f,
    without procps)."""
    found = []
    for stat in Path("/proc").glob("[0-9]*/stat"):
        try:
            parent = int(stat.read_text().rsplit(")", 1)[1].split()[1])
            line = (stat.parent / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except (OSError, IndexError, ValueError):  # gone meanwhile
            continue
        if parent == pid and command in line:
            found.append(int(stat.parent.name))
    return sorted(found)


def wait_for(predicate, process: subprocess.Popen, timeout: float = 120.0) -> None:
    start = time.monotonic()
    while not predicate():
        if process.poll() is not None:
            raise AssertionError(f"the run ended before the test could act: {process.communicate()}")
        if time.monotonic() - start > timeout:
            process.kill()
            raise AssertionError("timed out waiting for the run")
        time.sleep(0.02)


def whole_rows(path: Path) -> np.ndarray:
    text = Path(path).read_text()
    assert text.endswith("\n"), "the trajectory ends in a half-written row"
    rows = list(csv.reader(text.splitlines()))
    assert tuple(rows[0]) in (output.trajectory_columns(1), output.trajectory_columns(2))  # one sphere or a pair
    assert all(len(row) == len(rows[0]) for row in rows)
    return np.array(rows[1:], dtype=float)


def assert_same_trajectory(a: Path, b: Path) -> None:
    """Row by row: the same number of rows at the same printed times, the same values."""
    rows_a, rows_b = (Path(p).read_text().splitlines() for p in (a, b))
    assert len(rows_a) == len(rows_b), (len(rows_a), len(rows_b))
    assert [r.split(",")[0] for r in rows_a] == [r.split(",")[0] for r in rows_b]  # no row lost or doubled
    assert np.allclose(whole_rows(a), whole_rows(b), rtol=1e-9, atol=1e-14)


@pytest.fixture(scope="module")
def fd_run(tmp_path_factory):
    """A toy fd run, uninterrupted (checkpoints every 10 steps; its last at step 60 of 65): the reference
    for every restart below, and the run directory each checkpoint test copies."""
    out = tmp_path_factory.mktemp("fd") / "straight"
    assert cli.main(["run", *FD_TOY, "--out", str(out)]) == 0
    assert json.loads((out / "checkpoint" / "state.json").read_text())["step"] == 60
    return out


@pytest.fixture
def fd_copy(fd_run, tmp_path):
    """A copy of the toy fd run to break."""
    copy = tmp_path / "run"
    shutil.copytree(fd_run, copy, symlinks=True)
    (copy / "summary.json").unlink()  # as after a kill
    return copy


# -- data loss ------------------------------------------------------------------------------------


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


# A real SIGKILL (and Ctrl-C) then --restart, compared row by row with an uninterrupted run, for every model
# that writes checkpoints: tests/test_restart.py.


# -- one line instead of a traceback ----------------------------------------------------------------


def as_nobody_or_skip(cwd: Path, env: dict) -> dict:
    """Popen's arguments to run as user nobody, once nobody has started this interpreter and imported the
    package; skips when it cannot (a checkout under a 0700 directory such as /root: PermissionError)."""
    nobody = {"user": 65534, "group": 65534, "extra_groups": []}
    try:
        probe = subprocess.run([sys.executable, "-c", "import fem_bounce"], cwd=cwd, env=env, capture_output=True,
                               text=True, timeout=60, **nobody)
        reason = (probe.stderr.strip().splitlines() or [f"exit status {probe.returncode}"])[-1] \
            if probe.returncode else ""
    except OSError as err:
        reason = str(err)
    if reason:
        pytest.skip(f"user nobody cannot reach the interpreter at {sys.executable} or the package: {reason}")
    return nobody


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


@pytest.mark.parametrize("override,message", [
    ("gravity=0", "gravity = 0 moves nothing: allowed only for a free sphere launched by initial_velocity != 0 "
                  "or a pair set in motion by second_sphere.velocity"),
    ("contact.delta_sl=1e9", "contact.delta_sl = 1000000000.0 is out of range: allowed in (0, 0.5] (the gap, in "
                             "diameters, below which the contact model supplies the near-wall force)"),
    ("initial_gap=1e300", "initial_gap = 1e+300 m is 1.05e+302 diameters: allowed up to 1e+10 D"),
    ("sphere.poisson_ratio=-1", "sphere.poisson_ratio = -1.0 is out of range: allowed in (-1, 0.5)"),
    ("run.bounces=2.5", "run.bounces = 2.5 must be an integer"),
    ("name=../../x", "name = '../../x' must be a plain name"),
    ("sphere.density=1203", "sphere.density = 1203 kg/m3 equals liquid.density: a neutrally buoyant sphere"),
    ("sphere.density=1203.0001", "so nearly neutrally buoyant a sphere barely moves"),
])
def test_scene_values_outside_physics_are_refused(override, message, tmp_path, monkeypatch, capsys):
    """gravity = 0 ended in ZeroDivisionError; delta_sl = 1e9 (switching the resolved force off) and
    initial_gap = 1e300 (overflow, 300-digit numbers) ran; bounces = 2.5 said 'must be a number'; a
    name with '../' wrote the run outside runs/; a neutrally buoyant sphere crawled for ever."""
    monkeypatch.chdir(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--set", override)
    assert status == 2
    assert_one_line(lines, "error: ", message)
    assert list(tmp_path.iterdir()) == []


def test_negative_poisson_ratio_is_physical(tmp_path, capsys):
    """sphere.poisson_ratio = -0.5 was refused, although (-1, 0.5) is an isotropic solid's range."""
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--set", "sphere.poisson_ratio=-0.5",
                            "--set", "run.end_time=0.01", "--out", str(tmp_path / "run"))
    assert status == 0 and lines == []


@pytest.mark.parametrize("model", ["ode", "fd", "ib", "ale"])
def test_neutral_sphere_is_refused_alike_by_every_model(model, tmp_path, monkeypatch, capsys):
    """It hung the ODE model (6,815 steps for 0.1 ms, 100 kB/s of rows) and the ib model; fd and ale
    refused it from inside the model."""
    monkeypatch.chdir(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", "--model", model, "--quiet", "--set", "sphere.density=1203")
    assert status == 2
    assert_one_line(lines, "error: sphere.density = 1203 kg/m3 equals liquid.density")
    assert list(tmp_path.iterdir()) == []


def test_light_sphere_runs_with_a_warning_and_a_stated_stop(tmp_path, capsys):
    """A sphere lighter than the liquid rose and the run said 'completed', no impact, no word."""
    out = tmp_path / "run"
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--set", "sphere.density=600", "--out", str(out))
    assert status == 0
    assert_one_line(lines, "warning: sphere.density = 600 kg/m3 is below liquid.density",
                    "the run stops when it has risen 10 D above its release")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and "risen 10 D" in summary["stop_reason"] and not summary["impacts"]
    d, h0, final = 0.0095, 0.0152, summary["final"]
    longest_step = 0.02 * (d / 9.81) ** 0.5  # the integrator's largest step, sphere_ts_adapt_dt_max
    assert h0 + 10 * d <= final["gap"] <= h0 + 10 * d + abs(final["velocity"]) * longest_step


def test_light_sphere_stops_at_the_top_of_the_fd_refined_region(tmp_path, capsys):
    """With the fd model it rose out of the refined mesh and its velocity left the ODE model's."""
    out = tmp_path / "run"
    status, lines = run_cli(capsys, "run", *FD_TOY, "--set", "sphere.density=600", "--set", "run.end_time=0.6",
                            "--set", "numerics.fd.wake_length=0.5", "--out", str(out))
    assert status == 0
    assert_one_line(lines, "warning: ", "reached the top of the fd model's refined region (gap 2.1 D)")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and "refined region" in summary["stop_reason"]
    assert summary["final"]["gap"] / 0.0095 == pytest.approx(0.0152 / 0.0095 + 0.5, abs=0.02)
    assert summary["final"]["time"] < 0.1


@pytest.mark.parametrize("model,overrides", [
    ("ib", ["numerics.ib.cells_per_diameter=12", "numerics.ib.coupling=explicit", "sphere.density=1323"]),
    # the fixed mesh's (on the moving mesh the lagged force at the step's reference velocity carried this sphere up
    # to the lid without gaining energy)
    ("fd", ["numerics.fd.cells_per_diameter=6", "numerics.fd.coupling=explicit", "sphere.density=96",
            "run.end_time=0.02", "numerics.fd.mesh=fixed"]),
])
def test_energy_gain_stops_the_run_and_names_the_coupling(model, overrides, tmp_path, capsys):
    """An unstable coupling threw spheres up at several times their impact speed and nothing caught the
    energy gain; the ib model blamed its grid region ('raise fine_margin'), sending the user the wrong way."""
    out = tmp_path / "run"
    scene = "li2011-case3" if model == "ib" else "tencate2002-e4"
    args = [item for pair in (("--set", o) for o in overrides) for item in pair]
    status, lines = run_cli(capsys, "run", scene, "--model", model, "--quiet", *args, "--out", str(out))
    assert status == 1
    lines = [line for line in lines if "warning:" not in line]  # the light sphere's warning
    assert_one_line(lines, "diverged: the sphere gained energy it cannot have",
                    f'numerics.{model}.coupling = "explicit" fails here')
    assert "grid region" not in lines[0]
    assert json.loads((out / "summary.json").read_text())["status"].startswith("diverged: the sphere gained energy")


def test_ib_too_coarse_for_its_kernel_says_so(tmp_path, monkeypatch, capsys):
    """At 2 cells/D the ib model said the sphere left a region that its own numbers placed it inside."""
    monkeypatch.chdir(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", "--model", "ib", "--quiet",
                            "--set", "numerics.ib.cells_per_diameter=2")
    assert status == 2
    assert_one_line(lines, "error: numerics.ib: at 2 cells/D the delta kernel reaches 0.75 D",
                    "raise numerics.ib.cells_per_diameter")
    assert list(tmp_path.iterdir()) == []


def test_fd_below_what_it_resolves_warns(tmp_path, capsys):
    """fd at 2 cells/D ran without a word (V_i -13 %, apex -22 % against 12 cells/D)."""
    status, lines = run_cli(capsys, "run", "li2011-case3", "--model", "fd", "--quiet", "--set",
                            "numerics.fd.cells_per_diameter=2", "--set", "run.end_time=0.002",
                            "--out", str(tmp_path / "run"))
    assert status == 0
    assert_one_line(lines, "warning: numerics.fd.cells_per_diameter = 2 puts 0.4 fine cells across the delta_sl gap")


# -- restarts ---------------------------------------------------------------------------------------


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


# -- options and parallel runs -------------------------------------------------------------------


@pytest.mark.parametrize("sweeps,message", [
    ("nonsense", "--sweeps: unknown sweep 'nonsense': choose from density_ratio, cfl, cells_per_gap, delta_sl"),
    ("cfl", "--sweeps: cfl does not apply to the ode model (it has only density_ratio)"),
])
def test_unknown_study_sweep_is_refused(sweeps, message, tmp_path, capsys):
    """`study stability --sweeps nonsense` ran a different sweep and exited 0."""
    status, lines = run_cli(capsys, "study", "stability", "--model", "ode", "--sweeps", sweeps,
                            "--out", str(tmp_path / "study"))
    assert status == 2
    assert_one_line(lines, "error: ", message)
    assert list(tmp_path.iterdir()) == []


def test_huge_numbers_print_readably(tmp_path, capsys):
    """Re and St printed with 300 digits for a viscosity of 1e-300."""
    status = cli.main(["run", "li2011-case3", *ODE, "--set", "liquid.viscosity=1e-300", "--set", "run.bounces=1",
                       "--out", str(tmp_path / "run")])
    captured = capsys.readouterr()
    assert status == 0
    printed = captured.out.splitlines() + captured.err.splitlines()
    assert max(len(line) for line in printed) < 250 and any(re.search(r"Re = 5\.\d\de\+300", line) for line in printed)


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
