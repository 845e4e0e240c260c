"""The oblique study (fem-bounce study oblique): its checks, and a two-angle sweep of the dry glass preset that
writes its table and figure, sliding at the steep angle as the rigid theory says."""
from __future__ import annotations

import csv

import pytest
from mpi4py import MPI

from fem_bounce import scene as scenes
from fem_bounce.studies import oblique
from fem_bounce.tangential_contact import sliding_threshold


def test_the_study_needs_a_launched_sphere_and_a_friction(tmp_path):
    with pytest.raises(scenes.SceneError, match="initial_velocity"):
        oblique.run(scenes.load("li2011-case3"), MPI.COMM_SELF, tmp_path / "a", [30.0])
    with pytest.raises(scenes.SceneError, match="contact.friction"):
        oblique.run(scenes.load("li2011-case3", {"initial_velocity": -0.3}), MPI.COMM_SELF, tmp_path / "b", [30.0])
    with pytest.raises(scenes.SceneError, match="--angles"):
        oblique.run(scenes.load("foerster1994-glass"), MPI.COMM_SELF, tmp_path / "c", [95.0])
    assert not any(tmp_path.iterdir())  # refused before anything is written


@pytest.mark.slow
def test_a_sweep_writes_its_table_and_figure(tmp_path):
    rows = oblique.run(scenes.load("foerster1994-glass"), MPI.COMM_SELF, tmp_path, [10.0, 50.0])
    assert (tmp_path / "oblique.png").stat().st_size > 0
    with open(tmp_path / "oblique.csv") as stream:
        assert [float(r["angle_deg"]) for r in csv.DictReader(stream)] == [10.0, 50.0]
    steep = rows[1]
    assert steep["psi_in_contact"] > sliding_threshold(0.83, 0.125)
    assert steep["effective_friction_contact"] == pytest.approx(0.125, rel=0.01)
    assert rows[0]["effective_friction_contact"] < 0.125  # the shallow one sticks: less than mu's impulse


def test_the_study_says_how_far_each_branch_is_from_the_rigid_theory():
    """rigid_agreement: a sliding run against psi_in - (7/2) mu (1 + e_n), a rolling one against 0 over psi_in."""
    theory = {"friction": 0.125, "normal_restitution": 0.83}
    threshold = sliding_threshold(0.83, 0.125)
    rows = [{"psi_in_contact": 0.5, "psi_out_contact": -0.05, "normal_restitution_contact": 0.83},
            {"psi_in_contact": threshold + 0.4, "psi_out_contact": 0.404, "normal_restitution_contact": 0.83},
            {"psi_in_contact": None, "psi_out_contact": None, "normal_restitution_contact": None}]
    line = oblique.rigid_agreement(rows, theory)
    assert "psi_out within 0.01 of it" in line and "within 0.1 psi_in of 0" in line
