"""Predictions with bands: what the uncertain properties of a scene (fem_bounce.uncertain) do to its bounce.

    fem-bounce study band li2011-case3 --model ode --samples 64 --jobs 2      # the default ranges
    fem-bounce study band my.toml --model ode --samples 64 --vary liquid.viscosity=+-7%
    fem-bounce restitution --band --samples 32 --jobs 2                       # e(St) with its band

A seeded space-filling design over the ranges (scipy.stats.qmc: a scrambled Sobol' sequence, the default, or a Latin
hypercube; `saltelli`: Saltelli's scheme on a Sobol' sequence, SALib.sample.sobol), built in the unit cube [0, 1)^d
and mapped to each setting by its Range, so the same seed gives the same samples.  Every sample is a normal run of
the scene with those values, through the studies' runner: cached, resumable, spread by --jobs or an MPI pool.

What it gives (band.json, samples.csv, band_trajectory.csv and the figures):
- the 5, 50 and 95 % percentiles of every summary quantity (per impact k: impact_speed_k (the 2 ms mean), Re_k,
  St_k, restitution_k, apex_gap_k; the impacts, the time the sphere came to rest) over the samples that have it,
  and of the trajectory (gap and velocity interpolated onto a common time grid);
- where the scene's measurement falls (V_i, Re_I, Re_II of Table 2): inside the 5-95 % band or not, and its
  percentile among the samples; a measured Re against the samples' speeds over the scene's own viscosity, as the
  experiment computed it from its speed (a sample's own Re_k divides by its varied viscosity);
- which property matters: first-order Sobol' indices of each quantity, from the same runs, by SALib's given-data
  estimator (`indices`; bootstrap confidence intervals), or with design `saltelli` first-order and total indices by
  SALib's Sobol' analysis (N (d + 2) runs).  A warning says when a 95 % confidence interval is
  wider than +-CI_LIMIT: the indices then do not rank the properties, and the warning names the sample count that
  would narrow them (the half-width falls as 1 / sqrt(N)).
"""
from __future__ import annotations

import contextlib
import io
import math
import time
import warnings
from pathlib import Path

import numpy as np

from .. import scene as scenes
from .. import uncertain
from ..output import read_summary, read_trajectory
from .common import StudyDirectory
from .runner import Runner

DESIGNS = ("sobol", "lhs", "saltelli")
PERCENTILES = (5.0, 50.0, 95.0)
CI_LIMIT = 0.1  # half-width of a 95 % interval of an index above which the indices do not rank the properties
TRAJECTORY_POINTS = 1000  # the common time grid of the trajectory band
MAX_SAMPLES = 100_000
# the quantities the sensitivity figure draws, in this order, where the runs have them
FIGURE_QUANTITIES = ("impact_speed_1", "restitution_1", "apex_gap_1", "Re_2", "restitution_2", "rest_time")
# the scene's measurements (scene.reference) and the quantity each is compared with
MEASURED = {"impact_speed": "impact_speed_1", "re_first": "Re_1", "re_second": "Re_2"}


# -- the design ---------------------------------------------------------------------------------


def is_power_of_two(n: int) -> bool:
    return n >= 1 and n & (n - 1) == 0


