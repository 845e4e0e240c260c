"""Scenes: presets, round trips, overrides and the errors a user can cause."""
import re
import tomllib
import warnings

import pytest

from fem_bounce import scene


@pytest.mark.parametrize("name", scene.preset_names())
def test_every_preset_round_trips_through_toml(name):
    loaded = scene.load(name)
    assert scene.from_dict(tomllib.loads(scene.dumps(loaded))) == loaded


def test_table2_cases_carry_their_reference_values():
    case = scene.load("li2011-case3")
    assert case.initial_gap == 0.0152 and case.reference.impact_speed == 0.393
    assert case.reference.re_first == 90 and case.reference.re_second == 55
    assert case.density_ratio == pytest.approx(7780 / 1203)


def test_derived_groups():
    case = scene.load("li2011-case3")
    assert case.reynolds(0.393) == pytest.approx(1203 * 0.0095 * 0.393 / 0.0502)
    assert case.stokes(0.393) == pytest.approx(case.density_ratio * case.reynolds(0.393) / 9)
    assert case.time_unit == pytest.approx((0.0095 / 9.81) ** 0.5)


def test_overrides_and_files(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(scene.dumps(scene.load("li2011-case1")))
    mine = scene.load(path, {"sphere.density": 8000})
    assert mine.sphere.density == 8000.0 and mine.name == "li2011-case1"
    assert scene.parse_override("contact.wall_drag=simple") == ("contact.wall_drag", "simple")
    assert scene.parse_override("run.bounces=2") == ("run.bounces", 2)
    # boolean settings take TOML booleans
    assert scene.load("brenner-approach", {"numerics.fd.steady_stokes": True}).numerics.fd.steady_stokes is True


@pytest.mark.parametrize("override,message", [
    ({"sphere.densty": 1.0}, "did you mean sphere.density"),
    ({"liquid.viscosity": -1.0}, "liquid.viscosity = -1.0 Pa s is out of range: allowed in (0, 1e+08] Pa s"),
    ({"liquid.density": 0.0}, "liquid.density = 0.0 kg/m3 is out of range"),
    ({"initial_gap": 0.0}, "initial_gap = 0.0 m is out of range"),
    ({"contact.delta_ss": 0.3}, "must be smaller than contact.delta_sl"),
    ({"contact.wall_drag": "exact"}, "contact.wall_drag = 'exact' is not one of 'brenner', 'simple'"),
    ({"sphere.poisson_ratio": 0.5}, "sphere.poisson_ratio = 0.5 is out of range: allowed in (-1, 0.5)"),
    ({"container.radius": 0.1}, "container needs both radius and height"),
    ({"run.bounces": "two"}, "run.bounces = 'two' must be an integer"),
    ({"run.bounces": True}, "run.bounces = True must be an integer"),
    ({"numerics.fd.steady_stokes": 1}, "numerics.fd.steady_stokes = 1 must be true or false"),
])
def test_bad_values_name_the_field_and_range(override, message):
    with pytest.raises(scene.SceneError, match=re.escape(message)):
        scene.load("li2011-case3", override)


def test_unknown_preset_suggests_the_nearest():
    with pytest.raises(scene.SceneError, match="did you mean li2011-case3"):
        scene.load("li2011-case33")


def test_reynolds_beyond_the_axisymmetric_range_warns():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        scene.load("li2011-case3", {"liquid.viscosity": 0.005})
    assert any("axisymmetric" in str(w.message) for w in caught)
