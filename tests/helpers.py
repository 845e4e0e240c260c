"""What the tests of a user's input share: the one line fem-bounce prints, a directory tree's fingerprint (what
"left as it was" means), fem-bounce in a process of its own, and the scenes cheap enough to run anywhere.

Fixtures (the toy fd run and its copies) are in conftest.py."""
import csv
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from fem_bounce import cli, output

ODE = ["--model", "ode", "--quiet"]
ODE_ONE = ["li2011-case3", *ODE, "--set", "run.bounces=1"]
# The ale model's toy numerics where a test checks neither its surface refinement nor its adaptive step: the surface
# at the path's size and the cfl step throughout (the default's finer surface and resolved collisions make a toy run
# several times longer; test_ale.py's command-line bounce and test_ale_speed's adaptive-step tests keep them)
ALE_PLAIN = {"numerics.ale.surface_refinement": 1.0, "numerics.ale.adaptive_step": False}
ALE_PLAIN_OPTIONS = [word for key, value in ALE_PLAIN.items() for word in ("--set", f"{key}={json.dumps(value)}")]
# the one-shot penalty along the path of a fixed mesh: its short steps give the checkpoints these tests break (60 of
# 65 steps)
FD_TOY = ["li2011-case3", "--model", "fd", "--quiet", "--set", "numerics.fd.cells_per_diameter=6",
          "--set", "run.end_time=0.03", "--set", "numerics.fd.checkpoint_every=10", "--set", "numerics.fd.mesh=fixed",
          "--set", "numerics.fd.constraint=penalty", "--set", "numerics.fd.patch=false"]


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
    # one sphere (head-on or oblique) or a pair
    assert tuple(rows[0]) in (output.trajectory_columns(1), output.trajectory_columns(1, oblique=True),
                              output.trajectory_columns(2))
    assert all(len(row) == len(rows[0]) for row in rows)
    return np.array(rows[1:], dtype=float)


def assert_same_trajectory(a: Path, b: Path) -> None:
    """Row by row: the same number of rows at the same printed times, the same values."""
    rows_a, rows_b = (Path(p).read_text().splitlines() for p in (a, b))
    assert len(rows_a) == len(rows_b), (len(rows_a), len(rows_b))
    assert [r.split(",")[0] for r in rows_a] == [r.split(",")[0] for r in rows_b]  # no row lost or doubled
    assert np.allclose(whole_rows(a), whole_rows(b), rtol=1e-9, atol=1e-14)


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


def refused(capsys, tmp_path, monkeypatch, *argv, message: str) -> None:
    """Exit 2, one line and nothing else on stderr (no start line), and nothing written in the working directory."""
    monkeypatch.chdir(tmp_path)
    before = tree(tmp_path)
    status = cli.main(list(argv))
    err = capsys.readouterr().err
    assert status == 2, err
    assert_one_line(err.splitlines(), "error: ", message)
    assert tree(tmp_path) == before


def refused_same_listing(capsys, tmp_path, monkeypatch, *argv, message: str, status: int = 2) -> None:
    """Exit `status` and one fem-bounce line naming `message` (a start line may come before it), and the working
    directory lists the same names as before."""
    monkeypatch.chdir(tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    code, lines = run_cli(capsys, *argv)
    assert code == status
    assert_one_line(lines, "error: ", message)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written


def ode_run(capsys, tmp_path, *settings: str) -> tuple[dict, list[str], list[str]]:
    """Case 3 with the ode model and --set `settings` into tmp_path/run: (summary, stdout lines, fem-bounce's
    stderr lines)."""
    out = tmp_path / "run"
    argv = ["run", "li2011-case3", *ODE, "--out", str(out)]
    for setting in settings:
        argv += ["--set", setting]
    assert cli.main(argv) == 0
    captured = capsys.readouterr()
    return json.loads((out / "summary.json").read_text()), captured.out.splitlines(), messages(captured.err)
