"""What a user is told when an input is wrong, a run ends early or a record has no value: a refusal of one line
naming what to change, and reports that say what happened rather than print a number that was never measured.

Each test's docstring says what the user did and what went wrong before.  The ode model runs in this process
(seconds each); a subprocess only where the process (its exit status) is the point.
"""
import json
from pathlib import Path

import pytest

import fem_bounce as fb
from fem_bounce import cli, plots
from fem_bounce import scene as scenes
from fem_bounce.studies import restitution_planning

EHD = {"contact.model": "ehd"}


def fem_bounce_lines(err: str) -> list[str]:
    """fem-bounce's own lines on stderr, without the start line ('... on 1 rank(s) -> DIR')."""
    assert "Traceback" not in err, err
    return [line for line in err.splitlines() if line.startswith("fem-bounce") and " rank(s) -> " not in line]


# -- the ehd restitution sweep ---------------------------------------------------------------------------------


def test_the_ehd_sweep_plans_without_refusing_its_fastest_launches():
    """`fem-bounce restitution --model ode --set contact.model=ehd --points 12` (docs/ehd.md) stopped with
    "contact.ehd_handover = 2e-05 m is out of range", a key the user never set: the planning launched every set at
    up to 10 m/s, where the handover is too thin for the film's elasticity, and the first refused launch ended the
    sweep.  steel-85's 10 m/s launch is such a one; its band ends at the Re limit below it, as without ehd."""
    speeds, stokes = restitution_planning.stokes_band("li2011-table3-steel-85", EHD)
    assert restitution_planning.band_limit("li2011-table3-steel-85", EHD) is None  # the Re limit ends it first
    assert 100.0 < stokes[-1] < 250.0 and speeds[-1] < 3.0
    restitution_planning.bounce_scene(scenes.load("li2011-table3-steel-85", EHD), speeds[-1])  # admitted


def test_a_band_cut_by_the_handover_is_said_and_its_stations_move():
    """With the handover's range cutting a set's launches short of the Re limit, the sweep refused as a whole;
    now the set's band ends at its fastest admitted launch, a warning names the set, the launch and the key, and
    what it cannot reach goes to no station (or another set's)."""
    thin = {**EHD, "contact.ehd_handover": 5e-6}  # steel-78: 10 x_d passes 5 um between 0.57 and 0.92 m/s
    with pytest.warns(UserWarning, match=r"li2011-table3-steel-78 is launched at most at 0.568 m/s .*"
                                         r"contact.ehd_handover = 5e-06 m is out of range"):
        planned = restitution_planning.plan(3, sets=["li2011-table3-steel-78"], overrides=thin)
    top = max(st for _, st, _ in planned)
    assert 20.0 < top < 100.0  # below the Re-limited band's 124
    for name, _, launch in planned:
        restitution_planning.bounce_scene(scenes.load(name, thin), launch)  # every station runs


def test_a_handover_refused_at_every_launch_names_the_set(tmp_path, monkeypatch, capsys):
    """A refusal of the sweep's scenes said "for this scene" and named no scene: the user could not tell which
    Table 3 set, launched how, the bound belonged to."""
    monkeypatch.chdir(tmp_path)
    status = cli.main(["restitution", "--set", "contact.model=ehd", "--set", "contact.ehd_handover=1e-6",
                       "--out", "r"])
    lines = fem_bounce_lines(capsys.readouterr().err)
    assert status == 2 and len(lines) == 1, lines
    assert "the sweep's scene li2011-table3-steel-95 with the --set values" in lines[0]
    assert "contact.ehd_handover = 1e-06 m is out of range" in lines[0]
    assert not (tmp_path / "r").exists()


# -- what a run prints -------------------------------------------------------------------------------------------


