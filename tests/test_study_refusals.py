"""What the studies, the restitution sweep and `run --accuracy` refuse before anything is written (one line, exit
2), and the sweep's plan saying what it runs.  The ODE model in this process."""
import json

import pytest

from fem_bounce import scene as scenes
from fem_bounce.studies import restitution, restitution_planning
from helpers import assert_one_line, ode_run, refused, refused_same_listing, run_cli


# -- studies and sweeps -----------------------------------------------------------------------------------------------


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


@pytest.mark.parametrize("argv,message", [
    (["study", "convergence", "li2011-case3", "--model", "ode", "--levels", "nan,inf"], "--levels 'nan,inf': expected"),
    (["study", "convergence", "li2011-case3", "--model", "fd", "--cfls", "0,-1"], "--cfls '0,-1': expected"),
    (["restitution", "--set", "sphere.densty=5"], "unknown key sphere.densty"),
    (["study", "restitution", "--model", "ode", "--points", "0"], "is now `fem-bounce restitution`"),
    (["restitution", "--points", "0"], "need --points >= 2"),
    (["restitution", "--points", "1000000000"], "--points 1000000000: allowed 2 to 1000"),
    (["restitution", "--set", "initial_gap=5"], "--set initial_gap: the restitution sweep sets initial_gap"),
    (["compare", "li2011-case3", "--models", "ode,ode"], "--models names ode more than once"),
    (["study", "oblique", "foerster1994-glass", "--angles", ""], "(0, 90) from the wall's normal, got none"),
    (["study", "oblique", "foerster1994-glass", "--angles", "0"], "--angles '0': expected"),
    (["study", "oblique", "foerster1994-glass", "--angles", "30,90"], "(0, 90) from the wall's normal, got 90"),
    (["study", "oblique", "foerster1994-glass", "--angles", "30,10,30"], "--angles names 30 more than once"),
])
def test_study_arguments_are_checked_before_anything_is_written(argv, message, tmp_path, monkeypatch, capsys):
    """--levels nan named numerics.ode.rtol and left an empty directory, --points 0 meant the default,
    10^9 points ran silently for ever, compare --models ode,ode ended in FileExistsError."""
    refused_same_listing(capsys, tmp_path, monkeypatch, *argv, "--out", "study", message=message)


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


# -- the restitution sweep's plan -------------------------------------------------------------------------------------


@pytest.mark.parametrize("case", ["bogus key", "bad value", "launched light sphere", "unreachable St", "light sets"])
def test_the_restitution_sweep_plans_what_it_runs(case, tmp_path, monkeypatch, capsys):
    """--points 3 dropped St 1000 silently and still said "St 10-1000"; a light sphere launched at the wall
    without gravity was said to rise; the sweep with sphere.density = 500 labelled its runs St 1-24 (planned with
    the shipped presets) where they measured St 0.015-0.09; a bad --set was refused after ~49 s of planning."""
    if case in ("bogus key", "bad value"):
        def planning(*args, **kwargs):
            raise AssertionError("the sweep planned before checking its --set values")
        monkeypatch.setattr(restitution_planning, "first_bounce", planning)
        setting, message = {"bogus key": ("bogus.key=1", "unknown key bogus"),
                            "bad value": ("contact.cavitation_pressure=abc", "cavitation_pressure = 'abc'")}[case]
        refused(capsys, tmp_path, monkeypatch, "restitution", "--set", setting, "--out", "r", message=message)
    elif case == "launched light sphere":
        summary, _, err = ode_run(capsys, tmp_path, "gravity=0", "initial_velocity=-0.3", "sphere.density=500")
        assert err == [] and summary["stop_reason"].startswith("the sphere stalled in the lubrication film")
    elif case == "unreachable St":
        reach = r"no Table 3 set reaches St 1000 \(.* they reach St 0.1[0-9]*-12[0-9]\): 1 of"
        with pytest.warns(UserWarning, match=reach):
            planned = restitution_planning.plan(3, sets=["li2011-table3-steel-78"])
        assert [round(st) for _, st, _ in planned][-1] == 32
        rows = [{"scene": "li2011-table3-steel-78", "St": st, "restitution": 0.5} for st in (12.0, 31.6)]
        assert restitution.compare(rows)["covered_St"] == [12.0, 31.6]
    else:
        light = {"sphere.density": 500.0}
        with pytest.warns(UserWarning, match="no Table 3 set reaches St 11.14"):  # lighter: slower in St
            planned = restitution_planning.plan(3, sets=["li2011-table3-steel-65"], overrides=light)
        assert planned
        for name, target, launch in planned:
            measured = restitution_planning.first_bounce(scenes.load(name, light), launch)["St"]
            assert measured == pytest.approx(target, rel=0.02)


