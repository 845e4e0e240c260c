"""Round two of bad input (issue 27), one test per finding: the exit status, the one line naming the
culprit, and nothing written for a refusal.  The ODE model in this process wherever the finding is not
model-specific; real processes where two runs at once are the point."""
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fem_bounce import output
from test_bad_input import ODE, assert_one_line, children_of, run_cli, spawn

PRESET = Path(__file__).resolve().parents[1] / "fem_bounce" / "presets" / "li2011-case3.toml"


def refused(capsys, tmp_path, monkeypatch, *argv, message: str, status: int = 2) -> None:
    monkeypatch.chdir(tmp_path)
    before = sorted(p.name for p in tmp_path.iterdir())
    code, lines = run_cli(capsys, *argv)
    assert code == status
    assert_one_line(lines, "error: ", message)
    assert sorted(p.name for p in tmp_path.iterdir()) == before  # nothing written


# -- scene files that are not scenes ------------------------------------------------------------------


def _write(path: Path, kind: str) -> None:
    if kind == "random bytes":
        path.write_bytes(bytes(range(128, 256)) * 2)
    elif kind == "utf-16":
        path.write_bytes('name = "x"\n'.encode("utf-16"))
    elif kind == "nested 100000 deep":
        path.write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    elif kind == "fifo":
        os.mkfifo(path)
    elif kind == "directory":
        path.mkdir()
    elif kind == "dangling symlink":
        path.symlink_to(path.parent / "nothing-here.toml")


@pytest.mark.parametrize("kind,message", [
    ("random bytes", "is not UTF-8 text"),
    ("utf-16", "is not UTF-8 text"),
    ("nested 100000 deep", "nested too deeply to read"),
    ("fifo", "is not a regular file"),
    ("directory", "is not a regular file"),
    ("dangling symlink", "does not exist (a symbolic link to a missing file)"),
])
def test_scene_file_that_is_not_a_scene_gives_one_line(kind, message, tmp_path, monkeypatch, capsys):
    """UnicodeDecodeError, RecursionError, a FIFO or directory 'does not exist', a dangling link."""
    source = tmp_path / "x.toml"
    _write(source, kind)
    refused(capsys, tmp_path, monkeypatch, "run", "x.toml", *ODE, "--out", "r", message=message)


def test_byte_order_mark_is_accepted(tmp_path, monkeypatch, capsys):
    """A UTF-8 file saved with a BOM said 'Invalid statement (at line 1, column 1)'."""
    (tmp_path / "bom.toml").write_bytes(b"\xef\xbb\xbf" + PRESET.read_bytes())
    monkeypatch.chdir(tmp_path)
    status, _ = run_cli(capsys, "run", "bom.toml", *ODE, "--set", "run.bounces=1", "--out", "r")
    assert status == 0 and (tmp_path / "r" / "summary.json").is_file()


# -- values inside the old ranges that overflowed, hung or crashed ----------------------------------------


@pytest.mark.parametrize("override,message", [
    ("liquid.viscosity=1e20", "liquid.viscosity = 1e+20 Pa s is out of range: allowed in (0, 1e+08] Pa s (pitch"),
    ("sphere.diameter=1e300", "sphere.diameter = 1e+300 m is out of range: allowed in [1e-06, 1000] m"),
    ("sphere.diameter=1e-10", "sphere.diameter = 1e-10 m is out of range"),
    ("sphere.density=1e300", "sphere.density = 1e+300 kg/m3 is out of range: allowed in (0, 100000] kg/m3"),
    ("liquid.density=1e-300", "liquid.density = 1e-300 kg/m3 is out of range: allowed in [1e-30, 100000]"),
    ("sphere.youngs_modulus=1e300", "sphere.youngs_modulus = 1e+300 Pa is out of range"),
    ("contact.history_c1=1e-3", "contact.history_c1 = 0.001 is out of range: allowed in [0.1, 100] (Mei & Adrian"),
    ("contact.history_c1=1e6", "contact.history_c1 = 1000000.0 is out of range"),
    ("reference.velocity_curve=nope", "reference.velocity_curve = 'nope' is not one of the package's velocity curves: "
                                      "'tencate2002_E4'"),
])
def test_values_that_broke_a_run_are_refused(override, message, tmp_path, monkeypatch, capsys):
    """viscosity 1e20 printed a warning a step for ever; diameters and densities of 1e300 overflowed;
    history_c1 1e-3 / 1e6 failed in scipy's nnls; an unknown velocity curve failed after the run."""
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r", "--set", override,
            message=message)


def test_start_inside_contact_names_the_numbers(tmp_path, monkeypatch, capsys):
    """initial_gap = 1e-300 said it "must exceed contact.delta_ss * sphere.diameter" without the numbers."""
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r", "--set", "initial_gap=1e-300",
            message="initial_gap = 1e-300 m is out of range: allowed > sphere.roughness + wall.roughness = 4e-08 m")


