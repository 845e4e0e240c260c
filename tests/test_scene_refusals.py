"""Scenes a run refuses before it writes anything, and the values near the edges that are physical and run: a scene
file that is not a scene, a value outside physics or one that broke a run, a prescribed motion's series that cannot
be followed.  Each refusal asserts the exit status, the one line naming the field (its allowed range, its numbers)
and that nothing was written.  The ODE model in this process wherever the finding is not model-specific."""
import os
import tomllib
from pathlib import Path

import pytest

import fem_bounce as fb
from fem_bounce import cli
from fem_bounce import scene as scenes
from helpers import FD_TOY, ODE, assert_one_line, refused, refused_same_listing, run_cli

PRESET = Path(__file__).resolve().parents[1] / "fem_bounce" / "presets" / "li2011-case3.toml"


# -- scene files that are not scenes ----------------------------------------------------------------------------------


def _write(path: Path, kind: str) -> None:
    if kind == "random bytes":
        path.write_bytes(bytes(range(128, 256)) * 2)
    elif kind == "utf-16":
        path.write_bytes('name = "x"\n'.encode("utf-16"))
    elif kind == "nested 100000 deep":
        path.write_text("a = " + "[" * 100_000 + "]" * 100_000 + "\n")
    elif kind == "fifo":
        os.mkfifo(path)
    elif kind == "directory":
        path.mkdir()
    elif kind == "dangling symlink":
        path.symlink_to(path.parent / "nothing-here.toml")


@pytest.mark.parametrize("kind,message", [
    ("random bytes", "is not UTF-8 text"),
    ("utf-16", "is not UTF-8 text"),
    ("nested 100000 deep", "nested too deeply to read"),
    ("fifo", "is not a regular file"),
    ("directory", "is not a regular file"),
    ("dangling symlink", "does not exist (a symbolic link to a missing file)"),
])
def test_scene_file_that_is_not_a_scene_gives_one_line(kind, message, tmp_path, monkeypatch, capsys):
    """UnicodeDecodeError, RecursionError, a FIFO or directory 'does not exist', a dangling link."""
    source = tmp_path / "x.toml"
    _write(source, kind)
    refused_same_listing(capsys, tmp_path, monkeypatch, "run", "x.toml", *ODE, "--out", "r", message=message)


def test_byte_order_mark_is_accepted(tmp_path, monkeypatch, capsys):
    """A UTF-8 file saved with a BOM said 'Invalid statement (at line 1, column 1)'."""
    (tmp_path / "bom.toml").write_bytes(b"\xef\xbb\xbf" + PRESET.read_bytes())
    monkeypatch.chdir(tmp_path)
    status, _ = run_cli(capsys, "run", "bom.toml", *ODE, "--set", "run.bounces=1", "--out", "r")
    assert status == 0 and (tmp_path / "r" / "summary.json").is_file()


# -- scene text -------------------------------------------------------------------------------------------------------


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


# -- values outside physics -------------------------------------------------------------------------------------------


