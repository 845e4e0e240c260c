"""The coefficient of restitution against impact Stokes number with any model (paper Fig. 13-14).

    fem-bounce restitution --model ode                       # about a minute
    fem-bounce restitution --model ale --points 12 --set numerics.ale.cells_per_diameter=8

The Table 3 material sets launched at the wall without gravity, as on Joseph et al.'s (2001) pendulum
(studies.restitution_planning.plan): a point every factor 1.3 between St 3 and 30 and the others spread
over 1-1000; with contact.model = "li2011" also the paper's runs 30-35 (85 % glycerol, delta_ss + 5 %).
Writes restitution.csv (a row per run, failed runs marked with their status and no e), restitution.json
(the comparison with the experiments' fit) and restitution.png (e against St with the ODE curve, the fit
and the experiments' limits); every run goes through the study cache.

e is measured at two stations (docs/physics.md section 4):
- at delta_sl = 0.2 D (the comparison with the fit): e = V_out / V_in, the speeds where the gap passes
  0.2 D inward and outward, just outside the wall's film, and St = rho_p V_in D / (9 mu);
- at the collision (columns St_2ms, restitution_2ms): the 2 ms means before and after the minimum gap, the
  speeds "just prior to and after impact" as Li et al. (2011, section 3.2) took them from their video and
  read Joseph et al.'s (2001); a sphere that leaves the contact but is stopped by the film before 0.2 D
  has e > 0 here and e = 0 at 0.2 D.
- at the camera's frames (St_frame, restitution_frame): the mean speeds over the one frame interval of Li et
  al.'s (2011, section 3.1) camera, 4000 frames per second, before and after the minimum gap: the speeds
  "just prior to and after impact" that a video at that rate gives (Joseph et al. 2001);
- at the peaks (St_peak, restitution_peak: summary.json's peak_speed and peak_restitution): the fastest
  approach since the launch over the fastest rise after the minimum gap.  On the pendulum the fastest
  approach is the launch speed at 2 D, not a speed near the wall.
The fit of Legendre et al. (2006), e / e_d = exp(-35 / St*), is written in St* = (rho_p + rho_l / 2) V D /
(9 mu), so each point is compared with the fit at its own St* = St (1 + rho_l / (2 rho_p)); the comparison
at the collision's station is reported beside the main one (`two_ms`).
"""
from __future__ import annotations

import functools
import math
from pathlib import Path

import numpy as np

from . import restitution_planning as restitution
from .. import scene as scenes
from ..output import read_summary, read_trajectory
from .common import StudyDirectory, measure_all
from .runner import Runner

NO_REBOUND_BELOW_ST = 10.0  # Joseph et al. (2001); the paper's runs 25-29
DRY_ABOVE_ST = 500.0  # Joseph et al. (2001): e close to the dry value above St ~ 500
LEGENDRE_CONSTANT = 35.0  # Legendre et al. (2006): e / e_d = exp(-35 / St*)
COMPARED_ST = (10.0, 1000.0)  # where the fit is compared with (the targets: rms < 0.1, no point off by > 0.2)


def legendre_fit(stokes: float, density_ratio: float, dry_restitution: float = 0.97) -> float:
    """e_d exp(-35 / St*) at the package's St (rho_p based), St* = St (1 + 1 / (2 density_ratio))."""
    st_star = stokes * (1.0 + 0.5 / density_ratio)
    return dry_restitution * math.exp(-LEGENDRE_CONSTANT / st_star) if st_star > 0 else 0.0


FRAME_INTERVAL = 0.25e-3  # s: Li et al.'s (2011, section 3.1) camera, 4000 frames per second


def frame_speeds(run_dir: Path, time: float, interval: float = FRAME_INTERVAL) -> tuple[float, float]:
    """The mean approach and rebound speeds [m/s] over one frame interval [s] before and after the minimum gap at
    `time` [s]: the gap's change between frames, as a camera sees it (trajectory.csv, linear between rows)."""
    path = read_trajectory(Path(run_dir))
    before, at, after = np.interp([time - interval, time, time + interval], path["t"], path["gap"])
    return (before - at) / interval, (after - at) / interval


MAX_POINTS = 1000  # runs per sweep: more is a typo rather than a plan (1000 ode runs take about 10 minutes)


def run(model: str, comm, out: Path, points: int = 12, st_range=(1.0, 1000.0), overrides: dict | None = None,
        ode_points: int = 24, runner: Runner | None = None) -> list[dict]:
    restitution.check_overrides(overrides)
    if not 2 <= points <= MAX_POINTS:
        raise scenes.SceneError(f"--points {points}: allowed 2 to {MAX_POINTS} Stokes numbers per sweep")
    study = StudyDirectory(out, comm)
    runner = runner or Runner(comm)
    planned = plan_points(points, st_range, overrides, runner)
    trials = [restitution.bounce_scene(scenes.load(name, overrides), launch) for name, _, launch in planned]
    measured = measure_all([(trial, model, f"{name} St ~ {target:.3g}")
                            for trial, (name, target, _) in zip(trials, planned)], study, runner)
    rows = [_row(name, target, launch, trial, found)
            for (name, target, launch), trial, found in zip(planned, trials, measured)]
    study.write_csv("restitution.csv", rows)
    study.write_json("restitution.json", compare(rows))
    if comm.rank == 0:
        ode = restitution.sweep(ode_points, st_range, runner.map, overrides) if model != "ode" else None
        figure(rows, ode, model, out / "restitution.png")
    return rows


