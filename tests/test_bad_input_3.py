"""Round three of bad input (issue 37), one test per finding: the exit status, the one line naming the culprit
(and no start line before a refusal), and nothing written or changed for a refusal; a failed --restart leaves
its directory byte for byte as it was.  The ODE model in this process wherever the finding is not
model-specific; toy fd and ale runs where checkpoints, side files and meshes are the point; real processes
where a kill, a signal, a file-size limit or two studies at once are the point."""
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

import fem_bounce as fb
from fem_bounce import cache, cli, progress, run
from fem_bounce import scene as scenes
from fem_bounce.fem import mesh as halfplane
from test_bad_input import (FD_TOY, ODE, as_nobody_or_skip, assert_one_line, children_of, fd_copy,  # noqa: F401
                            fd_run, messages, run_cli, spawn, tree, wait_for)

ALE_TOY = ["li2011-case3", "--model", "ale", "--quiet", "--set", "numerics.ale.cells_per_diameter=4",
           "--set", "run.bounces=1", "--set", "numerics.ale.checkpoint_every=10"]


def refused(capsys, tmp_path, monkeypatch, *argv, message: str) -> None:
    """Exit 2, one line and nothing else on stderr (no start line), and nothing written in the working directory."""
    monkeypatch.chdir(tmp_path)
    before = tree(tmp_path)
    status = cli.main(list(argv))
    err = capsys.readouterr().err
    assert status == 2, err
    assert_one_line(err.splitlines(), "error: ", message)
    assert tree(tmp_path) == before


def limited(argv: list[str], cwd: Path, limit: int) -> subprocess.CompletedProcess:
    """fem-bounce with every file limited to `limit` bytes (RLIMIT_FSIZE: a full disk; writes fail with EFBIG),
    set after MPI has started (its runtime writes large shared-memory files of its own)."""
    launcher = ("import resource, sys; from mpi4py import MPI; "
                f"resource.setrlimit(resource.RLIMIT_FSIZE, ({limit}, resource.RLIM_INFINITY)); "
                f"from fem_bounce.cli import main; sys.exit(main({argv!r}))")
    return subprocess.run([sys.executable, "-c", launcher], cwd=cwd, capture_output=True, text=True, timeout=300)


# -- data lost ----------------------------------------------------------------------------------------


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
def test_a_refused_restart_changes_nothing(damage, message, fd_copy, capsys):  # noqa: F811
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


def test_restart_from_inside_the_run_directory(fd_run, fd_copy, monkeypatch, capsys):  # noqa: F811
    """`--restart .` from inside the run directory said "choose another --out", an option --restart does not take."""
    monkeypatch.chdir(fd_copy)
    status, lines = run_cli(capsys, "run", "--restart", ".", "--quiet")
    assert status == 0 and lines == []
    assert (fd_copy / "trajectory.csv").read_text() == (fd_run / "trajectory.csv").read_text()


# -- one line instead of a traceback ----------------------------------------------------------------------


def test_a_tiny_contact_gap_factor_ends_with_a_summary(tmp_path, capsys):
    """contact_gap_factor = 1e-10 ended in ZeroDivisionError after the run, without summary.json (refused since
    issue 43: the smallest gap allowed, a few nm on smooth surfaces, runs)."""
    out = tmp_path / "run"
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--set", "contact.contact_gap_factor=3e-3",
                            "--set", "sphere.roughness=0", "--set", "wall.roughness=0", "--out", str(out))
    assert status == 0 and lines == []
    assert json.loads((out / "summary.json").read_text())["status"] == "completed"


@pytest.mark.parametrize("value,message", [
    ("nan", "contact.cavitation_pressure = nan Pa is out of range"),
    ("abc", "contact.cavitation_pressure = 'abc' is not a choice nor a pressure"),
])
def test_cavitation_is_checked_whatever_the_contact_model(value, message, tmp_path, monkeypatch, capsys):
    """contact.ehd_cavitation (now cavitation_pressure) = nan or abc was accepted with lubricated-hertz, then a
    ValueError writing scene.toml or building the contact."""
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r",
            "--set", f"contact.cavitation_pressure={value}", message=message)


@pytest.mark.parametrize("model", ["ale", "fd"])
def test_a_sphere_wider_than_the_domain_is_refused(model, tmp_path, monkeypatch, capsys):
    """second_sphere.diameter = 1000: a ValueError with ale, a std::bad_alloc abort with fd."""
    refused(capsys, tmp_path, monkeypatch, "run", "pair-settling-wall", "--model", model, "--quiet", "--out", "r",
            "--set", "second_sphere.diameter=1000",
            message=f"second_sphere.diameter = 1000 m does not fit in the {model} model's domain")