def test_a_pair_collision_the_run_ends_inside_is_in_progress(tmp_path, monkeypatch, capsys):
    """`fem-bounce run three-spheres-wall --model ode --set run.end_time=0.1` ended 0.25 ms after the pair 2-3's
    minimum gap, the pair still opening, and printed its collision with "e = 0.000"."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "three-spheres-wall", "--model", "ode", "--quiet", "--no-plots", "--out", "r",
                     "--set", "run.end_time=0.1"]) == 0
    lines = capsys.readouterr().out.splitlines()
    last = next(line for line in lines if line.startswith("collision 4 (pair_23)"))
    assert "  e = " not in last and "in progress" in last, last
    first = next(line for line in lines if line.startswith("collision 2 (pair_12)"))
    assert "  e = 0.8" in first, first  # a finished one keeps its e


def test_a_run_without_a_wall_says_where_the_sphere_went(tmp_path, monkeypatch, capsys):
    """li2011-case3 with wall.present = false printed "no impact: the sphere ended -17.9 D above the wall"."""
    monkeypatch.chdir(tmp_path)
    assert cli.main(["run", "li2011-case3", "--model", "ode", "--quiet", "--no-plots", "--out", "r",
                     "--set", "wall.present=false", "--set", "run.end_time=0.3"]) == 0
    out = capsys.readouterr().out
    assert "above the wall" not in out
    line = next(line for line in out.splitlines() if line.startswith("no wall"))
    travel = float(line.split("the sphere ended ")[1].split(" D below its start")[0])
    summary = json.loads((tmp_path / "r" / "summary.json").read_text())
    diameter = summary["scene"]["sphere"]["diameter"]
    expected = (summary["scene"]["initial_gap"] - summary["final"]["gap"]) / diameter
    assert travel == pytest.approx(expected, rel=1e-3) and travel > 1.0


def test_an_ode_divergence_names_its_step(tmp_path, monkeypatch, capsys):
    """An ode run that diverged (here: a prescribed path into the wall) said "(at step 0)" after hundreds of
    steps."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "series.csv").write_text("t,velocity\n0,0\n0.05,-0.2\n0.2,-0.2\n")
    status = cli.main(["run", "li2011-case3", "--model", "ode", "--quiet", "--no-plots", "--out", "r",
                       "--set", "motion.mode=prescribed", "--set", "motion.series=series.csv",
                       "--set", "run.end_time=0.2"])
    lines = fem_bounce_lines(capsys.readouterr().err)
    assert status == 1 and len(lines) == 1 and "diverged" in lines[0], lines
    steps = json.loads((tmp_path / "r" / "summary.json").read_text())["steps"]
    assert steps > 10 and f"at step {steps}" in lines[0], (steps, lines[0])


# -- the restitution sweep's rows and summary ------------------------------------------------------------------------


@pytest.fixture
def one_set(monkeypatch, tmp_path):
    """The sweep over one Table 3 set (steel-78, whose band tabulates in about 2 s) and a study cache of its own."""
    monkeypatch.setattr(restitution_planning, "MATERIAL_SETS", ("li2011-table3-steel-78",))
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "cache"))
    monkeypatch.chdir(tmp_path)


def test_a_run_without_an_impact_has_no_collision_restitution(one_set):
    """A sweep's run that stalled in the film before touching (steel-78 at St 5) had restitution_2ms = 0.0
    beside a blank St_2ms: an e at a collision that never happened."""
    rows = fb.restitution("ode", points=2, st_range=(5.0, 5.2))
    assert len(rows) == 1
    row = rows[0]
    assert row["status"] == "completed" and row["St"] > 4.0 and row["restitution"] == 0.0  # e = 0 at 0.2 D
    for station in ("2ms", "frame", "peak"):
        assert row[f"St_{station}"] is None and row[f"restitution_{station}"] is None, station


def test_the_sweep_summary_counts_one_run_as_one(one_set, capsys):
    """`fem-bounce restitution` over one Stokes number printed "1 runs -> ..." and "(1 runs)"."""
    assert cli.main(["restitution", "--st-min", "12", "--st-max", "12.4", "--points", "2", "--out", "r"]) == 0
    out = capsys.readouterr().out
    assert "1 runs" not in out and "1 run -> " in out and "(1 run)" in out, out


# -- the Python API's types --------------------------------------------------------------------------------------


@pytest.mark.parametrize("models", [["ode", None], None])
def test_compare_names_a_model_that_is_not_a_name(models):
    """`fb.compare(scene, ["ode", None])` raised AttributeError ('NoneType' object has no attribute 'strip')."""
    with pytest.raises(fb.ModelError, match="None is not a model's name"):
        fb.compare(fb.load("li2011-case3"), models)


def test_restitution_refuses_a_stokes_range_of_text():
    """`fb.restitution("ode", points=2, st_range=[50, "60"])` was accepted, while points='6' is refused."""
    with pytest.raises(fb.SceneError, match=r"st_range = \[50, '60'\] must be two numbers"):
        fb.restitution("ode", points=2, st_range=[50, "60"])


def test_load_of_a_scene_object_is_refused_in_a_line():
    """`fb.load(scene)` (a Scene, where load takes a preset name or a TOML file) was refused with 2,777
    characters holding the Scene's whole repr."""
    scene = fb.load("li2011-case3")
    with pytest.raises(fb.SceneError, match=r"load\(\) takes a preset name or a TOML file's path, not a "
                                            r"fem_bounce.Scene") as caught:
        fb.load(scene)
    assert len(str(caught.value)) < 300 and "Sphere(" not in str(caught.value)


# -- python -m fem_bounce.plots on damaged files -------------------------------------------------------------------


