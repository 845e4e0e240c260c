"""The Python API through its top-level names only (issue 28): a run kept in memory and one written to a
directory give the command line's numbers, a bad variant raises SceneError naming the field, and every
error the API raises on purpose is a fem_bounce.Error."""
import csv
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import pytest
from mpi4py import MPI

import fem_bounce as fb

TOY = {"run.bounces": 2}  # case 3 with the ode model to the second apex: about a second


def cli_run(tmp_path: Path, *args: str) -> Path:
    """`fem-bounce run li2011-case3 --model ode ...` in a process of its own; its run directory."""
    out = tmp_path / "cli"
    done = subprocess.run([sys.executable, "-m", "fem_bounce", "run", "li2011-case3", "--model", "ode", "--quiet",
                           "--set", "run.bounces=2", "--out", str(out), *args], capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    return out


def read_csv(path: Path) -> dict:
    with open(path, newline="") as stream:
        rows = list(csv.reader(stream))
    data = np.array(rows[1:], dtype=float)
    return {name: data[:, k] for k, name in enumerate(rows[0])}


def scratch_dirs() -> set:
    return {p.name for p in Path(tempfile.gettempdir()).glob("fem-bounce-*")}


def test_in_memory_and_on_disk_runs_give_the_command_lines_numbers(tmp_path, monkeypatch):
    cli_dir = cli_run(tmp_path)
    cli_summary = json.loads((cli_dir / "summary.json").read_text())
    cli_trajectory = read_csv(cli_dir / "trajectory.csv")
    monkeypatch.chdir(tmp_path)
    before, scratch = sorted(os.listdir(tmp_path)), scratch_dirs()

    scene = fb.load("li2011-case3", TOY)
    kept = fb.simulate(scene, "ode")
    assert kept.run_dir is None and kept.status == "completed"
    assert sorted(os.listdir(tmp_path)) == before and scratch_dirs() <= scratch  # nothing left behind
    disk = fb.simulate(scene, "ode", out=tmp_path / "api")
    assert disk.run_dir == tmp_path / "api"
    assert {"scene.toml", "trajectory.csv", "summary.json", "trajectory.png", "velocity_gap.png"} <= set(
        os.listdir(disk.run_dir))

    for result in (kept, disk):
        assert len(result.impacts) == len(cli_summary["impacts"]) == 2
        for impact, expected in zip(result.impacts, cli_summary["impacts"]):
            assert isinstance(impact, fb.Impact)
            assert impact.impact_speed == pytest.approx(expected["impact_speed"], rel=1e-9)
            assert impact.Re == pytest.approx(expected["Re"], rel=1e-9)
        for rebound, expected in zip(result.rebounds, cli_summary["rebounds"]):
            assert isinstance(rebound, fb.Rebound)
            assert rebound.restitution == pytest.approx(expected["restitution"], rel=1e-9)
        assert set(result.trajectory) == set(cli_trajectory)
        assert len(result.trajectory["t"]) == len(cli_trajectory["t"])
        for name in ("t", "gap", "velocity", "f_liquid"):
            np.testing.assert_allclose(result.trajectory[name], cli_trajectory[name], rtol=1e-9, atol=1e-300)
        assert result.collisions == []  # one sphere


def test_numerical_settings_by_name_are_the_scenes_dotted_keys(tmp_path):
    """simulate(..., rtol=1e-4) is --set numerics.ode.rtol=1e-4: the same run as the command line's."""
    cli_dir = cli_run(tmp_path, "--set", "numerics.ode.rtol=1e-4")
    expected = json.loads((cli_dir / "summary.json").read_text())
    result = fb.simulate(fb.load("li2011-case3", TOY), "ode", rtol=1e-4)
    assert result.scene.numerics.ode.rtol == pytest.approx(1e-4, rel=1e-12)
    assert result.impacts[0].impact_speed == pytest.approx(expected["impacts"][0]["impact_speed"], rel=1e-9)
    assert result.summary["steps"] == expected["steps"]
    with pytest.raises(fb.SceneError, match=r"unknown key numerics\.ode\.rtoll; did you mean numerics\.ode\.rtol\?"):
        fb.simulate("li2011-case3", "ode", rtoll=1e-4)


@pytest.mark.parametrize("change, message", [
    ({"contact.delta_ss": -0.01}, "contact.delta_ss = -0.01 is out of range: allowed > 0"),
    ({"contact.delta_ss": 0.3}, "contact.delta_ss = 0.3 must be smaller than contact.delta_sl = 0.2"),
    ({"sphere.densty": 8000}, "unknown key sphere.densty; did you mean sphere.density?"),
    ({"run.bounces": "two"}, "run.bounces = 'two' must be an integer"),
])
def test_a_bad_variant_raises_scene_error_naming_the_field(change, message):
    scene = fb.load("li2011-case3")
    for attempt in (lambda: scene.replace(**change), lambda: fb.load("li2011-case3", change)):
        with pytest.raises(fb.SceneError) as err:
            attempt()
        assert message in str(err.value) and "\n" not in str(err.value)
        assert isinstance(err.value, fb.Error)


def test_overrides_as_text_are_read_as_set_reads_them():
    scene = fb.load("li2011-case3", ["sphere.density=8000", "contact.model=li2011"])
    assert scene.sphere.density == pytest.approx(8000.0, rel=1e-15) and scene.contact.model == "li2011"
    assert scene == fb.load("li2011-case3", {"sphere.density": 8000, "contact.model": "li2011"})
    with pytest.raises(fb.SceneError, match="expected key=value"):
        fb.load("li2011-case3", ["nonsense"])


def test_a_saved_scene_loads_back_equal(tmp_path):
    scene = fb.load("li2011-case3").replace(**{"contact.dry_restitution": 0.9, "name": "softer"})
    path = fb.save(scene, tmp_path / "softer.toml")
    assert fb.load(path) == scene
    assert "li2011-case3" in fb.presets() and fb.model_names()[0] == "ode"


@pytest.mark.parametrize("call, kind, message", [
    (lambda: fb.simulate("li2011-case3", "odx"), fb.ModelError, "unknown model 'odx': choose one of ode"),
    (lambda: fb.load("li2011-case33"), fb.SceneError, "did you mean li2011-case3?"),
    (lambda: fb.simulate("li2011-case3", "ode", out=""), fb.OutputError, "--out is empty"),
    (lambda: fb.restitution("ode", points=1), fb.SceneError, "need --points >= 2"),
    (lambda: fb.restitution("ode", points=4, jobs=0), fb.RunnerError, "--jobs 0: give a whole number"),
    (lambda: fb.compare("li2011-case3", []), fb.ModelError, "needs at least one model"),
    (lambda: fb.compare("yang-hunt2006-pair", ["ode"]), fb.SceneError, "has a second sphere"),
    (lambda: fb.resume("nowhere"), fb.CheckpointError, "cannot restart nowhere: it does not exist"),
])
def test_every_refusal_is_one_fem_bounce_error(call, kind, message, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(kind) as err:
        call()
    assert isinstance(err.value, fb.Error) and message in str(err.value)
    assert os.listdir(tmp_path) == []  # refused before anything was written


def test_a_run_kept_in_memory_draws_where_it_is_told(tmp_path):
    result = fb.simulate("li2011-case3", "ode", **TOY)
    with pytest.raises(fb.OutputError, match="kept in memory: give draw\\(\\) a directory"):
        result.draw()
    drawn = result.draw(tmp_path / "figures")
    assert sorted(p.name for p in drawn) == ["losses.png", "trajectory.png", "velocity_gap.png"]
    assert all(p.stat().st_size > 10_000 for p in drawn)


def test_to_pandas_gives_the_trajectory_or_says_pandas_is_missing():
    result = fb.simulate("li2011-case3", "ode", **TOY)
    try:
        import pandas  # noqa: F401 -- only whether it is installed
    except ImportError:
        with pytest.raises(ImportError, match="pip install pandas"):
            result.to_pandas()
        return
    frame = result.to_pandas()
    assert list(frame.columns) == list(result.trajectory)
    np.testing.assert_allclose(frame["velocity"].to_numpy(), result.trajectory["velocity"], rtol=0)


def test_a_pair_run_lists_its_collisions():
    result = fb.simulate("yang-hunt2006-pair", "ode")
    assert result.collisions and result.collisions[0].kind == "pair"
    first = result.collisions[0]
    assert first.impact_speed == pytest.approx(result.summary["collisions"][0]["impact_speed"], rel=1e-12)
    assert first.details["kind"] == "pair" and "pair_gap" in result.trajectory


def test_compare_returns_the_command_lines_table(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "cache"))  # the study cache, as the command line's
    scene = fb.load("li2011-case3", TOY)
    table = fb.compare(scene, ["ode"])
    assert [row["model"] for row in table] == ["ode", "measured"]
    run = fb.simulate(scene, "ode")
    assert table[0]["impact_speed_1"] == pytest.approx(run.impacts[0].impact_speed, rel=1e-5)  # 6 digits
    assert table.column("impact_speed_1")[1] == pytest.approx(scene.reference.impact_speed, rel=1e-5)
    assert sorted(os.listdir(tmp_path)) == ["cache"]  # only the cache: nothing in the working directory


@pytest.mark.mpi
def test_in_memory_run_is_the_same_on_every_rank(shared_tmp):
    """Under mpiexec the API runs on MPI.COMM_WORLD as the command line does: the serial ode model on rank 0,
    its result on every rank; in memory and on disk alike."""
    comm = MPI.COMM_WORLD
    scene = fb.load("li2011-case3", TOY)
    kept = fb.simulate(scene, "ode")
    disk = fb.simulate(scene, "ode", out=shared_tmp / "run")
    speeds = comm.allgather([kept.impacts[0].impact_speed, disk.impacts[0].impact_speed,
                             len(kept.trajectory["t"]), len(disk.trajectory["t"])])
    for found in speeds:
        assert found == pytest.approx(speeds[0], rel=1e-12)
    assert speeds[0][0] == pytest.approx(speeds[0][1], rel=1e-12)


def test_help_lists_every_public_name():
    import pydoc

    text = pydoc.render_doc(fb, renderer=pydoc.plaintext)
    for name in fb.__all__:
        assert name in text, name
        assert getattr(fb, name).__doc__, f"{name} has no docstring"


def test_a_diverged_run_raises_with_what_it_computed(tmp_path, monkeypatch):
    """The paper's spring with delta_ss = 0.0002 cannot stop case 3's sphere: the run diverges (at 0.0003 it stops
    the sphere within 1e-11 m of the wall, or not, by round-off).  The error carries the partial run; kept in
    memory, its message points at no directory and none is left."""
    monkeypatch.chdir(tmp_path)
    scene = fb.load("li2011-case3", {"contact.model": "li2011", "contact.delta_ss": 0.0002})
    scratch = scratch_dirs()
    with pytest.raises(fb.RunDiverged) as err:
        fb.simulate(scene, "ode")
    assert isinstance(err.value, fb.RunFailed) and "outputs kept" not in str(err.value)
    partial = err.value.result
    assert partial.status.startswith("diverged") and partial.run_dir is None
    assert partial.trajectory["gap"].min() < 0.0002 * scene.sphere.diameter  # it got into the contact layer
    assert os.listdir(tmp_path) == [] and scratch_dirs() <= scratch
    with pytest.raises(fb.RunDiverged, match="outputs kept in") as err:
        fb.simulate(scene, "ode", out=tmp_path / "kept")
    assert err.value.result.run_dir == tmp_path / "kept" and (tmp_path / "kept" / "summary.json").is_file()


def test_the_callers_matplotlib_backend_is_kept(tmp_path, monkeypatch):
    """A notebook draws inline: the package's figures select Agg, and the API puts the caller's backend back."""
    import matplotlib
    import matplotlib.pyplot as plt

    monkeypatch.chdir(tmp_path)
    before = matplotlib.get_backend()
    plt.switch_backend("svg")
    try:
        fb.compare(fb.load("li2011-case3", TOY), ["ode"], out=tmp_path / "compared")  # draws comparison.png
        assert (tmp_path / "compared" / "comparison.png").is_file()
        assert matplotlib.get_backend() == "svg"
    finally:
        plt.switch_backend(before)


# -- arguments of the wrong type --------------------------------------------------------------------------------------


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


def test_api_flags_and_paths_are_checked(tmp_path, monkeypatch):
    """fb.simulate(..., plots="no") drew the figures, and fb.resume("") was taken as "." where out="" is refused."""
    monkeypatch.chdir(tmp_path)
    scene = fb.load("li2011-case3", {"run.bounces": 1})
    with pytest.raises(fb.OutputError, match="plots = 'no' must be True or False"):
        fb.simulate(scene, out="r", plots="no")
    with pytest.raises(fb.OutputError, match="run_dir is empty"):
        fb.resume("")
    assert list(tmp_path.iterdir()) == []
