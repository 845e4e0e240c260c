"""Coefficient of restitution against impact Stokes number: where each point of a sweep starts.

Joseph et al. (2001) measured e(St) with spheres launched at a wall on a pendulum: the collision is
horizontal, so gravity plays no part along the line of approach and a rebound of any size is seen.  The
sweep does the same: each Table 3 material set (paper runs 1-29) has gravity switched off along the
axis and is launched at the wall from LAUNCH_GAP = 2 diameters (outside the lubrication layer, never
inside it) at an initial speed; the liquid slows it on the way, as on the pendulum.  The launch speeds
LAUNCH_SPEEDS = 0.02-10 m/s give each set a band of impact Stokes numbers, cut where the impact Re
passes the axisymmetric limit (section 2.1).  `plan` puts a point every factor LOW_ST_RATIO = 1.3
between St 3 and 30, where e rises from 0, spreads the sweep's other points evenly in log St, and
assigns each to the set whose band holds it most centrally; the ODE model finds its launch speed.  The
bands are those of the scenes the sweep runs: the presets with the sweep's --set values (all but other
models' numerics), so that a run's target St is the one the ODE model measures on it; a target no set reaches
is dropped with a warning that names the reachable range.  A band also ends at the fastest launch whose scene
the checks admit: with contact.model = "ehd" the handover gap must hold 10 elastohydrodynamic gaps at the
launch speed, which the most viscous sets pass only up to a few m/s; such a cut is warned of, naming the set,
the launch and the check, and its Stokes numbers go to another set (or are dropped).

The speeds that define e and St are taken where the gap passes delta_sl = 0.2 D, on the way in and on
the way out (`crossing_speeds`): just before the wall's film slows the sphere and just after it has let
it go, what the pendulum's camera sees (the pair's collisions use the same gap, 0.2 x 2a*).  e = V_out /
V_in, 0 when the sphere does not come back out through 0.2 D (it stalls in the film or rests in the
contact); St = rho_p V_in D / (9 mu).  The 2 ms means of Table 2 are not used here: a sphere the film
slows to a crawl before it touches has a 2 ms impact speed near zero, whatever it arrived with.

    fem-bounce restitution --model ode      # -> results/restitution-ode/
    fem-bounce restitution --model ode --jobs 2     # the same, over 2 processes
"""
from __future__ import annotations

import math
import warnings

import numpy as np

from .. import scene as scenes
from ..integrator import BodyIntegrator
from ..progress import stop_requested

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
DSS_PLUS_5 = "li2011-table3-steel-85-dss105"  # runs 30-35: the 85 % set with delta_ss + 5 % (li2011 only)
BAND_SAMPLES = 14  # ODE runs per set that tabulate St against the launch speed
LAUNCH_GAP = 2.0  # D: where the sphere is launched, outside the lubrication layer
LAUNCH_SPEEDS = (0.02, 10.0)  # m/s, toward the wall
LOW_ST = (3.0, 30.0)  # where e rises from 0: a point every factor LOW_ST_RATIO
LOW_ST_RATIO = 1.3
PLANNED_KEYS = ("initial_gap", "initial_velocity", "gravity", "run.bounces", "run.end_time")


def bounce_scene(scene: scenes.Scene, launch: float) -> scenes.Scene:
    """`scene` launched at `launch` [m/s] toward the wall from LAUNCH_GAP without gravity, run to the end of
    the first rebound (its gap passing delta_sl outward) or until it stalls in the film, with time enough
    to arrive at a tenth of the launch speed and leave at a tenth of that."""
    gap = LAUNCH_GAP * scene.sphere.diameter
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Re warnings are the caller's business here
        return scene.replace(**{"initial_gap": gap, "initial_velocity": -launch, "gravity": 0.0,
                                "run.bounces": 1, "run.end_time": 100.0 * gap / launch})


def check_overrides(overrides: dict | None) -> None:
    """A sweep plans where each run starts and when it ends: a --set of those would defeat the plan.  Every
    set's scene with the --set values is checked here, before the planning's runs (a bad key or value: one
    line at once)."""
    for key in overrides or {}:
        if key in PLANNED_KEYS:
            raise scenes.SceneError(f"--set {key}: the restitution sweep sets {key} for each run itself (a launch "
                                    "speed per Stokes number); run one scene with `fem-bounce run` instead")
    for name in (*MATERIAL_SETS, DSS_PLUS_5):
        try:
            scene = scenes.load(name, overrides)
        except scenes.SceneError as err:  # say which of the sweep's scenes it was
            raise scenes.SceneError(f"the sweep's scene {name} with the --set values: {err}") from None
        try:
            bounce_scene(scene, LAUNCH_SPEEDS[0])
        except scenes.SceneError as err:  # a check of the launched scene: say which set and launch it was
            raise scenes.SceneError(f"{launched(name, LAUNCH_SPEEDS[0])}, the sweep's slowest launch: {err}") from None


def launched(name: str, launch: float) -> str:
    """The sweep's scene `name` launched at `launch` [m/s], in words."""
    return f"{name} launched at {launch:.3g} m/s from {LAUNCH_GAP:g} D without gravity"