@pytest.fixture(scope="module")
def run_files(tmp_path_factory) -> dict[str, str]:
    """A short ode run's trajectory.csv and summary.json."""
    folder = tmp_path_factory.mktemp("run") / "r"
    fb.simulate(fb.load("li2011-case3", {"run.end_time": 0.1}), "ode", out=folder, plots=False)
    return {name: (folder / name).read_text() for name in ("trajectory.csv", "summary.json")}


def _damaged(text: dict[str, str], damage: str) -> dict[str, str]:
    trajectory, summary = text["trajectory.csv"], json.loads(text["summary.json"])
    lines = trajectory.splitlines()
    if damage == "header only":
        trajectory = lines[0] + "\n"
    elif damage == "ragged row":
        trajectory = "\n".join([*lines[:5], lines[5] + ",1.0", *lines[6:]]) + "\n"
    elif damage == "text in a row":
        trajectory = "\n".join([*lines[:5], "abc" + lines[5][lines[5].index(","):], *lines[6:]]) + "\n"
    elif damage == "no gap column":
        header = lines[0].split(",")
        trajectory = "\n".join([",".join("height" if name == "gap" else name for name in header), *lines[1:]]) + "\n"
    elif damage == "impacts null":
        summary["impacts"] = None
    elif damage == "no scene":
        del summary["scene"]
    elif damage == "rebound without apex":
        summary["rebounds"] = [{"restitution": 0.5}]
    elif damage == "summary a list":
        summary = [1, 2]
    return {"trajectory.csv": trajectory, "summary.json": json.dumps(summary)}


@pytest.mark.parametrize("damage,file,what", [
    ("header only", "trajectory.csv", "no rows"),
    ("ragged row", "trajectory.csv", "line 6"),
    ("text in a row", "trajectory.csv", "line 6"),
    ("no gap column", "trajectory.csv", "no column 'gap'"),
    ("impacts null", "summary.json", "impacts"),
    ("no scene", "summary.json", "scene"),
    ("rebound without apex", "summary.json", "rebounds"),
    ("summary a list", "summary.json", "not an object"),
])
def test_plots_on_damaged_files_name_the_file_and_leave_no_figure(damage, file, what, run_files, tmp_path, capsys):
    """`python -m fem_bounce.plots DIR` on damaged files printed the internal exception (zero-size array,
    inhomogeneous shape, 'NoneType' object is not iterable, list index) and with a header-only trajectory left
    trajectory.png behind after exit 2."""
    folder = tmp_path / "r"
    folder.mkdir()
    for name, text in _damaged(run_files, damage).items():
        (folder / name).write_text(text)
    assert plots.main([str(folder)]) == 2
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1, lines
    assert f"cannot draw {folder}: {Path(folder) / file}" in lines[0] and what in lines[0], lines[0]
    for internal in ("zero-size", "inhomogeneous", "NoneType", "list index", "Error:"):
        assert internal not in lines[0], lines[0]
    assert sorted(p.name for p in folder.iterdir()) == ["summary.json", "trajectory.csv"]


def test_plots_redraws_a_sound_run(run_files, tmp_path, capsys):
    """The checks pass a run's own files: the figures are drawn (and named on stdout)."""
    folder = tmp_path / "r"
    folder.mkdir()
    for name, text in run_files.items():
        (folder / name).write_text(text)
    assert plots.main([str(folder)]) == 0
    assert {"trajectory.png", "velocity_gap.png"} <= {p.name for p in folder.iterdir()}
    assert sorted(p.name for p in folder.iterdir() if p.name.startswith(".")) == []


@pytest.mark.slow
def test_raising_the_bounce_limit_on_a_finished_run_and_restarting_runs_on(tmp_path, monkeypatch, capsys):
    """A finished run's run.bounces raised in DIR/scene.toml (a restart may change it): the restart said the new
    limit was reached and computed nothing, the checkpoint's own limit restored with its records.  A checkpoint
    every step, so that the last one is the finished run's."""
    monkeypatch.chdir(tmp_path)
    run_dir = tmp_path / "r"
    assert cli.main(["run", "li2011-case3", "--model", "fd", "--quiet", "--no-plots", "--out", str(run_dir),
                     "--set", "numerics.fd.cells_per_diameter=6", "--set", "numerics.fd.checkpoint_every=1",
                     "--set", "run.bounces=1"]) == 0
    first = json.loads((run_dir / "summary.json").read_text())
    assert len(first["impacts"]) == 1
    scene_file = run_dir / "scene.toml"
    scene_file.write_text(scene_file.read_text().replace("bounces = 1", "bounces = 2"))
    capsys.readouterr()
    assert cli.main(["run", "--restart", str(run_dir), "--quiet", "--no-plots"]) == 0
    again = json.loads((run_dir / "summary.json").read_text())
    assert len(again["impacts"]) == 2, capsys.readouterr().out
    assert again["impacts"][0]["impact_speed"] == pytest.approx(first["impacts"][0]["impact_speed"], rel=1e-9)
