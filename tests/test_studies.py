"""Study machinery: the run cache, error arithmetic, classification, and each study on the ODE model (the
speed-accuracy study's 3-D points also from a toy fd3d run)."""
import csv
import json
import math
from pathlib import Path

import pytest
from mpi4py import MPI

from fem_bounce import cache, cli, scene
from fem_bounce.studies import common, convergence, speed_accuracy, stability


def test_observed_order_and_richardson_recover_a_known_expansion():
    spacings = [1 / 8, 1 / 16, 1 / 32, 1 / 64]
    values = [2.0 + 3.0 * h**2 for h in spacings]
    orders = common.observed_orders(spacings, values)
    assert orders[0] == pytest.approx(math.log((3 / 64 - 3 / 4096) / (3 / 256 - 3 / 4096)) / math.log(2))
    order, limit = common.richardson(spacings, values)
    assert order == pytest.approx(2.0, rel=1e-6) and limit == pytest.approx(2.0, rel=1e-9)
    assert common.richardson([1.0, 0.5, 0.25], [1.0, 2.0, 1.5]) is None  # oscillating: no extrapolation


def test_pareto_front_keeps_only_undominated_points():
    points = [(1.0, 0.5), (2.0, 0.6), (3.0, 0.1), (4.0, 0.2), (5.0, 0.01)]
    assert common.pareto(points) == [0, 2, 4]


def test_recommendation_is_the_cheapest_setting_within_each_threshold():
    rows = [{"model": "ode", "setting": {"k": 1}, "wall_time_s": 0.1, "error": 0.2, "status": "completed"},
            {"model": "fd", "setting": {"k": 2}, "wall_time_s": 10, "error": 0.04, "status": "completed"},
            {"model": "fd", "setting": {"k": 3}, "wall_time_s": 20, "error": 0.005, "status": "completed"},
            {"model": "fd", "setting": {"k": 4}, "wall_time_s": 40, "error": 0.0, "status": "completed"}]
    picks = speed_accuracy.recommend(rows, ["impact_speed"], rows[-1])
    assert picks["10%"]["setting"] == {"k": 2} and picks["5%"]["setting"] == {"k": 2}
    assert picks["1%"]["setting"] == {"k": 3}  # the reference itself (error 0) is never recommended


def test_cache_reuses_finished_runs_and_keys_on_the_scene(tmp_path):
    sc = scene.load("li2011-case1", {"run.bounces": 1})
    first = cache.cached_run(sc, "ode", MPI.COMM_SELF, root=tmp_path)
    stamp = (first / "summary.json").stat().st_mtime_ns
    assert cache.cached_run(sc, "ode", MPI.COMM_SELF, root=tmp_path) == first
    assert (first / "summary.json").stat().st_mtime_ns == stamp
    assert cache.run_key(sc.replace(**{"contact.delta_ss": 0.018}), "ode") != cache.run_key(sc, "ode")
    assert cache.run_key(sc, "fd") != cache.run_key(sc, "ode")
    # one model's code does not key another's runs
    assert cache.code_version("ode") != cache.code_version("ib")


def test_energy_growth_flags_an_unphysical_trajectory(tmp_path):
    sc = scene.load("li2011-case3")
    sound = cache.cached_run(sc.replace(**{"run.bounces": 1}), "ode", MPI.COMM_SELF, root=tmp_path)
    assert not stability.energy_grew(sc, sound)
    rows = (sound / "trajectory.csv").read_text().splitlines()
    header = rows[0].split(",")
    last = rows[-1].split(",")
    last[header.index("velocity")] = "5.0"  # a kinetic energy the fall cannot have supplied
    (sound / "trajectory.csv").write_text("\n".join(rows[:-1] + [",".join(last)]) + "\n")
    assert stability.energy_grew(sc, sound)


