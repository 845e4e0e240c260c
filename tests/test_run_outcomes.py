"""How a run ends and what it records: the stop it states (a light sphere rising, a sphere at rest with nothing
left to do), the divergence that names its cause (an energy gain, a contact that cannot stop the sphere, a path
through the wall, a step below its floor), the contact gap kept above a continuum film, and a loss audit that is
right or absent with the reason in the summary.  The ODE model in this process wherever the finding is not
model-specific."""
import json
import time

import numpy as np
import pytest
from mpi4py import MPI

import fem_bounce as fb
from fem_bounce import output, progress, run
from helpers import FD_TOY, ODE, assert_one_line, ode_run, refused, run_cli


# -- the stop a run states --------------------------------------------------------------------------------------------


def test_light_sphere_runs_with_a_warning_and_a_stated_stop(tmp_path, capsys):
    """A sphere lighter than the liquid rose and the run said 'completed', no impact, no word."""
    out = tmp_path / "run"
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--set", "sphere.density=600", "--out", str(out))
    assert status == 0
    assert_one_line(lines, "warning: sphere.density = 600 kg/m3 is below liquid.density",
                    "the run stops when it has risen 10 D above its release")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and "risen 10 D" in summary["stop_reason"] and not summary["impacts"]
    d, h0, final = 0.0095, 0.0152, summary["final"]
    longest_step = 0.02 * (d / 9.81) ** 0.5  # the integrator's largest step, sphere_ts_adapt_dt_max
    assert h0 + 10 * d <= final["gap"] <= h0 + 10 * d + abs(final["velocity"]) * longest_step


def test_light_sphere_stops_at_the_top_of_the_fd_refined_region(tmp_path, capsys):
    """With the fd model it rose out of the refined mesh and its velocity left the ODE model's."""
    out = tmp_path / "run"
    status, lines = run_cli(capsys, "run", *FD_TOY, "--set", "sphere.density=600", "--set", "run.end_time=0.6",
                            "--set", "numerics.fd.wake_length=0.5", "--out", str(out))
    assert status == 0
    assert_one_line(lines, "warning: ", "reached the top of the fd model's refined region (gap 2.1 D)")
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "completed" and "refined region" in summary["stop_reason"]
    assert summary["final"]["gap"] / 0.0095 == pytest.approx(0.0152 / 0.0095 + 0.5, abs=0.02)
    assert summary["final"]["time"] < 0.1


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


# -- divergences that name their cause --------------------------------------------------------------------------------


@pytest.mark.parametrize("model,overrides", [
    ("ib", ["numerics.ib.cells_per_diameter=12", "numerics.ib.coupling=explicit", "sphere.density=1323"]),
    # the fixed mesh's (on the moving mesh the lagged force at the step's reference velocity carried this sphere up
    # to the lid without gaining energy)
    ("fd", ["numerics.fd.cells_per_diameter=6", "numerics.fd.coupling=explicit", "sphere.density=96",
            "run.end_time=0.02", "numerics.fd.mesh=fixed", "numerics.ode.flow_force=end"]),  # classically held
])
def test_energy_gain_stops_the_run_and_names_the_coupling(model, overrides, tmp_path, capsys):
    """An unstable coupling threw spheres up at several times their impact speed and nothing caught the
    energy gain; the ib model blamed its grid region ('raise fine_margin'), sending the user the wrong way."""
    out = tmp_path / "run"
    scene = "li2011-case3" if model == "ib" else "tencate2002-e4"
    args = [item for pair in (("--set", o) for o in overrides) for item in pair]
    status, lines = run_cli(capsys, "run", scene, "--model", model, "--quiet", *args, "--out", str(out))
    assert status == 1
    lines = [line for line in lines if "warning:" not in line]  # the light sphere's warning
    assert_one_line(lines, "diverged: the sphere gained energy it cannot have",
                    f'numerics.{model}.coupling = "explicit" fails here')
    assert "grid region" not in lines[0]
    assert json.loads((out / "summary.json").read_text())["status"].startswith("diverged: the sphere gained energy")


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


# -- the contact gap and the film -------------------------------------------------------------------------------------