def plan_points(points: int, st_range, overrides: dict | None, runner: Runner) -> list[tuple[str, float, float]]:
    """The sweep's (preset, target St, launch speed [m/s]), planned by the ODE model on the presets with the --set
    `overrides` (the band tabulation's runs spread by `runner`); SceneError when no set reaches st_range."""
    restitution.tabulate_bands(restitution.MATERIAL_SETS, runner.map, overrides)
    planned = restitution.plan(points, st_range, restitution.MATERIAL_SETS, overrides=overrides)  # those tabulated
    if not planned:
        bands = [restitution.stokes_band(name, overrides)[1] for name in restitution.MATERIAL_SETS]
        low, high = min(band[0] for band in bands), max(band[-1] for band in bands)
        given = "".join(f" --set {key}" for key in overrides or {})
        limits = [limit for name in restitution.MATERIAL_SETS if (limit := restitution.band_limit(name, overrides))]
        raise scenes.SceneError(f"--st-min {st_range[0]:g} --st-max {st_range[1]:g}{given}: no Table 3 set reaches a "
                                f"Stokes number there (launched at {restitution.LAUNCH_SPEEDS[0]:g}-"
                                f"{restitution.LAUNCH_SPEEDS[1]:g} m/s they reach St {low:.3g} to {high:.3g}"
                                + "".join(f"; {limit}" for limit in limits) + ")")
    if scenes.load(restitution.DSS_PLUS_5, overrides).contact.paper:  # the paper's runs 30-35
        restitution.tabulate_bands([restitution.DSS_PLUS_5], runner.map, overrides)
        lo, hi = restitution.stokes_band(restitution.DSS_PLUS_5, overrides)[1][[0, -1]]
        planned += [(restitution.DSS_PLUS_5, st, restitution.launch_for_stokes(restitution.DSS_PLUS_5, st, overrides))
                    for name, st, _ in planned if name == "li2011-table3-steel-85" and lo <= st <= hi]
    return planned


def _row(name: str, target: float, launch: float, trial: scenes.Scene, found: dict) -> dict:
    """One run of the sweep: its e and St, or only its status when it did not complete."""
    row = {"scene": name, "target_St": target, "launch_speed": launch, "status": found["status"],
           "failed": found["status"] != "completed", "St": None, "Re": None, "speed_in": None, "speed_out": None,
           "restitution": None, "St_2ms": None, "restitution_2ms": None, "St_frame": None, "restitution_frame": None,
           "St_peak": None, "restitution_peak": None, "fit": None, "stop_reason": None,
           "wall_time_s": found["wall_time_s"], "run_dir": found["run_dir"]}
    if row["failed"]:
        return row
    summary = read_summary(Path(found["run_dir"]))
    speed_in, speed_out = restitution.crossing_speeds(summary["blend_crossings"])
    impact = summary["impacts"][0] if summary["impacts"] else None
    rebound = summary["rebounds"][0] if summary["rebounds"] else None
    row.update(speed_in=speed_in, speed_out=speed_out, stop_reason=summary.get("stop_reason"))
    if speed_in:  # else it never came in through 0.2 D: no St there, and no e
        row.update(St=trial.stokes(speed_in), Re=trial.reynolds(speed_in), restitution=speed_out / speed_in,
                   fit=legendre_fit(trial.stokes(speed_in), trial.density_ratio, trial.contact.dry_restitution))
    if impact:  # else no collision (it stalled in the film): no St and no e at the collision's stations
        row.update(St_2ms=impact["St"], restitution_2ms=rebound["restitution"] if rebound else 0.0)
        frame_in, frame_out = frame_speeds(Path(found["run_dir"]), impact["time"])
        rose = bool(rebound and rebound["rebounded"])  # the package's rule: an apex below 0.05 D is no rebound
        row.update(St_frame=trial.stokes(frame_in), restitution_frame=frame_out / frame_in if rose else 0.0,
                   St_peak=trial.stokes(impact["peak_speed"]),
                   restitution_peak=rebound["peak_restitution"] if rose else 0.0)
    return row


def compare(rows: list[dict]) -> dict:
    """The sweep against the experiments: rms and largest difference to the Legendre et al. fit over
    COMPARED_ST, the critical St (between the last run without a rebound and the first with one), e at the
    largest St, and the failed runs; at 0.2 D, and under `two_ms` the same at the collision's station."""
    done = [r for r in rows if not r.get("failed") and r["St"]]
    return {
        "runs": len(rows), "failed": [r["scene"] + f" St ~ {r['target_St']:.3g}: {r['status']}"
                                      for r in rows if r.get("failed")],
        "compared_St": list(COMPARED_ST), **_against_fit(done, "St", "restitution"),  # the range compared over
        **{station: _against_fit([r for r in done if r.get(f"St_{key}")], f"St_{key}", f"restitution_{key}")
           for station, key in (("two_ms", "2ms"), ("frame", "frame"), ("peak", "peak"))},
    }