def test_convergence_study_on_the_ode_model(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    sc = scene.load("li2011-case1", {"run.bounces": 1})
    analysis = convergence.run(sc, "ode", MPI.COMM_SELF, tmp_path / "study", levels=(1e-3, 1e-4, 1e-5, 1e-6))
    assert (tmp_path / "study" / "convergence.png").exists()
    errors = analysis["space:apex_gap"]["errors_vs_finest"]
    assert errors[0] > errors[-1]  # tighter tolerances converge
    data = json.loads((tmp_path / "study" / "convergence.json").read_text())
    assert data["key"] == "numerics.ode.rtol" and len(data["rows"]) == 4


def test_accuracy_without_a_recorded_study_is_a_clear_error(capsys):
    assert cli.main(["run", "li2011-case5", "--model", "ode", "--accuracy", "5%"]) == 2
    assert "no recorded speed-accuracy study for 'li2011-case5'" in capsys.readouterr().err


def test_speed_accuracy_levels_must_name_a_chosen_model(capsys):
    assert cli.main(["study", "speed-accuracy", "li2011-case1", "--models", "ode", "--levels", "fd=8,12"]) == 2
    assert "--levels 'fd=8,12': expected MODEL=V1,V2,..." in capsys.readouterr().err


def test_time_step_ladder_scales_every_step_limit_of_a_model():
    """The fd model's dt is usually set by its forcing number, not its CFL: both must move."""
    sc = scene.load("li2011-case3", {"numerics.fd.constraint": "penalty"})
    cfl = sc.numerics.fd.resolved("peak_cfl")  # unset: the constraint's own
    change = common.LADDERS["fd"].time_step(sc, 2 * cfl)
    assert change == {"numerics.fd.peak_cfl": 2 * cfl,
                      "numerics.fd.forcing_number": pytest.approx(2 * sc.numerics.fd.forcing_number)}
    assert common.LADDERS["ode"].time_step(sc, 0.4) == {}


def test_figure_11_draws_from_the_run_into_the_study(tmp_path, monkeypatch):
    from fem_bounce import fields
    from fem_bounce.studies import figures

    calls = []
    monkeypatch.setattr(fields, "vorticity_figure",
                        lambda run_dir, times=None, path=None: calls.append((run_dir, path)) or path)
    study = common.StudyDirectory(tmp_path / "study", MPI.COMM_SELF)
    assert figures.figure_11(tmp_path / "run", tmp_path / "fig11.png", study) == tmp_path / "fig11.png"
    assert calls == [(tmp_path / "run", tmp_path / "fig11.png")]


def test_study_numbers_that_do_not_parse_are_a_clear_error(capsys):
    assert cli.main(["study", "convergence", "li2011-case1", "--model", "ode", "--levels", "1e-3,x"]) == 2
    assert "--levels '1e-3,x': expected comma-separated positive numbers" in capsys.readouterr().err


def test_record_writes_where_the_user_says_never_into_the_package(tmp_path, monkeypatch, capsys):
    """`study speed-accuracy --record` wrote into the installed package; now into --out, or results/, which
    `run --accuracy` then reads over the shipped record."""
    package_data = Path(speed_accuracy.__file__).parents[1] / "data"
    before = {p.name: p.read_bytes() for p in package_data.iterdir()}
    monkeypatch.chdir(tmp_path)
    args = ["study", "speed-accuracy", "li2011-case5", "--models", "ode", "--levels", "ode=1e-3,1e-4,1e-5",
            "--record", "--set", "run.bounces=1"]
    assert cli.main([*args, "--out", "mine"]) == 0
    assert "li2011-case5" in json.loads((tmp_path / "mine" / speed_accuracy.RECORD).read_text())
    assert not (tmp_path / "results" / speed_accuracy.RECORD).exists()
    assert cli.main(args) == 0
    assert (tmp_path / "results" / speed_accuracy.RECORD).is_file()
    assert {p.name: p.read_bytes() for p in package_data.iterdir()} == before
    assert "li2011-case5" in speed_accuracy.recorded()  # read from results/ in the current directory
    capsys.readouterr()
    assert cli.main(["run", "li2011-case5", "--accuracy", "10%", "--quiet", "--out", "acc"]) == 0
    assert "--accuracy 10%: ode with {'numerics.ode.rtol'" in capsys.readouterr().err


def test_speed_accuracy_reference_is_the_finest_level_at_a_shorter_step(tmp_path, monkeypatch):
    """A time-step error shared by every run of a model at its scene's step shows against the reference:
    the finest level run again at reference_step times the step (toy rows: an error of 1/cells^2 in
    space and of the CFL number in time, so each run's error against it is known)."""
    sc = scene.load("li2011-case3")
    cfl = sc.numerics.ale.cfl
    asked = []

    def toy_measure_all(tasks, study, runner=None):
        asked.extend(tasks)
        rows = []
        for task_scene, model, label in tasks:
            ale = task_scene.numerics.ale
            speed = 0.4 * (1.0 + 1.0 / ale.cells_per_diameter**2 + 0.01 * ale.cfl)
            rows.append({"model": model, "label": label, "run_dir": f"runs/{label}", "status": "completed",
                         "wall_time_s": ale.cells_per_diameter**2 / ale.cfl, "impact_speed": speed,
                         "apex_gap": 0.004 * (1.0 + 0.02 * ale.cfl), "restitution": 0.75, "re_second": 48.0})
        return rows

    monkeypatch.setattr(speed_accuracy, "measure_all", toy_measure_all)
    levels = {"ale": [8.0, speed_accuracy.Level(8.0, 0.5), 16.0, speed_accuracy.Level(16.0, 0.5)]}
    result = speed_accuracy.run(sc, ["ale"], MPI.COMM_SELF, tmp_path / "study", levels)
    # five runs: the four levels and the reference, 16 cells/D at a quarter of the scene's step
    assert [task[0].numerics.ale.cfl for task in asked] == pytest.approx([cfl, 0.5 * cfl, cfl, 0.5 * cfl,
                                                                          0.25 * cfl])
    # only the reference takes the reference's own settings (registry.ModelInfo.reference_settings: its surface
    # three times finer than its path, where the levels keep the default's five)
    assert [task[0].numerics.ale.surface_refinement for task in asked] == [5.0] * 4 + [3.0]
    collision = {"numerics.ale.adaptive_step": True, "numerics.ale.max_step_factor": 1.0,
                 "numerics.ale.min_step_factor": 0.05, "numerics.ale.surface_refinement": 3.0}
    assert result["reference"]["setting"] == {"numerics.ale.cells_per_diameter": 16.0,
                                              "numerics.ale.cfl": pytest.approx(0.25 * cfl), **collision}
    assert result["reference"]["step_factor"] == pytest.approx(0.25)
    by_label = {r["label"]: r for r in result["rows"]}
    finest = by_label["numerics.ale.cells_per_diameter = 16"]
    # the finest level at the scene's step is no longer error-free: its time-step error shows
    expected = (1 + 1 / 256 + 0.01 * cfl) / (1 + 1 / 256 + 0.0025 * cfl) - 1
    assert finest["error_impact_speed"] == pytest.approx(expected, rel=1e-9)
    assert finest["error_apex_gap"] == pytest.approx((1 + 0.02 * cfl) / (1 + 0.005 * cfl) - 1, rel=1e-9)
    assert finest["error_restitution"] == pytest.approx(0.0, abs=1e-15)  # reported beside, not judged
    assert result["quantities"] == ["impact_speed", "apex_gap"]
    assert result["secondary_quantities"] == ["restitution", "re_second"]
    # half the step at 8 cells/D is more accurate than 8 cells/D at the scene's step
    halved = by_label[f"numerics.ale.cells_per_diameter = 8, numerics.ale.cfl = {0.5 * cfl:g}"]
    assert halved["setting"]["numerics.ale.cfl"] == pytest.approx(0.5 * cfl)
    assert halved["error"] < by_label["numerics.ale.cells_per_diameter = 8"]["error"]
    # the reference is never recommended; the JSON and the log say what it is
    assert all(rec is None or rec["setting"] != result["reference"]["setting"]
               for rec in result["recommendations"].values())
    assert json.loads((tmp_path / "study" / "speed_accuracy.json").read_text())["reference"]["text"] == (
        f"ale, numerics.ale.cells_per_diameter = 16, numerics.ale.cfl = {0.25 * cfl:g}, numerics.ale.adaptive_step = "
        "true, numerics.ale.max_step_factor = 1, numerics.ale.min_step_factor = 0.05, "
        "numerics.ale.surface_refinement = 3")
    assert "reference: ale, numerics.ale.cells_per_diameter = 16" in (tmp_path / "study" / "progress.log").read_text()
    assert (tmp_path / "study" / "speed_accuracy.png").exists()


def test_speed_accuracy_step_levels_and_reference_step_are_checked(capsys):
    assert cli.main(["study", "speed-accuracy", "li2011-case1", "--models", "ode", "--levels", "ode=1e-3@0.5"]) == 2
    assert "the ode model has no time-step setting" in capsys.readouterr().err
    assert cli.main(["study", "speed-accuracy", "li2011-case1", "--models", "ode,ale", "--levels", "ale=8@x"]) == 2
    assert "optionally V@F for F times the time step" in capsys.readouterr().err
    assert cli.main(["study", "speed-accuracy", "li2011-case1", "--models", "ale", "--reference-step", "2"]) == 2
    assert "--reference-step 2 is out of range: allowed in (0, 1]" in capsys.readouterr().err


def test_speed_accuracy_judges_the_3d_model_against_the_axisymmetric_reference(tmp_path, monkeypatch):
    """fd3d's points go on the chart and CSV beside the axisymmetric models', judged against the same reference: ale's
    finest level, not fd3d's (listed first here), on a head-on scene; and however cheap and accurate its runs, they
    are never recommended for `run --accuracy` (registry.FRONT_PICKS: a head-on run never takes fd3d).  Toy rows:
    each model's error a known function of its resolution."""
    from fem_bounce.models.registry import MODELS

    sc = scene.load("li2011-case3")
    excess = {"ale": lambda c: 1 / c**2, "fd": lambda c: 0.1, "ode": lambda c: 0.3,
              "fd3d": lambda c: 1 / 256 + 0.2 / c**2}  # fd3d: within 2 % at 4 cells/D, the cheapest run that is
    cost = {"ale": lambda c: c**2, "fd": lambda c: 5.0, "ode": lambda c: 0.01, "fd3d": lambda c: c / 20}

    def toy_measure_all(tasks, study, runner=None):
        rows = []
        for task_scene, model, label in tasks:
            c = MODELS[model].resolution(task_scene)
            factor = 1.0 + excess[model](c)
            rows.append({"model": model, "label": label, "run_dir": f"runs/{model} {label}", "status": "completed",
                         "wall_time_s": cost[model](c), "impact_speed": 0.4 * factor, "apex_gap": 0.004 * factor,
                         "restitution": 0.75, "re_second": 48.0})
        return rows

    monkeypatch.setattr(speed_accuracy, "measure_all", toy_measure_all)
    levels = {"fd3d": [4.0, 6.0], "ode": [1e-3], "fd": [8.0], "ale": [8.0, 16.0]}
    out = tmp_path / "study"
    result = speed_accuracy.run(sc, ["fd3d", "ode", "fd", "ale"], MPI.COMM_SELF, out, levels)
    assert result["reference"]["model"] == "ale"
    assert result["reference"]["setting"]["numerics.ale.cells_per_diameter"] == 16.0
    fd3d = {r["setting"]["numerics.fd3d.cells_per_diameter"]: r for r in result["rows"] if r["model"] == "fd3d"}
    assert fd3d[4.0]["error_impact_speed"] == pytest.approx((1 + 1 / 256 + 0.2 / 16) / (1 + 1 / 256) - 1)
    assert fd3d[6.0]["error"] < fd3d[4.0]["error"] < 0.02
    with open(out / "speed_accuracy.csv", newline="") as stream:
        table = [row for row in csv.DictReader(stream) if row["model"] == "fd3d"]
    assert [float(row["numerics.fd3d.cells_per_diameter"]) for row in table] == [4.0, 6.0]
    assert (out / "speed_accuracy.png").exists()
    # fd3d's 4 cells/D would be the 2, 5 and 10 % picks; the recommendations come from the head-on picks only
    assert speed_accuracy.recommend(result["rows"], result["quantities"], None)["5%"]["model"] == "fd3d"
    picks = {level: rec["model"] for level, rec in result["recommendations"].items()}
    assert picks == {"1%": "ale", "2%": "ale", "5%": "ale", "10%": "fd"}
    assert result["recommended_from"] == ["fd", "ale", "ode"]
    assert "not recommended (one sphere on the axis" in (out / "progress.log").read_text()
    recorded = json.loads(speed_accuracy.record(result, tmp_path).read_text())["li2011-case3"]
    assert {pick["model"] for pick in recorded.values()} == {"ale", "fd"}
    assert speed_accuracy.series_style("fd3d") == ("D", "fd3d (3-D)")
    assert speed_accuracy.series_style("ale") == ("o", "ale")


def test_speed_accuracy_without_a_reference_model_is_a_clear_error(tmp_path, capsys):
    """fd3d alone has no reference to be judged by (it is none itself: registry.FIDELITY): one line, nothing run."""
    out = tmp_path / "study"
    assert cli.main(["study", "speed-accuracy", "li2011-case3", "--models", "fd3d", "--out", str(out)]) == 2
    assert "highest-fidelity model listed, one of ale, fd, ib, ode: add one, e.g. --models ale,fd3d" in (
        capsys.readouterr().err)
    assert not out.exists()


@pytest.mark.slow
def test_speed_accuracy_runs_the_3d_model_through_the_study_cache(tmp_path, monkeypatch, capsys):
    """A toy fd3d run (4 cells/D, its surface unrefined, to 12 ms: a few seconds; test_fd3d_model.py's TINY) goes
    through the study's runner and cache like the axisymmetric models' runs, and the study again reuses it."""
    monkeypatch.setenv("FEM_BOUNCE_CACHE", str(tmp_path / "cache"))
    args = ["study", "speed-accuracy", "li2011-case3", "--models", "ode,fd3d", "--levels", "ode=1e-3,1e-4",
            "--levels", "fd3d=4", "--set", "run.end_time=0.012", "--set", "numerics.fd3d.surface_refinement=1"]
    assert cli.main([*args, "--out", str(tmp_path / "first")]) == 0
    first = json.loads((tmp_path / "first" / "speed_accuracy.json").read_text())
    (row,) = [r for r in first["rows"] if r["model"] == "fd3d"]
    assert row["status"] == "completed" and 0.07 < row["peak_speed"] < 0.1  # the fall's, against ode's 0.086
    assert Path(row["run_dir"]).parent == tmp_path / "cache" / "runs"
    assert cli.main([*args, "--out", str(tmp_path / "again")]) == 0
    again = json.loads((tmp_path / "again" / "speed_accuracy.json").read_text())
    assert [r["run_dir"] for r in again["rows"]] == [r["run_dir"] for r in first["rows"]]
    assert [r["wall_time_s"] for r in again["rows"]] == [r["wall_time_s"] for r in first["rows"]]  # not run again