@pytest.mark.parametrize("content", ['{"li2011-case3": {"5%": {"mod', "[1, 2]"])
def test_a_broken_accuracy_record_gives_one_line(content, tmp_path, monkeypatch, capsys):
    """A truncated or list-valued results/accuracy_recommendations.json crashed `run --accuracy 5%`."""
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "accuracy_recommendations.json").write_text(content)
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", "--accuracy", "5%", "--quiet",
            message="results/accuracy_recommendations.json (the accuracy record `--accuracy` reads")


def test_a_full_disk_at_a_checkpoint_gives_one_line(fd_run, tmp_path):  # noqa: F811
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


def test_a_damaged_mesh_in_the_cache_is_made_again(tmp_path, monkeypatch):
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path))
    spec = halfplane.HalfPlane(radius=0.05, height=0.1, fine_size=0.01, coarse_size=0.02, grading=0.2)
    first, _, _ = halfplane.create_mesh(MPI.COMM_SELF, spec)
    entry = tmp_path / "meshes" / f"halfplane-{spec.key()}.msh"
    whole = entry.read_bytes()
    entry.write_bytes(whole[: len(whole) // 2])  # as a full disk or a crash left it
    again, _, _ = halfplane.create_mesh(MPI.COMM_SELF, spec)
    assert entry.read_bytes() == whole
    assert again.topology.index_map(2).size_global == first.topology.index_map(2).size_global


def test_wrong_types_raise_the_package_errors(tmp_path, monkeypatch):
    """Python's own TypeError, AttributeError or ValueError, some after 84 s of work."""
    monkeypatch.chdir(tmp_path)
    scene = fb.load("li2011-case3", {"run.bounces": 1})
    calls = {
        fb.SceneError: [lambda: fb.simulate([1, 2, 3]), lambda: fb.simulate({"sphere": 1}), lambda: fb.simulate(None),
                        lambda: fb.load("li2011-case3", [("k", 1)]), lambda: fb.load(5), lambda: fb.load("x", 5),
                        lambda: fb.restitution(points=2.5), lambda: fb.restitution(points="6"),
                        lambda: fb.restitution(st_range=(1,)), lambda: fb.restitution(st_range=(1, float("inf"))),
                        lambda: fb.save("li2011-case3", "x.toml")],
        fb.ModelError: [lambda: fb.simulate(scene, model=["ode"]), lambda: fb.compare(scene, [1, 2])],
        fb.RunnerError: [lambda: fb.simulate(scene, comm="world"), lambda: fb.restitution(points=2, cache=5),
                         lambda: fb.restitution(points=2, comm="world")],
        fb.OutputError: [lambda: fb.resume(None), lambda: fb.save(scene, 5), lambda: fb.simulate(scene, out=5)],
    }
    for kind, wrong in calls.items():
        for call in wrong:
            with pytest.raises(kind):
                call()
    assert list(tmp_path.iterdir()) == []


def test_numpy_numbers_are_numbers():
    """np.float32(8000) was refused as "8000.0 must be a number", np.int64(2) as "2 must be an integer"."""
    scene = fb.load("li2011-case3", {"sphere.density": np.float32(8000.0), "run.bounces": np.int64(1)})
    assert scene.sphere.density == pytest.approx(8000.0) and scene.run.bounces == 1
    assert isinstance(scene.run.bounces, int) and isinstance(scene.sphere.density, float)
    assert fb.simulate(scene, "ode", rtol=np.float64(1e-6)).status == "completed"


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


# -- wrong results and misleading messages -------------------------------------------------------------------


@pytest.mark.parametrize("text", ["a\nb", "tab\there", "del\x7f", "bell\x07", 'quote " and \\ backslash',
                                  "line\r\nbreak", "π ≈ 3.14 — ü", "\x00nul"])
def test_scene_text_round_trips_for_any_string(text):
    """A description with a newline, U+007F or another control character made a scene.toml (and `scenes show`)
    that was not valid TOML."""
    scene = fb.load("li2011-case3").replace(description=text)
    written = scenes.dumps(scene)
    assert tomllib.loads(written)["description"] == text
    assert scenes.from_dict(tomllib.loads(written)) == scene


def test_a_control_character_in_a_scene_file_runs_and_restarts(tmp_path, capsys):
    """A TOML file whose description holds an (escaped) control character ran, but its fd run could never be
    restarted: its scene.toml was not valid TOML."""
    source = tmp_path / "ctl.toml"
    source.write_text(scenes.preset_text("li2011-case3").replace('description = "', 'description = "a\\u0001b\\n'))
    out = tmp_path / "run"
    assert cli.main(["run", str(source), *FD_TOY[1:], "--out", str(out)]) == 0
    assert tomllib.loads((out / "scene.toml").read_text())["description"].startswith("a\x01b\n")
    (out / "summary.json").unlink()
    status, lines = run_cli(capsys, "run", "--restart", str(out), "--quiet")
    assert status == 0 and lines == []


@pytest.mark.parametrize("override,message", [
    ("name=\"ab\x7f\"", "must be a plain name of 1-100 printable characters"),
    ("sphere.youngs_modulus=1e-320", "sphere.youngs_modulus = 1e-320 Pa is out of range: allowed in [100, 1e+13]"),
    ("wall.youngs_modulus=1e-320", "wall.youngs_modulus = 1e-320 Pa is out of range"),
    ("sphere.youngs_modulus=1e-10", "sphere.youngs_modulus = 1e-10 Pa is out of range"),
    ("sphere.youngs_modulus=200", "are too soft for this scene: its wall contact would begin 0.00115 m apart"),
    ("initial_gap=0.0152", None),  # the preset as it is: accepted (the line below is not reached)
])
def test_moduli_outside_physics_are_refused(override, message, tmp_path, monkeypatch, capsys):
    """youngs_modulus = 1e-320 hung at t = 0 ignoring SIGTERM; 1e-10 "came to rest on the wall" 1.6 D above it."""
    if message is None:
        assert fb.load("li2011-case3", [override]).initial_gap == pytest.approx(0.0152)
        return
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r", "--set", override,
            message=message)


@pytest.mark.parametrize("argv,message", [
    (["yang-hunt2006-pair", "--set", "second_sphere.gap=1e300"], "second_sphere.gap = 1e+300 m is 7.87e+301 diameters"),
    (["yang-hunt2006-pair", "--set", "run.bounces=0", "--set", "run.end_time=1e300"],
     "allowed up to 100000 of them, 4233 s, for a scene that nothing ends earlier"),
])
def test_lengths_and_times_that_never_end_are_refused(argv, message, tmp_path, monkeypatch, capsys):
    """A pair without a wall given run.end_time = 1e300 drifted on for ever; a gap of 1e300 m overflowed."""
    refused(capsys, tmp_path, monkeypatch, "run", *argv, *ODE, "--out", "r", message=message)


@pytest.mark.parametrize("model", ["ale", "fd"])
def test_a_mesh_beyond_memory_is_refused(model, tmp_path, monkeypatch, capsys):
    """container.radius = height = 100 m: the ale model meshed the whole container (2.6e8 triangles) ignoring
    SIGTERM."""
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", "--model", model, "--quiet", "--out", "r",
            "--set", "container.radius=100", "--set", "container.height=100",
            message=f"numerics.{model}: its mesh of this scene would have ~2.6e+08 triangles")


