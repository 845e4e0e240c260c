"""Coefficient of restitution against impact Stokes number (paper section 5.4, Fig. 13-14).

The paper's Table 3 material sets each cover a band of impact Stokes numbers as
the initial gap varies (gaps not published).  `gap_for_stokes` finds the gap
that gives a target St with the ODE model; `sweep` spreads targets over the
sets, from 95 % glycerol (St ~ 1) to the artificial 48 g/cm3 sphere (St ~ 1000),
keeping Re below the axisymmetric limit.

    fem-bounce restitution --points 40      # CSV and figure in results/restitution/
"""
from __future__ import annotations

import csv
import math
import warnings
from pathlib import Path

import numpy as np

from . import scene as scenes
from .sphere import SphereIntegrator

# (preset, largest St it is used for): each set's St range at Re < 250 (measured with the ODE model)
MATERIAL_LADDER = (
    ("li2011-table3-steel-95", 1.3),
    ("li2011-table3-steel-85", 30.0),
    ("li2011-table3-steel-78", 90.0),
    ("li2011-table3-dense24-78", 300.0),
    ("li2011-table3-dense36-78", 480.0),
    ("li2011-table3-dense48-78", math.inf),
)
GAP_RANGE = (1.5, 1200.0)  # initial gap bracket, in units of delta_ss * D


def log_targets(st_min: float, st_max: float, points: int) -> np.ndarray:
    return np.geomspace(st_min, st_max, points)


def bounce_scene(scene: scenes.Scene, gap: float) -> scenes.Scene:
    """`scene` from `gap`, run to the apex after the first impact, with time enough to fall
    at a tenth of the terminal speed."""
    end = 10.0 * gap / scene.terminal_speed() + 20.0 * scene.time_unit
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Re warnings are the caller's business here
        return scene.replace(**{"initial_gap": gap, "run.bounces": 1, "run.end_time": end})


def first_bounce(scene: scenes.Scene, gap: float, rebound: bool = True) -> dict:
    """ODE model from `gap` to the apex after the first impact (or to the impact only)."""
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
                      peak_restitution=r.peak_restitution)
    return result


def gap_for_stokes(scene: scenes.Scene, stokes: float, rtol: float = 0.01) -> float:
    """The initial gap [m] at which the ODE model's first impact has Stokes number `stokes`.

    St grows monotonically with the fall height; bisection on log(gap), then secant steps."""
    unit = scene.contact.delta_ss * scene.sphere.diameter
    lo, hi = (unit * g for g in GAP_RANGE)
    st_lo, st_hi = (first_bounce(scene, g, rebound=False)["St"] for g in (lo, hi))
    if not st_lo <= stokes <= st_hi:
        raise scenes.SceneError(
            f"St = {stokes:g} is out of reach for {scene.name}: its first impact has St in [{st_lo:.3g}, {st_hi:.3g}]"
        )
    for _ in range(60):
        # secant in log-log, kept inside the bracket
        x_lo, x_hi, y_lo, y_hi = math.log(lo), math.log(hi), math.log(st_lo), math.log(st_hi)
        guess = x_lo + (math.log(stokes) - y_lo) * (x_hi - x_lo) / (y_hi - y_lo)
        mid = math.exp(min(max(guess, x_lo + 0.05 * (x_hi - x_lo)), x_hi - 0.05 * (x_hi - x_lo)))
        st_mid = first_bounce(scene, mid, rebound=False)["St"]
        if abs(st_mid / stokes - 1.0) < rtol:
            return mid
        if st_mid < stokes:
            lo, st_lo = mid, st_mid
        else:
            hi, st_hi = mid, st_mid
    return mid


def material_for(stokes: float, ladder=MATERIAL_LADDER) -> str:
    return next(name for name, limit in ladder if stokes <= limit)


def plan(targets, samples: int = 8, ladder=MATERIAL_LADDER) -> list[tuple[str, float, float]]:
    """(preset, target St, initial gap) per target: each set's St(gap) is tabulated with `samples`
    ODE runs to the first impact and the gap interpolated (monotone cubic in log-log)."""
    from scipy.interpolate import PchipInterpolator

    chosen = []
    for name, _ in ladder:
        wanted = [float(st) for st in targets if material_for(st, ladder) == name]
        if not wanted:
            continue
        scene = scenes.load(name)
        unit = scene.contact.delta_ss * scene.sphere.diameter
        gaps = np.geomspace(unit * GAP_RANGE[0], unit * GAP_RANGE[1], samples)
        stokes = np.array([first_bounce(scene, g, rebound=False)["St"] for g in gaps])
        log_gap = PchipInterpolator(np.log(stokes), np.log(gaps), extrapolate=False)
        for st in wanted:
            x = np.clip(math.log(st), math.log(stokes[0]), math.log(stokes[-1]))
            chosen.append((name, st, float(np.exp(log_gap(x)))))
    return chosen


def sweep(targets) -> list[dict]:
    """The ODE model at each planned gap, to its first apex."""
    return [{"scene": name, "target_St": st, **first_bounce(scenes.load(name), gap)}
            for name, st, gap in plan(targets)]


COLUMNS = ("scene", "target_St", "gap", "St", "Re", "impact_speed", "restitution", "rebound_speed", "apex_gap",
           "peak_restitution")


def write(results: list[dict], out_dir: Path) -> None:
    out_dir = Path(out_dir)
    with open(out_dir / "restitution.csv", "w", newline="") as stream:
        writer = csv.DictWriter(stream, COLUMNS, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(results)
    figure(out_dir / "restitution.csv", out_dir / "restitution.png")


def figure(csv_path: Path, png_path: Path, dry_restitution: float = 0.97) -> Path:
    """e against St from a sweep's CSV, with the paper's expectations (Fig. 13-14)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with open(csv_path, newline="") as stream:
        rows = list(csv.DictReader(stream))
    fig, ax = plt.subplots(figsize=(7, 4.5))
    for k, (name, _) in enumerate(MATERIAL_LADDER):
        mine = [r for r in rows if r["scene"] == name]
        if mine:
            stokes = [float(r["St"]) for r in mine]
            ax.semilogx(stokes, [float(r["restitution"] or 0) for r in mine], "os^vD<>"[k], color=f"C{k}", ms=5,
                        label=name.replace("li2011-table3-", "Table 3: "))
            ax.semilogx(stokes, [float(r["peak_restitution"] or 0) for r in mine], "os^vD<>"[k], color=f"C{k}",
                        ms=4, mfc="none", alpha=0.5)
    st = np.geomspace(1, 2000, 200)
    ax.semilogx(st, dry_restitution * np.exp(-35.0 / st), "k--", lw=1,
                label=r"Legendre et al. (2006) fit $e_d\,e^{-35/St}$")
    ax.axvline(10.0, color="0.5", ls=":", lw=1)
    ax.axhline(dry_restitution, color="0.5", ls=":", lw=1)
    ax.text(10.5, 0.03, "St = 10: no rebound below (paper)", fontsize=8, color="0.3")
    ax.text(1.1, dry_restitution + 0.015, r"$e_d$ = %.2f" % dry_restitution, fontsize=8, color="0.3")
    ax.set_xlabel("impact Stokes number St")
    ax.set_ylabel("coefficient of restitution e")
    ax.set_ylim(-0.02, 1.05)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title("ODE model: e from 2 ms mean speeds (filled), from peak speeds (open)", fontsize=10)
    fig.tight_layout()
    fig.savefig(png_path, dpi=130)
    plt.close(fig)
    return Path(png_path)