def check_design(method: str, samples: int, dimensions: int) -> None:
    """Refuse a design that cannot be built, naming the option: Sobol' points keep their balance only in powers
    of two; Saltelli's scheme needs N (d + 2) runs with N a power of two."""
    if method not in DESIGNS:
        raise scenes.SceneError(f"--design {method!r}: choose one of {', '.join(DESIGNS)}")
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or not 2 <= samples <= MAX_SAMPLES:
        raise scenes.SceneError(f"--samples {samples!r}: give a whole number of runs, 2 to {MAX_SAMPLES}")
    if method == "sobol" and not is_power_of_two(samples):
        low = 1 << (samples.bit_length() - 1)
        raise scenes.SceneError(f"--samples {samples}: a Sobol' design keeps its balance only in powers of two "
                                f"({low} or {2 * low}); or use --design lhs")
    if method == "saltelli":
        block = dimensions + 2
        base = samples // block
        if samples % block or not is_power_of_two(base):
            base = max(1, 1 << max(0, (max(1, samples // block)).bit_length() - 1))
            raise scenes.SceneError(f"--samples {samples}: Saltelli's scheme over {dimensions} properties runs "
                                    f"N x {block} samples with N a power of two ({base * block} or "
                                    f"{2 * base * block})")


def design(dimensions: int, samples: int, method: str = "sobol", seed: int = 0) -> np.ndarray:
    """(samples, dimensions) points in the unit cube [0, 1), the same for the same seed."""
    from scipy.stats import qmc

    check_design(method, samples, dimensions)
    if method == "sobol":
        return qmc.Sobol(dimensions, scramble=True, seed=seed).random(samples)
    if method == "lhs":
        return qmc.LatinHypercube(dimensions, seed=seed).random(samples)
    from SALib.sample import sobol as saltelli

    return saltelli.sample(_problem(dimensions), samples // (dimensions + 2), calc_second_order=False, seed=seed)


def _problem(dimensions: int, names=None) -> dict:
    """SALib's problem over the unit cube: the indices are those of the settings, each a monotone map of its u."""
    return {"num_vars": dimensions, "names": list(names or [f"u{k}" for k in range(dimensions)]),
            "bounds": [[0.0, 1.0]] * dimensions}


# -- percentiles and indices -------------------------------------------------------------------


def percentiles(values) -> dict | None:
    """{"p5", "p50", "p95", "mean", "n"} of the finite values (None when there are none)."""
    found = np.array([v for v in values if v is not None and math.isfinite(v)], dtype=float)
    if not found.size:
        return None
    low, mid, high = np.percentile(found, PERCENTILES)
    return {"p5": float(low), "p50": float(mid), "p95": float(high), "mean": float(found.mean()), "n": int(found.size)}


def indices(points: np.ndarray, values, names: list[str], method: str = "sobol", seed: int = 0) -> dict:
    """Sobol' indices of one quantity over the settings `names`: {"S1", "S1_conf"} (+ "ST", "ST_conf" for
    design saltelli), lists in the order of names, the confidence values being 95 % half-widths; or {"skipped":
    why} when the values cannot give them (missing in some runs, or all equal).

    From a Sobol' or Latin hypercube design: SALib's given-data estimator of the first-order index (delta.analyze,
    method "sobol": the variance of the quantity's means over equal-count classes of each input, Plischke, Borgonovo
    & Smith 2013, with a bootstrap interval).  Not RBD-FAST, SALib's other given-data estimator: on Sobol' points it
    gave a dummy input an index of 0.5 (256 points, 7 inputs), the points' own structure along a reordered axis.
    From design saltelli: SALib's Sobol' analysis, first-order and total."""
    y = np.array([np.nan if v is None else v for v in values], dtype=float)
    keep = np.isfinite(y)
    if method == "saltelli" and not keep.all():
        return {"skipped": f"{int((~keep).sum())} of {y.size} runs lack it (Saltelli's scheme needs them all)"}
    if keep.sum() < 8:
        return {"skipped": f"{int(keep.sum())} of {y.size} runs have it (8 or more needed)"}
    x, y = points[keep], y[keep]
    if np.ptp(y) <= 1e-12 * max(1.0, float(np.abs(y).max())):
        return {"skipped": "the same in every run"}
    problem = _problem(len(names), names)
    state, formatter = np.random.get_state(), warnings.formatwarning  # SALib's delta sets both globally
    try:
        with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
            warnings.simplefilter("ignore")  # SALib's remarks on small samples: the intervals say it
            if method == "saltelli":
                from SALib.analyze import sobol

                found = sobol.analyze(problem, y, calc_second_order=False, seed=seed)
                keys = ("S1", "S1_conf", "ST", "ST_conf")
            else:
                from SALib.analyze import delta

                found = delta.analyze(problem, x, y, seed=seed + 1, method="sobol")  # its seed 0 means none
                keys = ("S1", "S1_conf")
    finally:
        np.random.set_state(state)
        warnings.formatwarning = formatter
    return {key: [float(v) for v in found[key]] for key in keys} | {"runs": int(y.size)}


def widest_interval(found: dict) -> float:
    """The widest 95 % half-width of an indices record (0 when skipped)."""
    widths = [w for key in ("S1_conf", "ST_conf") for w in found.get(key, []) if math.isfinite(w)]
    return max(widths, default=0.0)


def samples_for(samples: int, width: float) -> int:
    """The sample count (a power of two) that would bring a half-width `width` at `samples` to CI_LIMIT."""
    needed = samples * (width / CI_LIMIT) ** 2
    return 1 << max(0, math.ceil(math.log2(max(needed, 1.0))))


def leading(found: dict, names: list[str]) -> str | None:
    """The setting with the largest index (the total one where there is one)."""
    index = found.get("ST") or found.get("S1")
    return names[int(np.nanargmax(index))] if index else None


# -- one scene's band ---------------------------------------------------------------------------


def sample_quantities(summary: dict) -> dict:
    """A run's summary quantities [SI]: per impact k (from 1) impact_speed_k, Re_k, St_k, impact_time_k,
    restitution_k, apex_gap_k; impacts; end_time; rest_time when it came to rest."""
    found: dict = {"impacts": len(summary.get("impacts", []))}
    for k, impact in enumerate(summary.get("impacts", []), 1):
        found.update({f"impact_speed_{k}": impact["impact_speed"], f"Re_{k}": impact["Re"], f"St_{k}": impact["St"],
                      f"impact_time_{k}": impact["time"]})
    for k, rebound in enumerate(summary.get("rebounds", []), 1):
        found[f"restitution_{k}"] = rebound["restitution"]
        if rebound.get("apex_gap") is not None:
            found[f"apex_gap_{k}"] = rebound["apex_gap"]
    final = summary.get("final") or {}
    found["end_time"] = final.get("time")
    if "came to rest" in (summary.get("stop_reason") or ""):
        found["rest_time"] = final.get("time")
    return found


def trajectory_band(trajectories: list[dict], points: int = TRAJECTORY_POINTS) -> dict:
    """{"t", "gap_p5", ..., "velocity_p95", "runs"} on a uniform grid from 0 to the longest run: each run's gap and
    velocity interpolated linearly between its rows, none beyond its own end (the percentiles there are of the runs
    still going, counted in "runs")."""
    end = max(float(path["t"][-1]) for path in trajectories)
    grid = np.linspace(0.0, end, points)
    band: dict = {"t": grid}
    for column in ("gap", "velocity"):
        stacked = np.full((len(trajectories), points), np.nan)
        for k, path in enumerate(trajectories):
            inside = grid <= path["t"][-1]
            stacked[k, inside] = np.interp(grid[inside], path["t"], path[column])
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # no run there: NaN
            for q in PERCENTILES:
                band[f"{column}_p{q:g}"] = np.nanpercentile(stacked, q, axis=0)
        band["runs"] = np.isfinite(stacked).sum(axis=0)
    return band


def plan(base: scenes.Scene, ranges: list[uncertain.Range], samples: int, method: str = "sobol",
         seed: int = 0) -> tuple[np.ndarray, list[scenes.Scene]]:
    """The design's points and the scene of each, all checked before anything runs."""
    points = design(len(ranges), samples, method, seed)
    trials = [uncertain.sample_scene(base, ranges, point, name=f"{base.name}-band{k}")
              for k, point in enumerate(points)]
    return points, trials


def run(base: scenes.Scene, model: str, comm, out: Path, ranges: list[uncertain.Range], samples: int = 64,
        method: str = "sobol", seed: int = 0, runner: Runner | None = None) -> tuple[dict, list[dict]]:
    """The band of `model` on `base` over `ranges`: writes band.json, samples.csv, band_trajectory.csv,
    band_trajectory.png and sensitivity.png into `out` and returns band.json's content and samples.csv's rows."""
    names = [r.key for r in ranges]
    points, trials = plan(base, ranges, samples, method, seed)
    study = StudyDirectory(out, comm)
    runner = runner or Runner(comm)
    start = time.perf_counter()
    study.log(f"band of {base.name} with {model}: {len(trials)} samples ({method} design, seed {seed}) over "
              f"{'; '.join(r.describe() for r in ranges)}; {runner.describe()} (finished runs come from the cache)")
    rows: list = [None] * len(trials)
    trajectories: list = [None] * len(trials)
    for k, run_dir in runner.run([(trial, model) for trial in trials]):
        summary = read_summary(run_dir)
        found = sample_quantities(summary)
        rows[k] = {"sample": k, **{name: uncertain_value(trials[k], name) for name in names},
                   "status": summary["status"], "wall_time_s": summary["wall_time_s"], **found,
                   "run_dir": str(run_dir)}
        if summary["status"] == "completed":
            path = read_trajectory(run_dir)
            trajectories[k] = {"t": path["t"], "gap": path["gap"], "velocity": path["velocity"]}
        study.log(f"sample {k}: {summary['status']}, V_i {found.get('impact_speed_1', float('nan')):.4g} m/s, "
                  f"e_1 {found.get('restitution_1', float('nan')):.4g}")
    result = summarise(base, model, ranges, points, rows, method, seed)
    result["study_wall_time_s"] = time.perf_counter() - start
    band = trajectory_band([t for t in trajectories if t is not None]) if any(trajectories) else None
    for message in result["warnings"]:
        warnings.warn(message, stacklevel=2)
    study.write_csv("samples.csv", rows)
    study.write_json("band.json", result)
    if band is not None:
        study.write_csv("band_trajectory.csv", [dict(zip(band, values)) for values in zip(*band.values())])
    if comm.rank == 0:
        if band is not None:
            trajectory_figure(band, result, base, out / "band_trajectory.png")
        sensitivity_figure(result, out / "sensitivity.png")
    study.log(f"band written: {len(result['quantities'])} quantities, leading property "
              f"{result['leading'].get('impact_speed_1')} (V_i), {result['leading'].get('restitution_1')} (e_1)")
    return result, rows


TABLE_QUANTITIES = ("impact_speed_1", "Re_1", "restitution_1", "apex_gap_1", "impact_speed_2", "Re_2",
                    "restitution_2", "rest_time")


def format_table(result: dict) -> str:
    """The band in a few lines: the main quantities' percentiles, the measurement and the leading setting."""
    lines = [f"{'quantity':16s} {'5 %':>10s} {'50 %':>10s} {'95 %':>10s} {'measured':>10s}  leading property"]
    for q in TABLE_QUANTITIES:
        found = result["quantities"].get(q)
        if found is None:
            continue
        seen = result["measured"].get(q)
        mark = "" if seen is None else f"{seen['measured']:10.4g}{' in' if seen['inside'] else ' OUT'}"
        if seen is not None and q.startswith("Re_"):
            lines.append(f"{q + ' as measured':16s} {seen['band']['p5']:10.4g} {seen['band']['p50']:10.4g} "
                         f"{seen['band']['p95']:10.4g} {mark:>13s}  (the speed over the scene's viscosity)")
            mark = ""
        lines.append(f"{q:16s} {found['p5']:10.4g} {found['p50']:10.4g} {found['p95']:10.4g} {mark:>13s}  "
                     f"{result['leading'].get(q) or '-'}")
    return "\n".join(lines)


def uncertain_value(scene: scenes.Scene, key: str) -> float:
    value = scene
    for part in key.split("."):
        value = getattr(value, part)
    return value


def summarise(base: scenes.Scene, model: str, ranges: list[uncertain.Range], points: np.ndarray, rows: list[dict],
              method: str, seed: int) -> dict:
    """band.json: the percentiles of every quantity over the completed runs, the measurement's place in them,
    the indices, the leading setting of each quantity and the warnings."""
    names = [r.key for r in ranges]
    done = [r["status"] == "completed" for r in rows]
    quantities = [q for q in dict.fromkeys(k for r in rows for k in r)
                  if q not in (*names, "sample", "status", "wall_time_s", "run_dir")]
    values = {q: [r.get(q) if ok else None for r, ok in zip(rows, done)] for q in quantities}
    bands = {q: found for q in quantities if (found := percentiles(values[q])) is not None}
    sensitivity = {q: indices(points, values[q], names, method, seed) for q in bands if q != "end_time"}
    warned = []
    wide = {q: w for q, found in sensitivity.items() if (w := widest_interval(found)) > CI_LIMIT}
    if wide:
        worst = max(wide, key=wide.get)
        warned.append(f"band of {base.name}: the sensitivity indices of {len(wide)} of {len(sensitivity)} quantities "
                      f"have 95 % intervals wider than +-{CI_LIMIT:g} (widest +-{wide[worst]:.2f}, {worst}) with "
                      f"{len(rows)} samples: they do not rank the properties; about "
                      f"{samples_for(len(rows), wide[worst])} samples would")
    failed = [r["sample"] for r in rows if r["status"] != "completed"]
    if failed:
        warned.append(f"band of {base.name}: {len(failed)} of {len(rows)} samples did not complete (samples "
                      f"{', '.join(map(str, failed[:5]))}{' ...' if len(failed) > 5 else ''}): left out of the band")
    measured = {}
    for field, quantity in MEASURED.items():
        value = getattr(base.reference, field)
        if value is None or quantity not in bands:
            continue
        seen = [v for v in values[quantity] if v is not None]
        if quantity.startswith("Re_"):  # as the experiment's Re: the speed over the scene's own (nominal) viscosity
            seen = [base.reynolds(v) for v in values[f"impact_speed_{quantity[3:]}"] if v is not None]
        found = percentiles(seen)
        measured[quantity] = {"measured": value, "band": found, "inside": found["p5"] <= value <= found["p95"],
                              "percentile": 100.0 * float(np.mean(np.array(seen) <= value)),
                              "median_error": found["p50"] / value - 1.0}
    return {"scene": base.name, "model": model, "samples": len(rows), "design": method, "seed": seed,
            "percentiles": list(PERCENTILES), "ranges": [r.as_dict() for r in ranges],
            "completed": int(sum(done)), "quantities": bands, "measured": measured, "indices": sensitivity,
            "leading": {q: leading(found, names) for q, found in sensitivity.items() if "skipped" not in found},
            "ci_limit": CI_LIMIT, "warnings": warned}


# -- figures --------------------------------------------------------------------------------------


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def trajectory_figure(band: dict, result: dict, base: scenes.Scene, path: Path) -> Path:
    """Gap and velocity against time: the median and the shaded 5-95 % band, with the measured impact speeds (V_i,
    and the speeds of Re_I, Re_II: Re nu / D) at the median impact times."""
    plt = _pyplot()
    diameter = base.sphere.diameter
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    t = band["t"]
    top.fill_between(t, band["gap_p5"] / diameter, band["gap_p95"] / diameter, color="C0", alpha=0.3, lw=0,
                     label="5-95 %")
    top.plot(t, band["gap_p50"] / diameter, "C0-", lw=1.2, label="median")
    bottom.fill_between(t, band["velocity_p5"], band["velocity_p95"], color="C1", alpha=0.3, lw=0, label="5-95 %")
    bottom.plot(t, band["velocity_p50"], "C1-", lw=1.2, label="median")
    quantities = result["quantities"]
    ref = base.reference
    nu_over_d = base.liquid.kinematic_viscosity / diameter
    marks = [("impact_speed", 1, ref.impact_speed, "V_i"), ("re_first", 1, ref.re_first and ref.re_first * nu_over_d,
                                                          "Re_I nu / D"),
             ("re_second", 2, ref.re_second and ref.re_second * nu_over_d, "Re_II nu / D")]
    for (_, k, speed, label), marker in zip(marks, "osD"):
        when = quantities.get(f"impact_time_{k}", {}).get("p50")
        if speed and when is not None:
            bottom.plot([when], [-speed], marker, color="k", mfc="none", ms=7, label=f"measured {label}")
    top.set(ylabel="gap / D", title=f"{base.name}, {result['model']}: {result['completed']} samples "
                                    f"({result['design']}), 5-95 % band")
    bottom.set(xlabel="t [s]", ylabel="velocity [m/s]")
    top.legend(fontsize=8)
    bottom.legend(fontsize=8, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return Path(path)


def sensitivity_figure(result: dict, path: Path, quantities=FIGURE_QUANTITIES) -> Path:
    """A group of bars per quantity, a bar per setting (first-order index, the total one hatched beside it), with
    the 95 % intervals."""
    plt = _pyplot()
    shown = [q for q in quantities if "S1" in result["indices"].get(q, {})]
    if not shown:
        shown = [q for q, found in result["indices"].items() if "S1" in found][:6]
    names = [r["key"] for r in result["ranges"]]
    total = any("ST" in result["indices"][q] for q in shown)
    fig, ax = plt.subplots(figsize=(max(6.0, 1.6 * max(1, len(shown))), 4.2))
    width = 0.8 / max(1, len(names))
    for j, name in enumerate(names):
        x = np.arange(len(shown)) + (j - (len(names) - 1) / 2) * width
        found = [result["indices"][q] for q in shown]
        ax.bar(x - (0.25 * width if total else 0.0), [f["S1"][j] for f in found], width * (0.45 if total else 0.9),
               yerr=[f["S1_conf"][j] for f in found], color=f"C{j}", capsize=2, label=name)
        if total:
            ax.bar(x + 0.25 * width, [f["ST"][j] for f in found], 0.45 * width, yerr=[f["ST_conf"][j] for f in found],
                   color=f"C{j}", alpha=0.5, hatch="//", capsize=2)
    ax.axhline(0.0, color="0.5", lw=0.6)
    ax.set_xticks(np.arange(len(shown)), shown, fontsize=8)
    kind = "first-order (solid) and total (hatched)" if total else "first-order (given data)"
    ax.set(ylabel="Sobol' index", title=f"{result['scene']}, {result['model']}: {kind} indices, "
                                        f"{result['samples']} samples, 95 % intervals")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return Path(path)


# -- e(St) with a band -------------------------------------------------------------------------------


def restitution_band(model: str, comm, out: Path, points: int = 24, st_range=(1.0, 1000.0),
                     overrides: dict | None = None, vary=(), defaults: bool = True, samples: int = 32,
                     method: str = "sobol", seed: int = 0, runner: Runner | None = None) -> dict:
    """The restitution sweep (studies.restitution) with a band: at each of its stations (a Table 3 set launched at
    the speed the ODE model plans for a target St on the nominal set) `samples` runs over the uncertain ranges
    (relative ones taken against each set's own values; the same design point k at every station), and per station
    the 5/50/95 % percentiles of St and of e at 0.2 D (and of the 2 ms means'), the experiments' fit at the
    median St and whether it lies inside the 5-95 % band, and the first-order indices of e.  Writes
    restitution_band.csv (a row per station), samples.csv (a row per run), band.json and restitution_band.png."""
    from . import restitution_planning as planning
    from .restitution import MAX_POINTS, _fit_inputs, _row

    planning.check_overrides(overrides)
    if not 2 <= points <= MAX_POINTS:
        raise scenes.SceneError(f"--points {points}: allowed 2 to {MAX_POINTS} Stokes numbers per sweep")
    names = (*planning.MATERIAL_SETS, planning.DSS_PLUS_5)
    ranges = {name: uncertain.ranges_for(scenes.load(name, overrides), vary, None, defaults) for name in names}
    keys = [r.key for r in ranges[names[0]]]
    if any([r.key for r in found] != keys for found in ranges.values()):
        raise scenes.SceneError("the restitution band's sets vary different settings (their contact models differ): "
                                "give the ranges with --vary and --no-defaults")
    for key in keys:
        if key in planning.PLANNED_KEYS:
            raise scenes.SceneError(f"--vary {key}: the restitution sweep sets {key} for each run itself")
    check_design(method, samples, len(keys))
    unit_points = design(len(keys), samples, method, seed)
    study = StudyDirectory(out, comm)
    runner = runner or Runner(comm)
    from .restitution import plan_points

    planned = plan_points(points, st_range, overrides, runner)
    trials, where = [], []
    for station, (name, _, launch) in enumerate(planned):
        base = scenes.load(name, overrides)
        for k, point in enumerate(unit_points):
            varied = uncertain.sample_scene(base, ranges[name], point, name=f"{name}-band{k}")
            trials.append(planning.bounce_scene(varied, launch))
            where.append((station, k))
    start = time.perf_counter()
    study.log(f"e(St) band with {model}: {len(planned)} stations x {samples} samples ({method}, seed {seed}) = "
              f"{len(trials)} runs over {'; '.join(r.describe() for r in ranges[names[1]])} (as on "
              f"{names[1]}); {runner.describe()} (finished runs come from the cache)")
    rows: list = [None] * len(trials)
    left = [samples] * len(planned)
    for j, run_dir in runner.run([(trial, model) for trial in trials]):
        station, k = where[j]
        name, target, launch = planned[station]
        summary = read_summary(run_dir)
        found = {"status": summary["status"], "wall_time_s": summary["wall_time_s"], "run_dir": str(run_dir)}
        row = _row(name, target, launch, trials[j], found)
        rows[j] = {"station": station, "sample": k, **{key: uncertain_value(trials[j], key) for key in keys}, **row}
        left[station] -= 1
        if not left[station]:
            study.log(f"station {station} ({name} St ~ {target:.3g}): its {samples} samples finished")
    stations = []
    for station, (name, target, launch) in enumerate(planned):
        mine = [r for r in rows if r["station"] == station]
        done = [r for r in mine if not r["failed"]]
        e = [r["restitution"] if not r["failed"] else None for r in mine]
        st, e_band = percentiles([r["St"] for r in done]), percentiles(e)
        two_ms = percentiles([r["restitution_2ms"] for r in done])
        entry = {"scene": name, "target_St": target, "launch_speed": launch, "runs": len(mine), "failed": len(mine) -
                 len(done)}
        for label, found in (("St", st), ("e", e_band), ("e_2ms", two_ms)):
            entry.update({f"{label}_{p}": (found or {}).get(p) for p in ("p5", "p50", "p95")})
        if st and e_band:
            fit = legendre_at(st["p50"], name, _fit_inputs)
            entry.update(fit=fit, fit_inside=bool(e_band["p5"] <= fit <= e_band["p95"]),
                         fit_distance=max(0.0, e_band["p5"] - fit, fit - e_band["p95"]))  # 0 inside
        sensitivity = indices(unit_points, e, keys, method, seed)
        entry["indices"] = sensitivity
        entry["leading"] = leading(sensitivity, keys) if "skipped" not in sensitivity else None
        entry["widest_interval"] = widest_interval(sensitivity)
        stations.append(entry)
    result = restitution_summary(stations, keys, model, samples, method, seed, ranges[names[1]])
    result["study_wall_time_s"] = time.perf_counter() - start
    for message in result["warnings"]:
        warnings.warn(message, stacklevel=2)
    study.write_csv("restitution_band.csv", [{k: v for k, v in s.items() if k != "indices"} |
                                             {f"S1_{key}": s["indices"].get("S1", [None] * len(keys))[i]
                                              for i, key in enumerate(keys)} for s in stations])
    study.write_csv("samples.csv", rows)
    study.write_json("band.json", result)
    if comm.rank == 0:
        restitution_figure(stations, result, out / "restitution_band.png")
    return result


def legendre_at(stokes: float, name: str, fit_inputs) -> float:
    """The experiments' fit (Legendre et al. 2006, the restitution study's) at the package's St, with the set's
    density ratio and dry restitution as the fit takes them (the nominal set's, not a sample's)."""
    from .restitution import legendre_fit

    return legendre_fit(stokes, *fit_inputs(name))


LOW_ST = 30.0  # "below St 30": where the package's e(St) misses the experiments (docs/validation.md section 5)


def restitution_summary(stations: list[dict], keys: list[str], model: str, samples: int, method: str, seed: int,
                        ranges: list[uncertain.Range]) -> dict:
    """band.json of the e(St) band: the stations, where the fit lies inside the band, the property that leads the
    band below LOW_ST (the largest mean first-order index there) and the warnings."""
    inside = [s["St_p50"] for s in stations if s.get("fit_inside")]
    outside = [s["St_p50"] for s in stations if s.get("fit_inside") is False]
    low = [s for s in stations if s["St_p50"] is not None and s["St_p50"] < LOW_ST and "S1" in s["indices"]]
    mean_low = {key: float(np.mean([s["indices"]["S1"][i] for s in low])) for i, key in enumerate(keys)} if low else {}
    warned = []
    wide = [s for s in stations if s["widest_interval"] > CI_LIMIT]
    if wide:
        worst = max(s["widest_interval"] for s in wide)
        warned.append(f"e(St) band: the indices of e at {len(wide)} of {len(stations)} stations have 95 % intervals "
                      f"wider than +-{CI_LIMIT:g} (widest +-{worst:.2f}) with {samples} samples: they do not rank the "
                      f"properties; about {samples_for(samples, worst)} samples would")
    failed = sum(s["failed"] for s in stations)
    if failed:
        warned.append(f"e(St) band: {failed} runs did not complete (marked in samples.csv): left out of the band")
    return {"model": model, "samples": samples, "design": method, "seed": seed, "percentiles": list(PERCENTILES),
            "ranges": [r.as_dict() for r in ranges], "stations": stations,
            "fit_inside_St": sorted(inside), "fit_outside_St": sorted(outside),
            "below_St": LOW_ST, "mean_S1_below_St": mean_low,
            "leading_below_St": max(mean_low, key=mean_low.get) if mean_low else None,
            "ci_limit": CI_LIMIT, "warnings": warned}


def restitution_figure(stations: list[dict], result: dict, path: Path) -> Path:
    """e against St: the 5-95 % band (shaded, over the stations in St order, and a bar at each), the medians by
    material set, the experiments' fit (Legendre et al. 2006) and their no-rebound and dry limits."""
    from . import restitution_planning as planning
    from .restitution import DRY_ABOVE_ST, NO_REBOUND_BELOW_ST, legendre_fit

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 5))
    ax.axvspan(0.8, NO_REBOUND_BELOW_ST, color="0.92", zorder=0)
    ax.axvspan(DRY_ABOVE_ST, 2000, color="0.95", zorder=0)
    st = np.geomspace(0.8, 2000, 200)
    steel = 7780.0 / 1200.0  # the restitution study's figure draws the fit for steel in aqueous glycerol
    ax.semilogx(st, [legendre_fit(s, steel) for s in st], "k--", lw=1,
                label=r"Legendre et al. (2006) fit, $0.97\,e^{-35/St^*}$")
    shown = sorted((s for s in stations if s["St_p50"] is not None and s["e_p50"] is not None),
                   key=lambda s: s["St_p50"])
    if shown:
        ax.fill_between([s["St_p50"] for s in shown], [s["e_p5"] for s in shown], [s["e_p95"] for s in shown],
                        color="C0", alpha=0.25, lw=0, label=f"{result['model']}: 5-95 % band ({result['samples']} "
                                                             "samples per point)")
    for k, name in enumerate((*planning.MATERIAL_SETS, planning.DSS_PLUS_5)):
        mine = [s for s in shown if s["scene"] == name]
        if not mine:
            continue
        x = np.array([s["St_p50"] for s in mine])
        y = np.array([s["e_p50"] for s in mine])
        err = np.array([[s["e_p50"] - s["e_p5"] for s in mine], [s["e_p95"] - s["e_p50"] for s in mine]])
        xerr = np.array([[s["St_p50"] - s["St_p5"] for s in mine], [s["St_p95"] - s["St_p50"] for s in mine]])
        ax.errorbar(x, y, yerr=err, xerr=xerr, fmt="os^vD<>ph"[k % 9], color=f"C{k}", ms=4, lw=0.8, capsize=2,
                    label=f"median: {name.replace('li2011-table3-', '')}")
    ax.set_xscale("log")
    ax.set(xlim=(0.8, 2000), ylim=(-0.03, 1.05),
           xlabel=r"impact Stokes number St = $\rho_p V_{in} D / 9\mu$ (at 0.2 D)",
           ylabel="e at 0.2 D", title=f"e(St) with its band: {result['model']}, {result['design']} design; "
                                     f"leading below St {result['below_St']:g}: {result['leading_below_St']}")
    ax.title.set_fontsize(9)
    ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return Path(path)