def test_a_tiny_contact_gap_factor_ends_with_a_summary(tmp_path, capsys):
    """contact_gap_factor = 1e-10 ended in ZeroDivisionError after the run, without summary.json (such a factor is
    refused now: the smallest gap allowed, a few nm on smooth surfaces, runs)."""
    out = tmp_path / "run"
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--set", "contact.contact_gap_factor=3e-3",
                            "--set", "sphere.roughness=0", "--set", "wall.roughness=0", "--out", str(out))
    assert status == 0 and lines == []
    assert json.loads((out / "summary.json").read_text())["status"] == "completed"


@pytest.mark.parametrize("settings,message", [
    (["contact.contact_gap_factor=1e-10"], "factor = 1e-10 is out of range: the wall contact would begin 4.68e-17 m "
                                           "apart, below 4e-08 m (the surfaces' combined roughness"),
    (["contact.contact_gap_factor=1e-3", "sphere.roughness=0", "wall.roughness=0"],
     "factor = 0.001 is out of range: the wall contact would begin 4.68e-10 m apart, below 1e-09 m (a few molecular"),
    (["run.bounces=0"], None),
])
def test_no_contact_below_a_continuum_film_and_no_impact_from_a_creep(settings, message, tmp_path, monkeypatch,
                                                                        capsys):
    """A contact gap of 4e-17 m was accepted, and the run recorded a third "impact" at 1.1e-9 m/s while the sphere
    crept on the wall; with the default gap a last "impact" at St 0.1 (0.06 mm/s into the contact) as it settled."""
    if message is not None:
        refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r",
                *[f"--set={s}" for s in settings], message=message)
        return
    summary, _, _ = ode_run(capsys, tmp_path, *settings)
    assert summary["stop_reason"].startswith("the sphere came to rest on the wall")
    assert len(summary["impacts"]) == 4 and min(i["contact_speed"] for i in summary["impacts"]) > 1e-2


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


# -- the loss audit ---------------------------------------------------------------------------------------------------


def inside_the_first_contact(tmp_path, capsys) -> float:
    """A time [s] when case 3's sphere is inside its first Hertz contact (overlapping the wall), from a run."""
    summary, _, _ = ode_run(capsys, tmp_path / "whole", "run.bounces=1")
    rows = output.read_trajectory(tmp_path / "whole" / "run")
    overlap = rows["t"][(rows["gap"] < 0.0) & (rows["t"] < summary["impacts"][0]["time"])]
    return float(overlap[len(overlap) // 2])


@pytest.mark.parametrize("setting", ["contact.model=ehd", "run.end_time=IN_CONTACT",
                                     "numerics.ode.output_interval=0.001", "initial_gap=0.001"])
def test_the_loss_audit_is_right_or_says_why(setting, tmp_path, capsys):
    """ehd wrote no audit (the handover row sits on the contact gap: no crossing); a run ending inside the Hertz
    contact said "no impact: the sphere ended -0.0005948 D above the wall"; rows 1 ms apart gave an audit with
    imbalance 47, drawn without a word; a release inside delta_sl D had no audit and no reason."""
    if setting == "run.end_time=IN_CONTACT":
        end = inside_the_first_contact(tmp_path, capsys)
        setting = f"run.end_time={end!r}"
    summary, out, err = ode_run(capsys, tmp_path, setting)
    impacts = summary["impacts"]
    if setting == "contact.model=ehd":
        assert len(impacts) == 3 and err == []
        for impact in impacts:
            assert abs(impact["losses"]["imbalance"]) < 1e-3 and impact["losses"]["share"]["film"][1] > 1.0
    elif setting.startswith("run.end_time="):
        assert impacts == [] and summary["final"]["in_contact"]
        assert any(line.startswith("impact in progress: the run ended at t = ") and "in the contact" in line
                   for line in out), out
    elif setting == "numerics.ode.output_interval=0.001":  # the rows cannot resolve any collision: no audit, said so
        assert impacts and all("losses" not in impact and "the trajectory's rows" in impact["losses_skipped"]
                               for impact in impacts)
        assert_one_line(err, "warning: no loss audit for impact(s) 1", "numerics.ode.output_interval = 0.001 s")
        assert not (tmp_path / "run" / "losses.png").exists()
    else:
        assert "losses" not in impacts[0] and "inside delta_sl D" in impacts[0]["losses_skipped"]
        assert err == []
