"""Coefficient of restitution against impact Stokes number, the paper's way (section 5.4, Fig. 13-14).

Low Stokes numbers come from viscous liquids, not from releasing a sphere inside the lubrication
layer.  Each Table 3 material set (paper runs 1-29) is released from rest between RELEASE_GAPS = 0.5
and 7 diameters above the wall: at least half a diameter, so the sphere starts outside the layer
where the wall dominates, and below the paper's fall distances of 7.5 D, where the flow stays
axisymmetric (section 2.1), also keeping the impact Re below 250.  So each set covers a band of
impact Stokes numbers; `plan` spreads a sweep's points over the union of the bands and finds each
point's release gap with the ODE model.  Stokes numbers between the bands (about 2.5-14 here: above
the 95 % glycerol set's terminal speed, below the 85 % set's half-diameter release) cannot be reached
this way and are not swept.

e is the integrator's (sphere.Rebound): the 2 ms mean speed after the minimum gap over the 2 ms mean
before it, and 0 when the apex stays inside the contact layer (no rebound, as the experiments report it).

    fem-bounce restitution --model ode --points 40      # -> results/restitution-ode/
    fem-bounce restitution --model ode --points 40 --jobs 2     # the same, over 2 processes
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from . import scene as scenes
from .sphere import SphereIntegrator

# Table 3, runs 1-29, in the order a Stokes number is assigned to a set that reaches it
MATERIAL_SETS = (
    "li2011-table3-steel-95",    # runs 25-29, 95 % glycerol: no rebound expected (St < 10)
    "li2011-table3-steel-85",    # runs 18-24
    "li2011-table3-steel-78",    # runs 4-10
    "li2011-table3-lead-78",     # runs 11-14
    "li2011-table3-steel-65",    # runs 1-3
    "li2011-table3-dense24-78",  # run 15
    "li2011-table3-dense36-78",  # run 16
    "li2011-table3-dense48-78",  # run 17
)
DSS_PLUS_5 = "li2011-table3-steel-85-dss105"  # runs 30-35: the 85 % set with delta_ss + 5 %
RELEASE_GAPS = (0.5, 7.0)  # initial gap / D
BAND_SAMPLES = 9  # ODE runs per set that tabulate St against the release gap


def bounce_scene(scene: scenes.Scene, gap: float) -> scenes.Scene:
    """`scene` released from `gap` [m], run to the apex after the first impact, with time enough to fall
    at a tenth of the terminal speed."""
    end = 10.0 * gap / scene.terminal_speed() + 20.0 * scene.time_unit
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Re warnings are the caller's business here
        return scene.replace(**{"initial_gap": gap, "run.bounces": 1, "run.end_time": end})


def first_bounce(scene: scenes.Scene, gap: float, rebound: bool = True) -> dict:
    """ODE model from `gap` [m] to the apex after the first impact (or to the impact only)."""
    trial = bounce_scene(scene, gap)
    integrator = SphereIntegrator(trial, stop_after_impacts=0 if rebound else 1)
    integrator.advance(trial.run.end_time)
    integrator.finish()
    if not integrator.impacts:
        return {"gap": gap, "St": 0.0, "Re": 0.0, "restitution": 0.0}
    impact = integrator.impacts[0]
    result = {"gap": gap, "St": impact.St, "Re": impact.Re, "impact_speed": impact.impact_speed}
    if rebound and integrator.rebounds:
        r = integrator.rebounds[0]
        result.update(restitution=r.restitution, rebound_speed=r.rebound_speed, apex_gap=r.apex_gap,
                      peak_restitution=r.peak_restitution, rebounded=r.rebounded)
    return result


_BANDS: dict[str, tuple[np.ndarray, np.ndarray]] = {}  # stokes_band's tables, by preset


def stokes_band(name: str) -> tuple[np.ndarray, np.ndarray]:
    """(release gaps [m], impact St) of a preset over RELEASE_GAPS with the ODE model, cut where the impact
    Re passes the axisymmetric limit; St grows with the gap.  Tabulated once per process."""
    if name not in _BANDS:
        _BANDS[name] = _tabulate_band(name)
    return _BANDS[name]


def tabulate_bands(names, mapper=map) -> None:
    """Tabulate the bands of several presets at once: `mapper` (map-like) may spread them over processes."""
    missing = [name for name in dict.fromkeys(names) if name not in _BANDS]
    _BANDS.update(zip(missing, mapper(_tabulate_band, missing)))


def forget_bands() -> None:
    """Drop the tabulated bands (a benchmark that times the planning)."""
    _BANDS.clear()


def _tabulate_band(name: str) -> tuple[np.ndarray, np.ndarray]:
    scene = scenes.load(name)
    gaps = scene.sphere.diameter * np.geomspace(*RELEASE_GAPS, BAND_SAMPLES)
    found = [first_bounce(scene, gap, rebound=False) for gap in gaps]
    keep = [r["Re"] <= scenes.AXISYMMETRIC_RE_LIMIT for r in found]
    if not any(keep):
        raise scenes.SceneError(f"{name}: every release gap in {RELEASE_GAPS} D gives Re > "
                                f"{scenes.AXISYMMETRIC_RE_LIMIT:g}")
    n = keep.index(False) if False in keep else len(keep)
    return gaps[:n], np.array([r["St"] for r in found[:n]])


def gap_for_stokes(scene_name: str, stokes: float) -> float:
    """The release gap [m] at which the ODE model's first impact of the preset has Stokes number `stokes`
    (monotone cubic interpolation of the tabulated band in log-log)."""
    from scipy.interpolate import PchipInterpolator

    gaps, band = stokes_band(scene_name)
    if not band[0] * (1 - 1e-9) <= stokes <= band[-1] * (1 + 1e-9):
        raise scenes.SceneError(f"St = {stokes:g} is out of reach for {scene_name}: released from "
                                f"{RELEASE_GAPS[0]:g}-{RELEASE_GAPS[1]:g} D its first impact has St in "
                                f"[{band[0]:.3g}, {band[-1]:.3g}]")
    if len(band) == 1:
        return float(gaps[0])
    log_gap = PchipInterpolator(np.log(band), np.log(gaps))
    return float(np.exp(log_gap(math.log(stokes))))


def plan(points: int, st_range=(1.0, 1000.0), sets=MATERIAL_SETS) -> list[tuple[str, float, float]]:
    """(preset, target St, release gap [m]) for `points` Stokes numbers spread evenly in log St over the
    parts of st_range that the sets reach; each goes to the first set (in `sets` order) that reaches it."""
    bands = {name: stokes_band(name)[1] for name in sets}
    pieces = _union([(max(b[0], st_range[0]), min(b[-1], st_range[1])) for b in bands.values()])
    pieces = [(lo, hi) for lo, hi in pieces if hi >= lo]
    lengths = [math.log(hi / lo) for lo, hi in pieces]
    total = sum(lengths)
    chosen = []
    for k in range(points):
        s = total * k / max(points - 1, 1)  # position along the concatenated log-intervals
        for (lo, hi), length in zip(pieces, lengths):
            if s <= length + 1e-12:
                stokes = lo * math.exp(min(s, length))
                break
            s -= length
        name = next(n for n in sets if bands[n][0] * (1 - 1e-9) <= stokes <= bands[n][-1] * (1 + 1e-9))
        chosen.append((name, stokes, gap_for_stokes(name, stokes)))
    return chosen


def _union(intervals: list[tuple[float, float]]) -> list[tuple[float, float]]:
    merged: list[list[float]] = []
    for lo, hi in sorted(intervals):
        if merged and lo <= merged[-1][1]:
            merged[-1][1] = max(merged[-1][1], hi)
        else:
            merged.append([lo, hi])
    return [(lo, hi) for lo, hi in merged]


def sweep(points: int, st_range=(1.0, 1000.0), mapper=map) -> list[dict]:
    """The ODE model at each planned release gap, to its first apex (a fraction of a second each).  The runs
    are independent: `mapper` (map-like, e.g. fem_bounce.studies.runner.Runner.map) may spread the band
    tabulation and the sweep's runs over processes; the builtin map runs them one after the other."""
    tabulate_bands(MATERIAL_SETS, mapper)
    planned = plan(points, st_range)
    found = mapper(_first_bounce_of, [name for name, _, _ in planned], [gap for _, _, gap in planned])
    return [{"scene": name, "target_St": st, **result} for (name, st, _), result in zip(planned, found)]


def _first_bounce_of(name: str, gap: float) -> dict:
    return first_bounce(scenes.load(name), gap)