def test_the_study_cache_cannot_be_poisoned(tmp_path, monkeypatch, capsys):
    """`--out CACHE/runs/<key> --force` with another scene was accepted and `compare` then reported that run; a
    cache entry edited or half-written was trusted."""
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "cache"))
    argv = ["compare", "li2011-case3", "--models", "ode", "--set", "run.bounces=1", "--quiet"]
    assert cli.main([*argv, "--out", str(tmp_path / "first")]) == 0
    entry, = (tmp_path / "cache" / "runs").glob("li2011-*")
    assert cache.finished(entry) == entry
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--set", "sphere.density=2000", "--force",
            "--out", str(entry), message="is inside fem_bounce's cache")
    trajectory = entry / "trajectory.csv"
    trajectory.write_text(trajectory.read_text().replace("0.", "1.", 5))
    assert cache.finished(entry) is None  # damaged: made again, never trusted
    assert cli.main([*argv, "--out", str(tmp_path / "second")]) == 0  # made again
    assert cache.finished(entry) == entry
    first, second = ((tmp_path / name / "ode" / "trajectory.csv").read_text() for name in ("first", "second"))
    assert first == second == trajectory.read_text()  # the damaged entry replaced by the run made again


def test_the_study_cache_key_holds_the_series_content(tmp_path, monkeypatch):
    """Editing a motion.series CSV did not invalidate the cached run (the key held its path only)."""
    monkeypatch.chdir(tmp_path)
    series = tmp_path / "series.csv"
    series.write_text("t,velocity\n0,0\n0.05,-0.1\n")
    scene = fb.load("li2011-case3", {"motion.mode": "prescribed", "motion.series": "series.csv"})
    before = cache.run_key(scene, "ode")
    series.write_text("t,velocity\n0,0\n0.05,-0.2\n")
    assert cache.run_key(scene, "ode") != before


