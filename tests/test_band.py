"""Predictions with bands (fem_bounce.uncertain, fem_bounce.studies.band): the ranges and their refusals, a seeded
design that repeats, the percentiles and indices of a linear response whose answer is known, and a band study that
is interrupted and resumed from the cache (the ode model on case 3 cut short: a fraction of a second a run)."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from mpi4py import MPI
from scipy.stats import truncnorm

from fem_bounce import cache, cli, uncertain
from fem_bounce import scene as scenes
from fem_bounce.errors import RunInterrupted
from fem_bounce.studies import band, runner as study_runner
from fem_bounce.studies.runner import Runner

CASE3 = scenes.load("li2011-case3")
SHORT = {"run.end_time": 0.075, "run.bounces": 1}  # the first impact at 0.069 s, no more


def one(text: str, scene: scenes.Scene = CASE3) -> uncertain.Range:
    key, spec = uncertain.parse_vary(text)
    return uncertain.parse(key, spec, scene)


# -- ranges ---------------------------------------------------------------------------------------


def test_each_syntax_gives_its_distribution():
    uniform = one("contact.dry_restitution=0.90:0.97")
    assert (uniform.distribution, uniform.low, uniform.high) == ("uniform", 0.90, 0.97)
    assert uniform.value(0.5) == pytest.approx(0.935)
    log = one("sphere.roughness=1e-8:1e-6:log")
    assert log.distribution == "log-uniform" and log.value(0.5) == pytest.approx(1e-7)
    negative = one("contact.cavitation_pressure=-1e6:-1e5:log")  # log-uniform in the magnitude
    assert negative.value(0.5) == pytest.approx(-math_sqrt(1e6 * 1e5))
    normal = one("liquid.viscosity=0.05~0.002")
    assert (normal.mean, normal.sd) == (0.05, 0.002) and normal.value(0.5) == pytest.approx(0.05)
    assert normal.bounds == pytest.approx((0.044, 0.056))  # cut at 3 standard deviations
    relative = one("liquid.viscosity=+-7%")
    assert (relative.low, relative.high) == pytest.approx((0.0502 * 0.93, 0.0502 * 1.07))
    spread = one("liquid.viscosity=~5%")
    assert (spread.mean, spread.sd) == pytest.approx((0.0502, 0.0502 * 0.05))
    assert one("liquid.viscosity=0.05~4%").sd == pytest.approx(0.002)


def math_sqrt(x: float) -> float:
    return float(np.sqrt(x))


@pytest.mark.parametrize("text, words", [
    ("contact.dry_restitution=0.9:1.2", ["contact.dry_restitution", "[0.9, 1.2]", "in [0, 1]"]),
    ("liquid.viscosity=~40%", ["liquid.viscosity", "3 standard deviations", "in (0, 1e+08]"]),
    ("contact.cavitation_pressure=-1e9:-1e5", ["contact.cavitation_pressure", "in [-1e+08, 0]"]),
    ("sphere.densty=7000:8000", ["unknown setting sphere.densty", "sphere.density"]),
    ("run.bounces=1:3", ["run.bounces", "whole number"]),
    ("contact.model=1:2", ["contact.model", "cannot be varied"]),
    ("sphere=1:2", ["sphere is a table"]),
    ("sphere.roughness=0:1e-6:log", ["one sign"]),
    ("contact.dry_restitution=0.97:0.9", ["LOW must be below HIGH"]),
    ("contact.dry_restitution=0.9..0.97", ["cannot read the range", "LOW:HIGH"]),
    ("liquid.viscosity=0.05~0", ["standard deviation must be > 0"]),
    ("contact.dry_restitution", ["expected KEY=RANGE"]),
])
def test_a_bad_range_is_refused_naming_the_setting(text, words):
    with pytest.raises(scenes.SceneError) as refused:
        uncertain.ranges_for(CASE3, [text], defaults=False)
    for word in words:
        assert word in str(refused.value)


def test_a_relative_range_needs_a_value_to_be_relative_to():
    with pytest.raises(scenes.SceneError, match="relative to the scene's value"):
        one("sphere.roughness=+-10%", CASE3.replace(**{"sphere.roughness": 0.0}))


def test_the_defaults_have_sources_and_follow_the_scene():
    defaults = uncertain.ranges_for(CASE3)
    keys = [r.key for r in defaults]
    assert {"contact.dry_restitution", "liquid.viscosity", "sphere.roughness", "contact.cavitation_pressure",
            "sphere.youngs_modulus", "wall.youngs_modulus"} <= set(keys)
    assert all(r.source for r in defaults)
    assert next(r for r in defaults if r.key == "contact.dry_restitution").bounds == (0.90, 0.97)
    paper = uncertain.ranges_for(scenes.load("li2011-case3", {"contact.model": "li2011"}))
    assert "sphere.roughness" not in [r.key for r in paper]  # roughness sets only lubricated-hertz's contact gap
    # --vary replaces a default's range and adds a setting
    chosen = uncertain.ranges_for(CASE3, ["contact.dry_restitution=0.8:0.9", "sphere.density=7700:7800"])
    assert next(r for r in chosen if r.key == "contact.dry_restitution").bounds == (0.8, 0.9)
    assert [r.key for r in chosen][-1] == "sphere.density" and len(chosen) == len(defaults) + 1
    assert [r.key for r in uncertain.ranges_for(CASE3, ["sphere.density=7700:7800"], defaults=False)] == \
        ["sphere.density"]


def test_a_scene_file_carries_its_uncertain_table(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(scenes.dumps(CASE3) + '\n[uncertain]\n"contact.dry_restitution" = "0.92:0.96"\n'
                    '"liquid.viscosity" = { range = "+-3%", source = "a thermostat at +-0.4 K" }\n')
    assert scenes.load(path) == scenes.load(path)  # a run takes the values and ignores the table
    table = uncertain.scene_table(path)
    ranges = uncertain.ranges_for(scenes.load(path), (), table)
    assert [r.key for r in ranges] == ["contact.dry_restitution", "liquid.viscosity"]
    assert ranges[1].source == "a thermostat at +-0.4 K"
    path.write_text(scenes.dumps(CASE3) + '\n[uncertain]\n"contact.dry_restitution" = "0.92:1.5"\n')
    with pytest.raises(scenes.SceneError, match=r"\[uncertain\] contact.dry_restitution.*in \[0, 1\]"):
        uncertain.ranges_for(scenes.load(path), (), uncertain.scene_table(path), where=f"{path} [uncertain]")


# -- the design, percentiles and indices --------------------------------------------------------------


def test_a_seeded_design_repeats():
    for method, samples in (("sobol", 16), ("lhs", 10), ("saltelli", 8 * 5)):
        first, again = band.design(3, samples, method, seed=7), band.design(3, samples, method, seed=7)
        assert first.shape == (samples, 3) and np.array_equal(first, again)
        assert not np.array_equal(first, band.design(3, samples, method, seed=8))
        assert ((first >= 0.0) & (first < 1.0)).all()
    points, trials = band.plan(CASE3, uncertain.ranges_for(CASE3), 8, seed=3)
    _, again = band.plan(CASE3, uncertain.ranges_for(CASE3), 8, seed=3)
    assert trials == again and len({t.name for t in trials}) == 8


def test_a_design_that_cannot_be_balanced_is_refused():
    with pytest.raises(scenes.SceneError, match="powers of two.*--design lhs"):
        band.check_design("sobol", 48, 3)
    with pytest.raises(scenes.SceneError, match="N x 5"):
        band.check_design("saltelli", 48, 3)
    with pytest.raises(scenes.SceneError, match="--design"):
        band.check_design("random", 16, 3)


def test_percentiles_of_a_linear_response():
    """Y = 2 + 3 u0 - u1 over uniform inputs: Y's percentiles are known (a triangle-trapezoid convolution), here the
    5/50/95 % of 3 u0 - u1 by the exact CDF; and the range of a setting maps the design's percentiles through."""
    points = band.design(2, 4096, "sobol", seed=1)
    found = band.percentiles(2.0 + 3.0 * points[:, 0] - points[:, 1])

    def cdf(y):  # P(3 u0 - u1 <= y) = E over u1 of P(u0 <= (y + u1) / 3)
        u1 = np.linspace(0.0, 1.0, 20001)
        return np.mean(np.clip((y + u1) / 3.0, 0.0, 1.0))

    for level, key in ((0.05, "p5"), (0.5, "p50"), (0.95, "p95")):
        assert cdf(found[key] - 2.0) == pytest.approx(level, abs=2e-3)
    viscosity = one("liquid.viscosity=0.04:0.06")
    values = [viscosity.value(u) for u in points[:, 0]]
    assert [band.percentiles(values)[k] for k in ("p5", "p50", "p95")] == pytest.approx([0.041, 0.05, 0.059], abs=2e-5)
    normal = one("liquid.viscosity=0.05~0.002")
    values = [normal.value(u) for u in points[:, 1]]
    exact = truncnorm.ppf([0.05, 0.5, 0.95], -3, 3, loc=0.05, scale=0.002)
    assert [band.percentiles(values)[k] for k in ("p5", "p50", "p95")] == pytest.approx(exact, abs=2e-5)
    assert band.percentiles([None, float("nan")]) is None


