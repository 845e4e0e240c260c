"""The loss audit (fem_bounce.losses): every force's impulse over each phase of a collision adds up to the
sphere's momentum change, with the ode model and with a resolved one, and it is written with the run."""
import json

import numpy as np
import pytest
from mpi4py import MPI

from fem_bounce import losses, output
from fem_bounce import scene as scenes
from fem_bounce.run import simulate

TOY_ALE = {"numerics.ale.cells_per_diameter": 6, "run.bounces": 1}


def audited_run(tmp_path, model: str, changes: dict) -> dict:
    sc = scenes.load("li2011-case3", changes)
    simulate(sc, model, MPI.COMM_SELF, tmp_path / model, progress=False, plots=False)
    return json.loads((tmp_path / model / "summary.json").read_text())


@pytest.mark.parametrize("model, changes", [("ode", {"run.bounces": 2}), ("ale", TOY_ALE)])
def test_the_impulses_add_up_to_the_momentum_change(tmp_path, model, changes):
    summary = audited_run(tmp_path, model, changes)
    audits = [impact["losses"] for impact in summary["impacts"]]
    assert audits
    for audit in audits:
        assert abs(audit["imbalance"]) < 0.01  # sum of impulses against m_p (V_out + V_in), of m_p V_peak
        phases = audit["phases"]
        assert phases["approach"][1] == phases["contact"][0] and phases["contact"][1] == phases["rebound"][0]
        contact = audit["impulse"]["contact"]
        assert contact[1] > 0.0 and contact[0] == pytest.approx(0.0, abs=1e-6 * contact[1])
    first = audits[0]
    names = set(first["impulse"])
    if model == "ode":
        assert {"drag", "lubrication", "history", "added_mass", "contact", "weight"} <= names
        assert first["share"]["lubrication"][0] > 0.0 > first["share"]["lubrication"][2]  # it resists both ways
    else:
        assert {"resolved_flow", "correction", "contact", "weight"} <= names and "history" not in names


def test_the_audit_is_redrawn_from_the_files(tmp_path):
    summary = audited_run(tmp_path, "ode", {"run.bounces": 1})
    trajectory = output.read_trajectory(tmp_path / "ode")
    again = json.loads(json.dumps(summary))
    for impact in again["impacts"]:
        impact.pop("losses")
    losses.annotate(again, trajectory)
    assert again["impacts"][0]["losses"]["share"] == summary["impacts"][0]["losses"]["share"]
    trajectory["f_elastic"] = np.zeros_like(trajectory["f_elastic"])
    losses.annotate(again, trajectory)
    assert abs(again["impacts"][0]["losses"]["imbalance"]) > 0.5  # without the contact nothing adds up