def test_two_identical_studies_at_once_share_their_runs(tmp_path, monkeypatch):
    """The second of two identical `compare` runs failed: "the cache directory is in use ... choose another --out"."""
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "cache"))
    argv = ["compare", "li2011-case3", "--models", "fd", "--quiet", "--set", "numerics.fd.cells_per_diameter=6",
            "--set", "run.end_time=0.05"]
    first = spawn([*argv, "--out", "a"], tmp_path)
    wait_for(lambda: any((tmp_path / "cache" / "runs").glob(".*.partial")), first)
    second = spawn([*argv, "--out", "b"], tmp_path)
    outcomes = [process.communicate(timeout=300) for process in (first, second)]
    assert [first.returncode, second.returncode] == [0, 0], outcomes
    assert len([p for p in (tmp_path / "cache" / "runs").iterdir() if not p.name.startswith(".")]) == 1
    assert (tmp_path / "a" / "comparison.csv").read_text() == (tmp_path / "b" / "comparison.csv").read_text()


@pytest.mark.parametrize("argv,message", [
    (["restitution", "--st-max", "inf", "--points", "2"], "both finite (got --points 2, --st-min 1, --st-max inf)"),
    (["study", "speed-accuracy", "li2011-case3", "--models", "ode", "--levels", "ode=1e-5", "--levels", "ode=1e-6"],
     "--levels 'ode=1e-6': the ode model's levels are given twice"),
    (["study", "speed-accuracy", "li2011-case3", "--models", "ode,ode"], "--models names ode more than once"),
    (["study", "convergence", "li2011-case3", "--model", "ode", "--cfls", "0.5,0.25"],
     "--cfls '0.5,0.25': the ode model has no time-step setting"),
])
def test_study_options_that_were_ignored_are_refused(argv, message, tmp_path, monkeypatch, capsys):
    """--st-max inf was accepted, a repeated --levels kept the last, --models ode,ode doubled the rows and --cfls
    was ignored for the ode model."""
    refused(capsys, tmp_path, monkeypatch, *argv, "--out", "study", message=message)


@pytest.mark.slow
def test_an_st_range_no_set_reaches_is_refused(tmp_path, monkeypatch, capsys):
    """It exited 0 saying "0 runs -> .../restitution.csv" and wrote no CSV.  (Its planning takes ~30 s.)"""
    refused(capsys, tmp_path, monkeypatch, "restitution", "--st-min", "2000", "--st-max", "3000", "--out", "o",
            message="--st-min 2000 --st-max 3000: no Table 3 set reaches a Stokes number there")


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


@pytest.mark.parametrize("place", ["a file", "a run directory", "read-only"])
def test_a_study_out_that_cannot_hold_it_is_refused_first(place, fd_run, tmp_path, monkeypatch, capsys):  # noqa: F811
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


def test_run_directory_refusals_print_no_start_line(tmp_path, monkeypatch, capsys):
    """Every run-directory refusal printed the start line ("... on 1 rank(s) -> DIR") before its one line."""
    (tmp_path / "results" / "sub").mkdir(parents=True)
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "results", "--force",
            message="results is not a fem-bounce run directory")


# -- hangs --------------------------------------------------------------------------------------------------


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


def test_a_run_below_its_step_floor_ends_as_diverged():
    """A run whose steps shrink to nothing crawled for ever (Young's modulus 1e-320: 12 minutes at t = 0)."""
    time_unit = 0.03
    monitor = progress.Monitor(progress.ProgressBar(1.0, [0.01], enabled=False), MPI.COMM_SELF, None, (), time_unit)
    t = 0.0
    with pytest.raises(fb.RunDiverged, match="the step fell below its floor"):
        for step in range(1, 2 * progress.STEP_FLOOR_WINDOW + 1):
            t += 0.5 * progress.STEP_FLOOR * time_unit
            monitor(t, step, np.array([0.001]), np.array([-1e-6]))
    healthy = progress.Monitor(progress.ProgressBar(1.0, [0.01], enabled=False), MPI.COMM_SELF, None, (), time_unit)
    for step in range(1, 2 * progress.STEP_FLOOR_WINDOW + 1):
        healthy(step * 2.0 * progress.STEP_FLOOR * time_unit, step, np.array([0.001]), np.array([-1e-6]))


def test_a_zero_step_left_by_the_bodies_solver_is_restarted():
    """pair-settling-wall with its default ale model ended "diverged: t = 0.17122 s: a solver failed (PETSc error
    72)": PETSc's TS had left a step of 0 after landing on a fluid step's end as an event was located there, and
    the next fluid step divided by it.  (The preset itself now completes: both spheres come to rest at t = 0.231 s,
    377 steps, ~0.5 s each; three minutes, too long for this suite.)"""
    integrator = run.RunIntegrator(fb.load("li2011-case3"))
    integrator.advance(0.01)
    integrator.ts.setTimeStep(0.0)
    integrator.advance(0.02)
    assert integrator.time == pytest.approx(0.02, rel=1e-12) and np.all(np.isfinite(integrator.gaps))
    integrator.destroy()
