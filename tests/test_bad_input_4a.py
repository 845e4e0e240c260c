"""Round four of bad input (issue 43, part A), one test per finding: the exit status, the one line naming the
culprit, nothing written or left behind by a refusal, and no Python, C++ or PETSc error text.  The ODE model in
this process wherever the finding is not about a process; real processes where a pipe, a signal, a kill, a
deleted working directory or a locale is the point."""
import json

import pytest

import fem_bounce as fb
from test_bad_input import ODE
from test_bad_input_3 import refused

ODE_ONE = ["li2011-case3", *ODE, "--set", "run.bounces=1"]


# -- tracebacks -------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("overrides", [{"contact.cavitation_pressure": -1e-300},
                                       {"liquid.ambient_pressure": 1e-320, "liquid.vapour_pressure": 0.0}])
def test_a_tension_below_the_films_scale_is_the_film_that_holds_none(overrides):
    """A tension of 1e-300 Pa (or an ambient pressure of 1e-320 Pa over no vapour pressure) overflowed 1 / s^2 in
    the tension relief: "ValueError: cannot convert float NaN to integer" after trajectory.csv was written.  It is
    the limit of a liquid that holds no tension."""
    scene = fb.load("li2011-case3", {"run.bounces": 1})
    tiny = fb.simulate(scene.replace(**overrides), "ode")
    none = fb.simulate(scene.replace(**{"contact.cavitation_pressure": 0.0}), "ode")
    assert tiny.status == "completed"
    assert tiny.rebounds[0].restitution == pytest.approx(none.rebounds[0].restitution, rel=1e-6)


@pytest.mark.parametrize("entry", [{"quantities": [1]}, {"error": True}])
def test_an_accuracy_record_of_wrong_types_names_its_file(entry, tmp_path, monkeypatch, capsys):
    """A record entry with "quantities": [1] or a bool "error" gave a TypeError on `run --accuracy 10%`."""
    pick = {"model": "ode", "setting": {"numerics.ode.rtol": 1e-3}, "error": 0.05, "quantities": ["impact_speed"],
            **entry}
    (tmp_path / "results").mkdir()
    (tmp_path / "results" / "accuracy_recommendations.json").write_text(json.dumps({"li2011-case3": {"10%": pick}}))
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", "--accuracy", "10%", "--quiet",
            message="results/accuracy_recommendations.json (the accuracy record `--accuracy` reads")