def _against_fit(done: list[dict], stokes: str, restitution: str) -> dict:
    """The fit comparison of the runs `done` with St and e read from the columns `stokes` and `restitution`
    (`covered_St`: the St range of the runs compared, inside COMPARED_ST)."""
    compared = [r for r in done if COMPARED_ST[0] <= r[stokes] <= COMPARED_ST[1]]
    differences = np.array([r[restitution] - legendre_fit(r[stokes], *_fit_inputs(r["scene"])) for r in compared])
    bouncing = sorted(r[stokes] for r in done if r[restitution] > 0.0)
    stuck = sorted(r[stokes] for r in done if r[restitution] == 0.0 and (not bouncing or r[stokes] < bouncing[0]))
    top = max(done, key=lambda r: r[stokes]) if done else None
    return {
        "compared_runs": len(compared),
        "covered_St": [min(r[stokes] for r in compared), max(r[stokes] for r in compared)] if compared else None,
        "rms_to_fit": float(np.sqrt(np.mean(differences**2))) if compared else None,
        "max_abs_to_fit": float(np.max(np.abs(differences))) if compared else None,
        "critical_St": [stuck[-1] if stuck else None, bouncing[0] if bouncing else None],
        "largest_St": top[stokes] if top else None, "e_at_largest_St": top[restitution] if top else None,
    }


@functools.cache
def _fit_inputs(name: str) -> tuple[float, float]:
    scene = scenes.load(name)
    return scene.density_ratio, scene.contact.dry_restitution


def figure(rows: list[dict], ode: list[dict] | None, model: str, path: Path, dry_restitution: float = 0.97) -> Path:
    """e against St: the model's runs by material set (failed runs as red crosses at their target St), the
    ODE curve, and what the experiments say."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    st = np.geomspace(0.8, 2000, 200)
    ax.axvspan(0.8, NO_REBOUND_BELOW_ST, color="0.92", zorder=0)
    ax.text(0.9, 0.62, "Joseph et al. (2001),\nLi et al. (2011): no\nrebound below St ~ 10", fontsize=7, color="0.3")
    ax.axvspan(DRY_ABOVE_ST, 2000, color="0.95", zorder=0)
    ax.text(DRY_ABOVE_ST * 1.05, 0.62, "e near the\ndry value\n(Joseph et\nal. 2001)", fontsize=7, color="0.3")
    steel = 7780.0 / 1200.0  # steel in aqueous glycerol: the fit drawn at the package's St
    ax.semilogx(st, [legendre_fit(s, steel, dry_restitution) for s in st], "k--", lw=1,
                label=r"Legendre et al. (2006) fit, $e_d\,e^{-35/St^*}$, $St^* = St\,(1 + \rho_l / 2\rho_p)$")
    ax.axhline(dry_restitution, color="0.5", ls=":", lw=1)
    if ode:
        curve = sorted((r["St"], r.get("restitution", 0.0)) for r in ode if r["St"])
        ax.semilogx([c[0] for c in curve], [c[1] for c in curve], "-", color="0.55", lw=1.2, label="ode model")
    markers = "os^vD<>ph"
    for k, name in enumerate((*restitution.MATERIAL_SETS, restitution.DSS_PLUS_5)):
        mine = [r for r in rows if r["scene"] == name and r["St"]]
        if mine:
            label = name.replace("li2011-table3-", "").replace("-dss105", r", $\delta_{ss}$+5 %")
            ax.semilogx([r["St"] for r in mine], [r["restitution"] for r in mine], markers[k % len(markers)],
                        color=f"C{k}", ms=6, mfc="none" if name == restitution.DSS_PLUS_5 else None,
                        label=f"{model}: {label}")
    failed = [r for r in rows if r["failed"]]
    if failed:
        ax.semilogx([r["target_St"] for r in failed], [0.0] * len(failed), "x", color="red", ms=9, mew=2,
                    label=f"failed run ({len(failed)}): no e")
    ax.set_xlabel(r"impact Stokes number St = $\rho_p V_{in} D / 9\mu$ ($V_{in}$: speed at 0.2 D from the wall)")
    ax.set_ylabel(r"coefficient of restitution e = $V_{out} / V_{in}$ (at 0.2 D)")
    ax.set_xlim(0.8, 2000)
    ax.set_ylim(-0.03, 1.05)
    ax.legend(fontsize=7, loc="upper left", ncol=2, bbox_to_anchor=(0.0, 0.93))
    ax.set_title(f"Restitution against Stokes number: Table 3 sets launched at the wall without gravity ({model})",
                 fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return Path(path)