@pytest.mark.parametrize("overrides,cause", [
    (["contact.model=li2011", "contact.dry_restitution=0"], "the paper's spring e_d W_o F(delta/delta_ss) stores too "
                                                             "little energy over delta_ss to stop it"),
    (["contact.model=li2011", "contact.dry_restitution=0.01"], "raise contact.delta_ss or use contact.model = "
                                                                '"lubricated-hertz"'),
    (["contact.model=li2011", "contact.delta_ss=1e-300"], "stores too little energy over delta_ss"),
    (["sphere.youngs_modulus=1e4"], "the solids are too soft for this impact (sphere.youngs_modulus, "
                                  "wall.youngs_modulus)"),
])
def test_a_contact_that_cannot_stop_the_sphere_is_named(overrides, cause, tmp_path, monkeypatch, capsys):
    """These always diverged with "the sphere reached the wall" and no word of the cause."""
    monkeypatch.chdir(tmp_path)
    argv = ["run", "li2011-case3", *ODE, "--out", "r", "--set", "run.bounces=1"]
    for text in overrides:
        argv += ["--set", text]
    status, lines = run_cli(capsys, *argv)
    assert status == 1
    assert_one_line(lines, "diverged: the sphere went through the wall", cause)


@pytest.mark.parametrize("override", ["second_sphere.diameter=1e300", "second_sphere.diameter=1e-300"])
def test_pair_sizes_that_crashed_are_refused(override, tmp_path, monkeypatch, capsys):
    """OverflowError and LinAlgError (leaving r/ behind)."""
    refused(capsys, tmp_path, monkeypatch, "run", "yang-hunt2006-pair", *ODE, "--out", "r", "--set", override,
            message="second_sphere.diameter = ")


def test_a_container_that_is_not_a_table_names_the_alternative(tmp_path, monkeypatch, capsys):
    """container = "boxed" said "must be a table" without naming its keys or "unbounded"."""
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r", "--set", 'container="boxed"',
            message="container = 'boxed' must be a table of radius, height (leave [container] out for an unbounded")


def test_the_ode_model_says_it_ignores_the_container(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--out", "r", "--set", "run.bounces=1",
                            "--set", "container.radius=0.02", "--set", "container.height=0.1")
    assert status == 0
    assert_one_line([line for line in lines if "warning" in line], "ignores [container]")


# -- prescribed motion ---------------------------------------------------------------------------------------


@pytest.mark.parametrize("content,message", [
    (b"", "has 0 row(s); a series needs at least 2"),
    (bytes(range(128, 256)), "cannot be read as UTF-8 text"),
    (b"t,velocity\n0,0.1\n", "has 1 row(s)"),
    (b"t,velocity\n0,0\n0.2,-0.1\n0.1,-0.1\n", "the times t must increase"),
    (b"t,velocity\n0,0\n0.1,nan\n", "holds a value that is not finite"),
    (b"t,velocity\n0.5,0\n1,-0.1\n", "starts at t = 0.5 s; it must cover the start of the run, t = 0"),
    (b"time,speed\n0,0\n1,1\n", "needs a header t,velocity"),
])
def test_bad_series_is_refused_before_the_run(content, message, tmp_path, monkeypatch, capsys):
    (tmp_path / "series.csv").write_bytes(content)
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r", "--set", "motion.mode=prescribed",
            "--set", "motion.series=series.csv", message=f"motion.series = 'series.csv': {message}")


def test_prescribed_path_through_the_wall_is_a_divergence(tmp_path, monkeypatch, capsys):
    """It completed with 'the sphere ended -0.5053 D above the wall'."""
    (tmp_path / "series.csv").write_text("t,velocity\n0,0\n0.05,-0.2\n0.2,-0.2\n")
    monkeypatch.chdir(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--out", "r", "--set", "motion.mode=prescribed",
                            "--set", "motion.series=series.csv", "--set", "run.end_time=0.2")
    assert status == 1
    assert_one_line(lines, "diverged: the prescribed motion (motion.series = 'series.csv') drives the sphere into "
                           "the wall")
    assert json.loads((tmp_path / "r" / "summary.json").read_text())["status"].startswith("diverged")


# -- run directories: one owner, no nesting ---------------------------------------------------------------


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


# -- paths and entry points ------------------------------------------------------------------------------------


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
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", out, message=message)


def test_empty_model_name_is_refused(tmp_path, monkeypatch, capsys):
    """--model '' ran the default fd model at 24 cells/D."""
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", "--model", "", "--quiet", "--out", "r",
            message="unknown model ''")


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


# -- studies and sweeps: checked like scene fields, nothing written when refused ---------------------------------