def test_indices_of_a_linear_response():
    """Y = u0 + 0.5 u1 + 0 u2: first-order indices 0.8, 0.2, 0 (b_i^2 / sum b_j^2 for equal variances)."""
    points = band.design(3, 1024, "sobol", seed=2)
    found = band.indices(points, points[:, 0] + 0.5 * points[:, 1], ["a", "b", "c"])
    assert found["S1"] == pytest.approx([0.8, 0.2, 0.0], abs=0.05)  # the binned estimator, 6 classes: a few % low
    assert band.widest_interval(found) < band.CI_LIMIT and band.leading(found, ["a", "b", "c"]) == "a"
    saltelli = band.design(3, 256 * 5, "saltelli", seed=2)
    found = band.indices(saltelli, saltelli[:, 0] + 0.5 * saltelli[:, 1], ["a", "b", "c"], "saltelli")
    assert found["S1"] == pytest.approx([0.8, 0.2, 0.0], abs=0.05)
    assert found["ST"] == pytest.approx([0.8, 0.2, 0.0], abs=0.05)  # additive: total = first order
    assert "skipped" in band.indices(points, np.ones(1024), ["a", "b", "c"])
    few = band.design(3, 16, "sobol", seed=2)
    wide = band.indices(few, few[:, 0] + 0.5 * few[:, 1], ["a", "b", "c"])
    assert band.widest_interval(wide) > band.CI_LIMIT  # 16 samples: the study warns
    assert band.samples_for(16, band.widest_interval(wide)) > 16