@pytest.mark.parametrize("override,message", [
    ("gravity=0", "gravity = 0 moves nothing: allowed only for a free sphere launched by initial_velocity != 0 "
                  "or a pair set in motion by second_sphere.velocity"),
    ("contact.delta_sl=1e9", "contact.delta_sl = 1000000000.0 is out of range: allowed in (0, 0.5] (the gap, in "
                             "diameters, below which the contact model supplies the near-wall force)"),
    ("initial_gap=1e300", "initial_gap = 1e+300 m is 1.05e+302 diameters: allowed up to 1e+10 D"),
    ("sphere.poisson_ratio=-1", "sphere.poisson_ratio = -1.0 is out of range: allowed in (-1, 0.5)"),
    ("run.bounces=2.5", "run.bounces = 2.5 must be an integer"),
    ("name=../../x", "name = '../../x' must be a plain name"),
    ("sphere.density=1203", "sphere.density = 1203 kg/m3 equals liquid.density: a neutrally buoyant sphere"),
    ("sphere.density=1203.0001", "so nearly neutrally buoyant a sphere barely moves"),
])
def test_scene_values_outside_physics_are_refused(override, message, tmp_path, monkeypatch, capsys):
    """gravity = 0 ended in ZeroDivisionError; delta_sl = 1e9 (switching the resolved force off) and
    initial_gap = 1e300 (overflow, 300-digit numbers) ran; bounces = 2.5 said 'must be a number'; a
    name with '../' wrote the run outside runs/; a neutrally buoyant sphere crawled for ever."""
    monkeypatch.chdir(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--set", override)
    assert status == 2
    assert_one_line(lines, "error: ", message)
    assert list(tmp_path.iterdir()) == []


def test_negative_poisson_ratio_is_physical(tmp_path, capsys):
    """sphere.poisson_ratio = -0.5 was refused, although (-1, 0.5) is an isotropic solid's range."""
    status, lines = run_cli(capsys, "run", "li2011-case3", *ODE, "--set", "sphere.poisson_ratio=-0.5",
                            "--set", "run.end_time=0.01", "--out", str(tmp_path / "run"))
    assert status == 0 and lines == []


@pytest.mark.parametrize("model", ["ode", "fd", "ib", "ale"])
def test_neutral_sphere_is_refused_alike_by_every_model(model, tmp_path, monkeypatch, capsys):
    """It hung the ODE model (6,815 steps for 0.1 ms, 100 kB/s of rows) and the ib model; fd and ale
    refused it from inside the model."""
    monkeypatch.chdir(tmp_path)
    status, lines = run_cli(capsys, "run", "li2011-case3", "--model", model, "--quiet", "--set", "sphere.density=1203")
    assert status == 2
    assert_one_line(lines, "error: sphere.density = 1203 kg/m3 equals liquid.density")
    assert list(tmp_path.iterdir()) == []


# -- values that overflowed, hung or crashed a run --------------------------------------------------------------------


@pytest.mark.parametrize("override,message", [
    ("liquid.viscosity=1e20", "liquid.viscosity = 1e+20 Pa s is out of range: allowed in (0, 1e+08] Pa s (pitch"),
    ("sphere.diameter=1e300", "sphere.diameter = 1e+300 m is out of range: allowed in [1e-06, 1000] m"),
    ("sphere.diameter=1e-10", "sphere.diameter = 1e-10 m is out of range"),
    ("sphere.density=1e300", "sphere.density = 1e+300 kg/m3 is out of range: allowed in (0, 100000] kg/m3"),
    ("liquid.density=1e-300", "liquid.density = 1e-300 kg/m3 is out of range: allowed in [1e-30, 100000]"),
    ("sphere.youngs_modulus=1e300", "sphere.youngs_modulus = 1e+300 Pa is out of range"),
    ("contact.history_c1=1e-3", "contact.history_c1 = 0.001 is out of range: allowed in [0.1, 100] (Mei & Adrian"),
    ("contact.history_c1=1e6", "contact.history_c1 = 1000000.0 is out of range"),
    ("reference.velocity_curve=nope", "reference.velocity_curve = 'nope' is not one of the package's velocity curves: "
                                      "'tencate2002_E4'"),
])
def test_values_that_broke_a_run_are_refused(override, message, tmp_path, monkeypatch, capsys):
    """viscosity 1e20 printed a warning a step for ever; diameters and densities of 1e300 overflowed;
    history_c1 1e-3 / 1e6 failed in scipy's nnls; an unknown velocity curve failed after the run."""
    refused_same_listing(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r", "--set", override,
                         message=message)


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


def test_start_inside_contact_names_the_numbers(tmp_path, monkeypatch, capsys):
    """initial_gap = 1e-300 said it "must exceed contact.delta_ss * sphere.diameter" without the numbers."""
    refused_same_listing(
        capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r", "--set", "initial_gap=1e-300",
        message="initial_gap = 1e-300 m is out of range: allowed > sphere.roughness + wall.roughness = 4e-08 m")


@pytest.mark.parametrize("argv,message", [
    (["yang-hunt2006-pair", "--set", "second_sphere.gap=1e300"], "second_sphere.gap = 1e+300 m is 7.87e+301 diameters"),
    (["yang-hunt2006-pair", "--set", "run.bounces=0", "--set", "run.end_time=1e300"],
     "allowed up to 100000 of them, 4233 s, for a scene that nothing ends earlier"),
])
def test_lengths_and_times_that_never_end_are_refused(argv, message, tmp_path, monkeypatch, capsys):
    """A pair without a wall given run.end_time = 1e300 drifted on for ever; a gap of 1e300 m overflowed."""
    refused(capsys, tmp_path, monkeypatch, "run", *argv, *ODE, "--out", "r", message=message)


@pytest.mark.parametrize("override", ["second_sphere.diameter=1e300", "second_sphere.diameter=1e-300"])
def test_pair_sizes_that_crashed_are_refused(override, tmp_path, monkeypatch, capsys):
    """OverflowError and LinAlgError (leaving r/ behind)."""
    refused_same_listing(
        capsys, tmp_path, monkeypatch, "run", "yang-hunt2006-pair", *ODE, "--out", "r", "--set", override,
        message="second_sphere.diameter = ")


def test_a_container_that_is_not_a_table_names_the_alternative(tmp_path, monkeypatch, capsys):
    """container = "boxed" said "must be a table" without naming its keys or "unbounded"."""
    refused_same_listing(
        capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r", "--set", 'container="boxed"',
        message="container = 'boxed' must be a table of radius, height (leave [container] out for an unbounded")


@pytest.mark.parametrize("value,message", [
    ("nan", "contact.cavitation_pressure = nan Pa is out of range"),
    ("abc", "contact.cavitation_pressure = 'abc' is not a choice nor a pressure"),
])
def test_cavitation_is_checked_whatever_the_contact_model(value, message, tmp_path, monkeypatch, capsys):
    """contact.ehd_cavitation (now cavitation_pressure) = nan or abc was accepted with lubricated-hertz, then a
    ValueError writing scene.toml or building the contact."""
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r",
            "--set", f"contact.cavitation_pressure={value}", message=message)