def planning(overrides: dict | None) -> dict:
    """The --set values that change what the ODE model plans with: all but other models' numerics."""
    return {key: value for key, value in (overrides or {}).items()
            if not key.startswith("numerics.") or key.startswith("numerics.ode.")}


def first_bounce(scene: scenes.Scene, launch: float, rebound: bool = True) -> dict:
    """ODE model launched at `launch` [m/s] to the end of the first rebound (or, rebound=False, until the gap
    passes delta_sl inward, where St is measured: the planning's runs, whatever the contact does after)."""
    trial = bounce_scene(scene, launch)
    integrator = BodyIntegrator(trial, stop_after_impacts=0 if rebound else 1)

    def observe(row: dict) -> None:
        stop_requested()  # a signal stops the planning within a step
        if not rebound and integrator.blend_crossings:
            integrator.done = True
    integrator.observers.append(observe)
    try:
        integrator.advance(trial.run.end_time)
    finally:
        integrator.finish()
        integrator.destroy()
    speed_in, speed_out = crossing_speeds(integrator.blend_crossings)
    return {"launch": launch, "St": trial.stokes(speed_in), "Re": trial.reynolds(speed_in), "speed_in": speed_in,
            "speed_out": speed_out, "restitution": speed_out / speed_in if speed_in else 0.0,
            "impacts": len(integrator.impacts), "stop_reason": integrator.stop_reason}


def crossing_speeds(crossings: list[dict]) -> tuple[float, float]:
    """(speed in, speed out) [m/s] where the gap first passes delta_sl inward and then outward (0 when it
    does not)."""
    inward = next((c for c in crossings if c["direction"] == "in"), None)
    if inward is None:
        return 0.0, 0.0
    outward = next((c for c in crossings if c["direction"] == "out" and c["time"] > inward["time"]), None)
    return inward["speed"], outward["speed"] if outward else 0.0


# stokes_band's tables by preset and --set: (launch speeds, St, what ended the band short of the Re limit or None)
_BANDS: dict[tuple[str, str], tuple[np.ndarray, np.ndarray, str | None]] = {}


def _band_key(name: str, overrides: dict | None) -> tuple[str, str]:
    return name, repr(sorted(planning(overrides).items()))