def test_the_trajectory_band_of_linear_paths():
    """Paths gap = a t, a = 1..9 (9 runs), each to its own end: the percentiles at t are those of a t."""
    paths = [{"t": np.array([0.0, 1.0 + 0.1 * a]), "gap": np.array([0.0, a * (1.0 + 0.1 * a)]),
              "velocity": np.array([a, a])} for a in range(1, 10)]
    found = band.trajectory_band(paths, points=21)
    assert found["t"][-1] == pytest.approx(1.9)
    at_one = np.searchsorted(found["t"], 1.0 - 1e-12)
    assert found["gap_p50"][at_one] == pytest.approx(5.0 * found["t"][at_one])
    assert found["velocity_p5"][at_one] == pytest.approx(np.percentile(np.arange(1, 10), 5))
    assert found["runs"][0] == 9 and found["runs"][-1] == 1  # only the longest run reaches its end


# -- a band study, interrupted and resumed ------------------------------------------------------------


def test_a_band_study_resumes_from_the_cache(tmp_path, monkeypatch):
    scene = CASE3.replace(**SHORT)
    ranges = uncertain.ranges_for(scene, ["liquid.viscosity=+-7%", "contact.dry_restitution=0.90:0.97"],
                                  defaults=False)
    made = []
    real_simulate, real_cached_run = cache.simulate, study_runner.cached_run

    def counted(*args, **kwargs):
        made.append(args[0].name)
        return real_simulate(*args, **kwargs)

    def interrupted_after_two(*args, **kwargs):
        if len(made) == 2:
            raise RunInterrupted("interrupted by SIGINT", 2)
        return real_cached_run(*args, **kwargs)

    monkeypatch.setattr(cache, "simulate", counted)
    monkeypatch.setattr(study_runner, "cached_run", interrupted_after_two)
    root = tmp_path / "cache"
    with pytest.raises(RunInterrupted):
        band.run(scene, "ode", MPI.COMM_SELF, tmp_path / "first", ranges, 4, runner=Runner(MPI.COMM_SELF, root=root))
    assert len(made) == 2
    monkeypatch.setattr(study_runner, "cached_run", real_cached_run)
    result, rows = band.run(scene, "ode", MPI.COMM_SELF, tmp_path / "band", ranges, 4,
                            runner=Runner(MPI.COMM_SELF, root=root))
    assert len(made) == 4  # the two finished samples came from the cache, the other two ran
    assert result["completed"] == 4 and [r["sample"] for r in rows] == [0, 1, 2, 3]
    speeds = [r["impact_speed_1"] for r in rows]
    assert result["quantities"]["impact_speed_1"]["p50"] == pytest.approx(np.percentile(speeds, 50))
    assert result["measured"]["impact_speed_1"]["measured"] == 0.393
    written = json.loads((tmp_path / "band" / "band.json").read_text())
    assert written["samples"] == 4 and written["ranges"][0]["key"] == "liquid.viscosity"
    with open(tmp_path / "band" / "samples.csv") as stream:
        table = list(csv.DictReader(stream))
    assert [float(r["liquid.viscosity"]) for r in table] == pytest.approx([r["liquid.viscosity"] for r in rows])
    for name in ("band_trajectory.csv", "band_trajectory.png", "sensitivity.png"):
        assert (tmp_path / "band" / name).stat().st_size > 0
    again, _ = band.run(scene, "ode", MPI.COMM_SELF, tmp_path / "again", ranges, 4,
                        runner=Runner(MPI.COMM_SELF, root=root))
    assert len(made) == 4 and again["quantities"] == result["quantities"]  # all from the cache, the same band


def test_the_command_refuses_a_bad_range_before_running(tmp_path, capsys):
    code = cli.main(["study", "band", "li2011-case3", "--model", "ode", "--samples", "4", "--out", str(tmp_path / "b"),
                     "--vary", "contact.dry_restitution=0.9:1.1"])
    assert code == 2 and "contact.dry_restitution" in capsys.readouterr().err
    assert not (tmp_path / "b").exists()