@pytest.mark.parametrize("argv,message", [
    (["study", "convergence", "li2011-case3", "--model", "ode", "--levels", "nan,inf"], "--levels 'nan,inf': expected"),
    (["study", "convergence", "li2011-case3", "--model", "fd", "--cfls", "0,-1"], "--cfls '0,-1': expected"),
    (["restitution", "--set", "sphere.densty=5"], "unknown key sphere.densty"),
    (["study", "restitution", "--model", "ode", "--points", "0"], "is now `fem-bounce restitution`"),
    (["restitution", "--points", "0"], "need --points >= 2"),
    (["restitution", "--points", "1000000000"], "--points 1000000000: allowed 2 to 1000"),
    (["restitution", "--set", "initial_gap=5"], "--set initial_gap: the restitution sweep sets initial_gap"),
    (["compare", "li2011-case3", "--models", "ode,ode"], "--models names ode more than once"),
])
def test_study_arguments_are_checked_before_anything_is_written(argv, message, tmp_path, monkeypatch, capsys):
    """--levels nan named numerics.ode.rtol and left an empty directory, --points 0 meant the default,
    10^9 points ran silently for ever, compare --models ode,ode ended in FileExistsError."""
    refused(capsys, tmp_path, monkeypatch, *argv, "--out", "study", message=message)


def test_pair_refused_by_fd_writes_nothing(tmp_path, monkeypatch, capsys):
    """The refusal came after the marker, scene.toml, a header-only trajectory and a 64 kB reserve."""
    refused(capsys, tmp_path, monkeypatch, "run", "yang-hunt2006-pair", "--model", "fd", "--quiet", "--out", "r",
            "--set", "numerics.fd.cells_per_diameter=6", "--set", "numerics.fd.constraint=penalty",
            "--set", "numerics.fd.mesh=fixed", message="spheres' indicators overlap")


def test_full_stdout_gives_one_line(tmp_path):
    """OSError 28 traceback after the run when stdout is /dev/full."""
    with open("/dev/full", "w") as full:
        done = subprocess.run([sys.executable, "-m", "fem_bounce", "run", "li2011-case3", *ODE, "--out", "r",
                               "--set", "run.bounces=1"], cwd=tmp_path, stdout=full, stderr=subprocess.PIPE, text=True)
    assert done.returncode == 1 and "Traceback" not in done.stderr and "Exception ignored" not in done.stderr
    assert done.stderr.splitlines()[-1] == "fem-bounce: error: cannot write the output: No space left on device"


# -- caches: the user's cache folder, never the working directory or the source tree -------------------------------


def test_studies_and_meshes_cache_outside_the_working_directory(tmp_path, monkeypatch, capsys):
    """restitution, study and compare wrote results/cache/ into the working directory even with --out,
    and generated meshes went to meshes/cache/ inside the source tree."""
    from fem_bounce import cachedir

    monkeypatch.chdir(tmp_path / "work" if (tmp_path / "work").mkdir() is None else tmp_path)
    monkeypatch.delenv("FEM_BOUNCE_CACHE", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cachedir.folder("runs") == tmp_path / "xdg" / "fem_bounce" / "runs"
    code, _ = run_cli(capsys, "compare", "li2011-case3", "--models", "ode", "--out", str(tmp_path / "cmp"),
                      "--set", "run.bounces=1")
    assert code == 0 and os.listdir(tmp_path / "work") == []
    assert list((tmp_path / "xdg" / "fem_bounce" / "runs").iterdir())


def test_a_cache_that_is_a_file_gives_one_line(tmp_path, monkeypatch, capsys):
    """FEM_BOUNCE_MESH_CACHE pointing at a file ended in FileExistsError."""
    (tmp_path / "file").write_text("")
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "file"))
    refused(capsys, tmp_path, monkeypatch, "compare", "li2011-case3", "--models", "ode", "--out", "c",
            message="cannot use " + str(tmp_path / "file" / "runs") + " as fem_bounce's cache")


@pytest.mark.parametrize("bounces", ["0", "1000"])
def test_nothing_left_to_do_ends_the_run(bounces, tmp_path, monkeypatch, capsys):
    """run.end_time = 1e6 with no bounce limit (or 1000): the sphere rested on the wall and the run stepped on,
    about 1 GB of trajectory an hour; it now ends with the reason."""
    monkeypatch.chdir(tmp_path)
    start = time.monotonic()
    status, _ = run_cli(capsys, "run", "li2011-case3", *ODE, "--out", "r", "--set", "run.end_time=1e6",
                        "--set", f"run.bounces={bounces}")
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    assert status == 0 and summary["stop_reason"].startswith("the sphere came to rest on the wall")
    assert time.monotonic() - start < 120 and (tmp_path / "r" / "trajectory.csv").stat().st_size < 5e6