PEAK_CFL = ("numerics.{model}.cfl is now numerics.{model}.peak_cfl, the same number: the Courant number at the peak "
            "fluid speed 1.5 U (numerics.ale.cfl and numerics.ib.cfl are at the speed scale U)")


@pytest.mark.parametrize("model", ["fd", "fd3d"])
def test_the_fd_models_old_cfl_is_refused_naming_peak_cfl(model, tmp_path, monkeypatch, capsys):
    """numerics.fd.cfl and numerics.fd3d.cfl meant dt = cfl h / (1.5 U), numerics.ale.cfl and numerics.ib.cfl
    dt = cfl h / U: one name, two meanings.  The fd models' key is peak_cfl now; the old one, on the command line or
    in a scene file, is refused with one line naming the new key (the same number), whichever model runs."""
    message = PEAK_CFL.format(model=model)
    refused(capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r",
            "--set", f"numerics.{model}.cfl=0.4", message=message)
    old = tmp_path / "old.toml"
    old.write_text(PRESET.read_text() + f"\n[numerics.{model}]\ncfl = 0.4\n")
    refused(capsys, tmp_path, monkeypatch, "run", str(old), *ODE, "--out", "r", message=message)
    with pytest.raises(fb.SceneError) as refusal:
        scenes.load("li2011-case3").replace(**{f"numerics.{model}.cfl": 0.4})
    assert str(refusal.value) == message


@pytest.mark.parametrize("model, settings, peak_cfl", [
    ("fd", {"numerics.fd.peak_cfl": 0.3}, 0.3),
    ("fd", {}, 0.8),  # unset: the moving mesh's own
    ("fd", {"numerics.fd.mesh": "fixed"}, 0.4),  # the fixed mesh's
    ("fd", {"numerics.fd.mesh": "fixed", "numerics.fd.constraint": "penalty"}, 0.2),  # the one-shot penalty's
    ("fd3d", {}, 0.4),
    ("fd3d", {"numerics.fd3d.peak_cfl": 0.3}, 0.3),
])
def test_peak_cfl_gives_the_step_cfl_gave(model, settings, peak_cfl):
    """numerics.fd.peak_cfl and numerics.fd3d.peak_cfl are the old cfl renamed, not rescaled: the step is
    dt = peak_cfl h / (1.5 U), h the fine size D / cells_per_diameter and U the speed scale, to round-off (the
    penalty's also at most forcing_number h^2 / nu)."""
    from mpi4py import MPI

    from fem_bounce.fem.domain import speed_scale
    from fem_bounce.models.fd.domain import time_step
    from fem_bounce.models.fd3d.model import FictitiousDomain3DModel

    sc = scenes.load("li2011-case3", settings)
    table = getattr(sc.numerics, model)
    fine = sc.sphere.diameter / table.cells_per_diameter
    expected = peak_cfl * fine / (1.5 * speed_scale(sc, model))
    if model == "fd":
        if table.constraint == "penalty":
            expected = min(expected, table.forcing_number * fine**2 / sc.liquid.kinematic_viscosity)
        assert time_step(sc) == pytest.approx(expected, rel=1e-14)
    else:
        assert FictitiousDomain3DModel(sc, MPI.COMM_SELF).cfl_step == pytest.approx(expected, rel=1e-14)


# -- prescribed motion ------------------------------------------------------------------------------------------------


@pytest.mark.parametrize("content,message", [
    (b"", "has 0 row(s); a series needs at least 2"),
    (bytes(range(128, 256)), "cannot be read as UTF-8 text"),
    (b"t,velocity\n0,0.1\n", "has 1 row(s)"),
    (b"t,velocity\n0,0\n0.2,-0.1\n0.1,-0.1\n", "the times t must increase"),
    (b"t,velocity\n0,0\n0.1,nan\n", "holds a value that is not finite"),
    (b"t,velocity\n0.5,0\n1,-0.1\n", "starts at t = 0.5 s; it must cover the start of the run, t = 0"),
    (b"time,speed\n0,0\n1,1\n", "needs a header t,velocity"),
])
def test_bad_series_is_refused_before_the_run(content, message, tmp_path, monkeypatch, capsys):
    (tmp_path / "series.csv").write_bytes(content)
    refused_same_listing(
        capsys, tmp_path, monkeypatch, "run", "li2011-case3", *ODE, "--out", "r", "--set", "motion.mode=prescribed",
        "--set", "motion.series=series.csv", message=f"motion.series = 'series.csv': {message}")