def stokes_band(name: str, overrides: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
    """(launch speeds [m/s], impact St) of a preset (with `overrides`) over LAUNCH_SPEEDS with the ODE model,
    cut where the impact Re passes the axisymmetric limit; St grows with the speed.  Tabulated once per
    process."""
    key = _band_key(name, overrides)
    if key not in _BANDS:
        _BANDS[key] = _tabulate_band(name, planning(overrides))
    return _BANDS[key][:2]


def band_limit(name: str, overrides: dict | None = None) -> str | None:
    """Why the band of `name` (with `overrides`) ends below the Re limit: its first refused launch and the check
    that refused it; None when the Re limit (or the fastest launch) ends it."""
    stokes_band(name, overrides)
    return _BANDS[_band_key(name, overrides)][2]


def tabulate_bands(names, mapper=map, overrides: dict | None = None) -> None:
    """Tabulate the bands of several presets at once: `mapper` (map-like) may spread them over processes."""
    missing = [name for name in dict.fromkeys(names) if _band_key(name, overrides) not in _BANDS]
    found = mapper(_tabulate_band, missing, [planning(overrides)] * len(missing))
    _BANDS.update(zip((_band_key(name, overrides) for name in missing), found))


def forget_bands() -> None:
    """Drop the tabulated bands (a benchmark that times the planning)."""
    _BANDS.clear()


def _tabulate_band(name: str, overrides: dict | None = None) -> tuple[np.ndarray, np.ndarray, str | None]:
    """(launch speeds, St, limit) of stokes_band and band_limit; launches from the first the scene's checks refuse
    up are not run (the checks that depend on the launch, the ehd handover's and the contact gap's, only tighten
    with its speed)."""
    scene = scenes.load(name, overrides)
    speeds, found, refused = np.geomspace(*LAUNCH_SPEEDS, BAND_SAMPLES), [], None
    for speed in speeds:
        try:
            bounce_scene(scene, speed)
        except scenes.SceneError as err:
            if not found:
                raise scenes.SceneError(f"{launched(name, speed)}: {err}") from None
            refused = f"{launched(name, speed)} is refused: {err}"
            break
        found.append(first_bounce(scene, speed, rebound=False))
    keep = [0.0 < r["St"] and r["Re"] <= scenes.AXISYMMETRIC_RE_LIMIT for r in found]  # 0: stopped before 0.2 D
    if not any(keep):
        raise scenes.SceneError(f"{name}: no launch speed in {LAUNCH_SPEEDS} m/s reaches the wall below Re "
                                f"{scenes.AXISYMMETRIC_RE_LIMIT:g}" + (f" ({refused})" if refused else ""))
    first = keep.index(True)  # the slowest launches stop in the liquid before the wall
    n = keep.index(False, first) if False in keep[first:] else len(keep)
    limit = refused if n == len(keep) else None  # the refusal, not the Re limit, ended the band
    return speeds[first:n], np.array([r["St"] for r in found[first:n]]), limit


def launch_for_stokes(name: str, stokes: float, overrides: dict | None = None) -> float:
    """The launch speed [m/s] at which the ODE model's first impact of the preset (with `overrides`) has
    Stokes number `stokes` (monotone cubic interpolation of the tabulated band in log-log)."""
    from scipy.interpolate import PchipInterpolator

    speeds, band = stokes_band(name, overrides)
    if not band[0] * (1 - 1e-9) <= stokes <= band[-1] * (1 + 1e-9):
        raise scenes.SceneError(f"St = {stokes:g} is out of reach for {name}: launched from {LAUNCH_GAP:g} D at "
                                f"{LAUNCH_SPEEDS[0]:g}-{LAUNCH_SPEEDS[1]:g} m/s its first impact has St in "
                                f"[{band[0]:.3g}, {band[-1]:.3g}]")
    if len(band) == 1:
        return float(speeds[0])
    log_speed = PchipInterpolator(np.log(band), np.log(speeds))
    return float(np.exp(log_speed(math.log(stokes))))


def targets(points: int, st_range=(1.0, 1000.0)) -> list[float]:
    """The sweep's Stokes numbers: `points` evenly in log St over st_range, and one every factor
    LOW_ST_RATIO over LOW_ST inside it (where e rises from 0)."""
    lo, hi = st_range
    low = LOW_ST[0] * LOW_ST_RATIO ** np.arange(int(math.log(LOW_ST[1] / LOW_ST[0]) / math.log(LOW_ST_RATIO)) + 1)
    chosen = [*np.geomspace(lo, hi, points), *(s for s in low if lo <= s <= hi)]
    merged: list[float] = []
    for st in sorted(chosen):  # two targets closer than a few per cent are one
        if not merged or st > merged[-1] * 1.05:
            merged.append(float(st))
    return merged


def plan(points: int, st_range=(1.0, 1000.0), sets=MATERIAL_SETS,
         overrides: dict | None = None) -> list[tuple[str, float, float]]:
    """(preset, target St, launch speed [m/s]) for each of `targets` that a set (with `overrides`) reaches, by
    the set whose band holds it furthest from its ends; the targets none reaches are dropped with a warning."""
    bands = {name: stokes_band(name, overrides)[1] for name in sets}
    for name in sets:
        limit = band_limit(name, overrides)
        if limit:
            fastest = stokes_band(name, overrides)[0][-1]
            warnings.warn(f"restitution: {name} is launched at most at {fastest:.3g} m/s (St {bands[name][-1]:.3g}), "
                          f"short of the Re limit: {limit}; its higher Stokes numbers go to the other sets",
                          stacklevel=2)
    chosen, dropped = [], []
    for stokes in targets(points, st_range):
        reaching = [n for n in sets if bands[n][0] * (1 - 1e-9) <= stokes <= bands[n][-1] * (1 + 1e-9)]
        if reaching:  # the set that reaches it most centrally: the curve then spans liquids and materials
            name = max(reaching, key=lambda n: min(stokes / bands[n][0], bands[n][-1] / stokes))
            chosen.append((name, stokes, launch_for_stokes(name, stokes, overrides)))
        else:
            dropped.append(f"{stokes:.4g}")
    if dropped and chosen:
        low, high = min(band[0] for band in bands.values()), max(band[-1] for band in bands.values())
        warnings.warn(f"restitution: no Table 3 set reaches St {', '.join(dropped)} (launched at "
                      f"{LAUNCH_SPEEDS[0]:g}-{LAUNCH_SPEEDS[1]:g} m/s below Re {scenes.AXISYMMETRIC_RE_LIMIT:g} they "
                      f"reach St {low:.3g}-{high:.3g}): {len(dropped)} of the planned points dropped", stacklevel=2)
    return chosen


def sweep(points: int, st_range=(1.0, 1000.0), mapper=map, overrides: dict | None = None) -> list[dict]:
    """The ODE model at each planned launch, to the end of its first rebound (a fraction of a second each),
    with `overrides` applied to every scene (and to the plan).  The runs are independent: `mapper` (map-like,
    e.g. fem_bounce.studies.runner.Runner.map) may spread the band tabulation and the sweep's runs over
    processes; the builtin map runs them one after another."""
    check_overrides(overrides)
    tabulate_bands(MATERIAL_SETS, mapper, overrides)
    planned = plan(points, st_range, overrides=overrides)
    found = mapper(_first_bounce_of, [name for name, _, _ in planned], [launch for _, _, launch in planned],
                   [overrides or {}] * len(planned))
    return [{"scene": name, "target_St": st, **result} for (name, st, _), result in zip(planned, found)]


def _first_bounce_of(name: str, launch: float, overrides: dict) -> dict:
    return first_bounce(scenes.load(name, overrides), launch)