# -- the records `run --accuracy` reads -------------------------------------------------------------------------------


@pytest.mark.parametrize("content", ['{"li2011-case3": {"5%": {"mod', "[1, 2]"])
def test_a_broken_accuracy_record_gives_one_line(content, tmp_path, monkeypatch, capsys):
    """A truncated or list-valued results/accuracy_recommendations.json crashed `run --accuracy 5%`."""
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "accuracy_recommendations.json").write_text(content)
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", "--accuracy", "5%", "--quiet",
            message="results/accuracy_recommendations.json (the accuracy record `--accuracy` reads")


@pytest.mark.parametrize("entry", [{"quantities": [1]}, {"error": True}])
def test_an_accuracy_record_of_wrong_types_names_its_file(entry, tmp_path, monkeypatch, capsys):
    """A record entry with "quantities": [1] or a bool "error" gave a TypeError on `run --accuracy 10%`."""
    pick = {"model": "ode", "setting": {"numerics.ode.rtol": 1e-3}, "error": 0.05, "quantities": ["impact_speed"],
            **entry}
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "accuracy_recommendations.json").write_text(json.dumps({"li2011-case3": {"10%": pick}}))
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", "--accuracy", "10%", "--quiet",
            message="results/accuracy_recommendations.json (the accuracy record `--accuracy` reads")


@pytest.mark.parametrize("case,argv,setting,message", [
    ("other density", ["li2011-case3", "--set", "sphere.density=2000"], None,
     "the record of 'li2011-case3' was measured on other values"),
    ("renamed", ["li2011-case1", "--set", "name=li2011-case3"], None,
     "the record of 'li2011-case3' was measured on other values"),
    ("own --set", ["li2011-case3", "--set", "numerics.ode.rtol=1e-7"], None,
     "--set numerics.ode.rtol=1e-07 and --accuracy 10% (which sets numerics.ode.rtol = "),  # the packaged pick's
    ("physical key", ["li2011-case3"], {"sphere.density": 2000.0},
     "results/accuracy_recommendations.json: the 10% pick of 'li2011-case3' sets sphere.density, not a numerical"),
    ("bad value", ["li2011-case3"], {"numerics.ode.rtol": -1.0},
     "results/accuracy_recommendations.json: the 10% pick for 'li2011-case3': numerics.ode.rtol = -1.0 is out"),
])
def test_an_accuracy_record_applies_to_its_own_scene_and_numerics(case, argv, setting, message, tmp_path, monkeypatch,
                                                                   capsys):
    """Case 3's record was applied to case 3 at St 2.9 (sphere.density = 2000) and to case 1 renamed li2011-case3
    (looked up by name); a record setting sphere.density was applied; the user's --set numerics.ode.rtol was
    replaced silently; a bad entry was reported without naming the record file."""
    if setting is not None:  # the user's own record, measured on case 3 as shipped
        digest = scenes.physics_digest(scenes.load("li2011-case3"))
        pick = {"model": "ode", "setting": setting, "error": 0.05, "quantities": ["impact_speed"],
                "scene_digest": digest, "wall_time_s": 1.0}
        (tmp_path / "results").mkdir()
        (tmp_path / "results" / "accuracy_recommendations.json").write_text(json.dumps({"li2011-case3": {"10%": pick}}))
    refused(capsys, tmp_path, monkeypatch, "run", *argv, "--accuracy", "10%", "--quiet", "--out", "r", message=message)
