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


# |imbalance| measured 5e-4 (ode) and 4e-3 (ale at 6 cells/D): leaving out the smallest term (the ode's drag, a
# net 5e-3 of m_p V_peak on the first impact; ale's correction, 0.045) breaks the limit
@pytest.mark.parametrize("model, changes, limit", [("ode", {"run.bounces": 2}, 2e-3), ("ale", TOY_ALE, 0.01)])
def test_the_impulses_add_up_to_the_momentum_change(tmp_path, model, changes, limit):
    summary = audited_run(tmp_path, model, changes)
    audits = [impact["losses"] for impact in summary["impacts"]]
    assert audits
    for audit in audits:
        assert abs(audit["imbalance"]) < limit  # sum of impulses against m_p (V_out + V_in), of m_p V_peak
        phases = audit["phases"]
        assert phases["approach"][0] < phases["contact"][0] < phases["contact"][1] < phases["rebound"][1]
        contact = audit["impulse"]["contact"]  # the elastic force acts inside the contact phase only
        assert audit["left_contact"] and contact[1] > 0.0
        assert contact[0] == pytest.approx(0.0, abs=1e-6 * contact[1])
        assert contact[2] == pytest.approx(0.0, abs=1e-6 * contact[1])
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
    for name, shares in summary["impacts"][0]["losses"]["share"].items():
        assert again["impacts"][0]["losses"]["share"][name] == pytest.approx(shares, rel=1e-9, abs=1e-12)
    trajectory["f_elastic"] = np.zeros_like(trajectory["f_elastic"])
    warning = losses.annotate(again, trajectory)  # without the contact nothing adds up: no audit, and why
    assert "losses" not in again["impacts"][0] and "its impulses miss" in again["impacts"][0]["losses_skipped"]
    assert warning.startswith("no loss audit for impact(s) 1:")


@pytest.mark.slow
def test_ode_and_ale_agree_on_a_bounce_at_st_20(tmp_path):
    """Case 3 in a 0.13 Pa s liquid (first impact at St ~21), ale at a toy 6 cells/D: the two models return the
    same share of the speed across the contact, take about the same share of the momentum on the way out (the
    ode model's history force kept through the contact: 1.21 times ale's at this resolution, within 5-10 % of
    it at 16 cells/D; paused, about 0.6 times: docs/physics.md 3.6), and differ in e by what their approaches
    differ (measured 0.534 against 0.602; benchmarks/impact_history.py)."""
    changes = {"liquid.viscosity": 0.13, "run.bounces": 1}
    ode = audited_run(tmp_path, "ode", changes)
    ale = audited_run(tmp_path, "ale", {**changes, "numerics.ale.cells_per_diameter": 6})

    def phases(summary):
        share = summary["impacts"][0]["losses"]["share"]
        total = [sum(values[j] for values in share.values()) for j in range(3)]
        liquid = [sum(values[j] for name, values in share.items() if name not in ("contact", "weight"))
                  for j in range(3)]
        arriving = -1.0 + total[0]
        return -(arriving + total[1]) / arriving, liquid[2], summary["rebounds"][0]["restitution"]

    (across_ode, out_ode, e_ode), (across_ale, out_ale, e_ale) = phases(ode), phases(ale)
    assert across_ode == pytest.approx(across_ale, abs=0.02)
    assert 0.8 < out_ode / out_ale < 1.3
    assert abs(e_ode - e_ale) < 0.1 and e_ode > 0.3
