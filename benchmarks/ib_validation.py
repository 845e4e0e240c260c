"""Validation and cost of the immersed-boundary model, at full resolution.

    .venv/bin/python benchmarks/ib_validation.py                 # every check (~40 min on 2 cores)
    .venv/bin/python benchmarks/ib_validation.py drag case3      # some of them
    .venv/bin/python benchmarks/ib_validation.py --cells 48 drag # another resolution

Checks (targets from the project's reference values and the issue):
  drag        fixed sphere, Re 100 and 200: Cd against 1.087 and 0.77 (3 %); recirculation length
  tencate     ten Cate E4: peak speed against 0.1226 m/s (3 %), rms deviation from the curve
  case3       Li case 3: first impact speed against 0.393 m/s (5 %), Re_II against 55 (10 %),
              at least two rebounds; also with contact.inertial_factor = none (sensitivity)
  cases       Li cases 1-7 against Table 2 (V_i, Re_I, Re_II)
  density     lowest stable density ratio of the implicit coupling (rising light sphere)
  resolution  case 3, first bounce, at 16..64 cells per diameter: apex, V_i, cost; and the cost
              per step at the paper's 100 cells per diameter
  domain      far-field distance and cell growth (graded single grid): Cd(100) and case 3 V_i
  timestep    case 3 at CFL 0.4 and 0.2
  speed       case 3 with ode and ib in this session (wall-time ratio)
  retraction  Cd(100), ten Cate peak and case 3 with the points on radius a - 0.3 h (Breugem 2012)

Results are merged into benchmarks/history/ib_validation.json with the date and machine.
Timings are of this machine at the time; another job running alongside makes them noisy.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fem_bounce import reference, scene
from fem_bounce.output import read_summary, read_trajectory
from fem_bounce.errors import RunDiverged
from fem_bounce.run import run_logged as simulate  # the libraries' output goes to the run's run.log

RESULTS = Path(__file__).parent / "history" / "ib_validation.json"
COMM = MPI.COMM_SELF


def run(name: str, changes: dict, model: str = "ib") -> dict:
    """One run in a scratch directory; the summary, with the trajectory under "_trajectory"."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = scene.load(name, changes)
    with tempfile.TemporaryDirectory() as scratch:
        out = Path(scratch) / "run"
        try:
            simulate(sc, model, COMM, out, progress=False, plots=False)
        except RunDiverged:
            pass  # the summary says so
        summary = read_summary(out)
        summary["_trajectory"] = read_trajectory(out)
    return summary


def impacts(summary: dict) -> dict:
    d = summary["scene"]["sphere"]["diameter"]
    out = {"status": summary["status"], "wall_time_s": round(summary["wall_time_s"], 2), "steps": summary["steps"],
           "impact_speed": [round(i["impact_speed"], 5) for i in summary["impacts"]],
           "Re": [round(i["Re"], 2) for i in summary["impacts"]],
           "restitution": [round(r["restitution"], 4) for r in summary["rebounds"]],
           "apex_gap_over_D": [round(r["apex_gap"] / d, 5) if r["apex_gap"] else None for r in summary["rebounds"]]}
    ib = summary.get("ib", {})
    for key in ("seconds_per_step", "cg_iterations_mean", "max_cfl", "refactorisations", "force_tables_assembled"):
        if key in ib:
            out[key] = round(ib[key], 4) if isinstance(ib[key], float) else ib[key]
    out["unknowns"] = (summary.get("sizes") or {}).get("unknowns")
    return out


def rel(value, target):
    return round((value - target) / target, 4)


def check_drag(cells):
    out = {}
    for re_number, target, wake in ((100, 1.087, 0.87), (200, 0.77, 1.46)):
        s = run(f"sphere-drag-re{re_number}", {"numerics.ib.cells_per_diameter": cells})
        cd = s["ib"]["drag_coefficient"]
        length = s["ib"].get("recirculation_length_over_D")
        out[f"Re{re_number}"] = {"Cd": round(cd, 4), "target": target, "error": rel(cd, target),
                                 "recirculation_length_over_D": length and round(length, 3),
                                 "recirculation_target": wake,
                                 "met_3pct": abs(rel(cd, target)) <= 0.03, "drift": s["ib"]["drag_coefficient_drift"],
                                 "wall_time_s": round(s["wall_time_s"], 1), "unknowns": s["sizes"]["unknowns"]}
    return out


def check_tencate(cells):
    s = run("tencate2002-e4", {"numerics.ib.cells_per_diameter": cells})
    t, v = s["_trajectory"]["t"], s["_trajectory"]["velocity"]
    peak = float(-v.min())
    t_exp, u_exp = reference.velocity_curve("tencate2002_E4")
    before = t_exp < t[np.argmin(v)]  # the approach, up to the simulated peak
    rms = float(np.sqrt(np.mean((np.interp(t_exp[before], t, v) - u_exp[before]) ** 2)))
    return {"peak_speed": round(peak, 5), "target": 0.1226, "error": rel(peak, 0.1226),
            "met_3pct": abs(rel(peak, 0.1226)) <= 0.03, "rms_curve_deviation_before_peak_m_per_s": round(rms, 5),
            "wall_time_s": round(s["wall_time_s"], 1), "unknowns": s["sizes"]["unknowns"]}


def check_case3(cells):
    out = {}
    for label, changes in (("default", {}), ("inertial_factor_none", {"contact.inertial_factor": "none"})):
        s = run("li2011-case3", {"numerics.ib.cells_per_diameter": cells, **changes})
        rec = impacts(s)
        if rec["impact_speed"]:
            rec["V_i_error"] = rel(rec["impact_speed"][0], 0.393)
            rec["met_V_i_5pct"] = abs(rec["V_i_error"]) <= 0.05
        if len(rec["Re"]) > 1:
            rec["Re_II_error"] = rel(rec["Re"][1], 55.0)
            rec["met_Re_II_10pct"] = abs(rec["Re_II_error"]) <= 0.10
        rec["rebounds"] = sum(1 for a in rec["apex_gap_over_D"] if a)
        out[label] = rec
    return out


def check_cases(cells):
    table = {r["case"]: r for r in reference.table("li2011_table2_experiments")}
    out = {}
    for case in range(1, 8):
        s = run(f"li2011-case{case}", {"numerics.ib.cells_per_diameter": cells, "run.bounces": 2})
        rec = impacts(s)
        ref = table[case]
        rec.update(measured_V_i=ref["V_i_m_per_s"], measured_Re_I=ref["Re_I"], measured_Re_II=ref["Re_II"])
        out[f"case{case}"] = rec
    return out


def check_density(cells):
    """A sphere rising from rest in ten Cate's liquid and box at decreasing density ratio."""
    out = {}
    for coupling, ratio in [("implicit", r) for r in (1.167, 0.5, 0.1, 0.01, 0.001)] + \
            [("explicit", r) for r in (4.0, 3.0, 2.0, 1.5, 1.167)]:
        changes = {"numerics.ib.cells_per_diameter": 16, "sphere.density": 960.0 * ratio, "initial_gap": 0.03,
                   "run.end_time": 0.3, "container": {"radius": 0.05, "height": 0.16},
                   "numerics.ib.coupling": coupling}
        if ratio > 1:
            changes["initial_gap"] = 0.1  # heavy: falls
        s = run("tencate2002-e4", changes)
        velocity = s["_trajectory"]["velocity"]
        stable = s["status"] == "completed" and bool(np.all(np.isfinite(velocity)))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            terminal = scene.load("tencate2002-e4", changes).terminal_speed()
        wobble = float(np.abs(np.diff(velocity, 2)).max() / max(np.abs(velocity).max(), 1e-12))
        out[f"{coupling} {ratio:.4g}"] = {"stable": stable and wobble < 0.05,
                               "max_step_wobble_relative": round(wobble, 5),
                               "final_speed": round(float(abs(velocity[-1])), 5),
                               "terminal_speed_schiller_naumann": round(terminal, 5), "status": s["status"][:80],
                               "wall_time_s": round(s["wall_time_s"], 1)}
    return out


def check_resolution(cells):
    out = {}
    for n in (16, 24, 32, 48, 64):
        s = run("li2011-case3", {"numerics.ib.cells_per_diameter": n, "run.bounces": 1})
        out[str(n)] = impacts(s)
    apex = {n: out[n]["apex_gap_over_D"][0] for n in out}
    keys = list(apex)
    out["apex_change_vs_next_finer"] = {keys[k]: round(apex[keys[k]] / apex[keys[k + 1]] - 1.0, 4)
                                         for k in range(len(keys) - 1)}
    out["paper_grid_100"] = cost_at(100)
    return out


def cost_at(cells: int, steps: int = 40) -> dict:
    """Set-up and per-step cost at `cells` per diameter (case 3, first steps), and the
    projected cost of case 3's first bounce there (steps scale with cells per diameter)."""
    from fem_bounce.models.ib import ImmersedBoundaryModel
    from fem_bounce.run import Controller
    from fem_bounce.models.registry import MODELS
    from fem_bounce.integrator import BodyIntegrator

    sc = scene.load("li2011-case3", {"numerics.ib.cells_per_diameter": cells})
    start = time.perf_counter()
    model = ImmersedBoundaryModel(sc, COMM)
    sc_short = sc.replace(**{"run.end_time": steps * model.dt})
    model = ImmersedBoundaryModel(sc_short, COMM)
    integrator = BodyIntegrator(sc_short, resolved=True)
    result = Controller(model, MODELS["ib"], integrator).run()
    wall = time.perf_counter() - start
    return {"cells_per_diameter": cells, "unknowns": result["sizes"]["unknowns"], "dt": model.dt,
            "steps_measured": result["steps"], "wall_time_s": round(wall, 2),
            "seconds_per_step": round(result["extra"]["ib"]["seconds_per_step"], 4),
            "note": "includes the first force tables; a whole first bounce needs ~0.1 s / dt steps"}


def check_domain(cells):
    out = {}
    for far, growth in ((8.0, 1.05), (15.0, 1.05), (30.0, 1.05), (15.0, 1.1)):
        key = f"far{far:g}_growth{growth:g}"
        s = run("sphere-drag-re100", {"numerics.ib.cells_per_diameter": cells, "numerics.ib.far_field": far,
                                      "numerics.ib.growth": growth})
        c = run("li2011-case3", {"numerics.ib.cells_per_diameter": cells, "numerics.ib.far_field": far,
                                 "numerics.ib.growth": growth, "run.bounces": 1})
        out[key] = {"Cd100": round(s["ib"]["drag_coefficient"], 4), "unknowns": s["sizes"]["unknowns"],
                    "case3": impacts(c), "cd_wall_time_s": round(s["wall_time_s"], 1)}
    return out


def check_timestep(cells):
    return {f"cfl{cfl:g}": impacts(run("li2011-case3", {"numerics.ib.cells_per_diameter": cells, "numerics.ib.cfl": cfl,
                                                       "run.bounces": 2}))
            for cfl in (0.4, 0.2)}


def check_retraction(cells):
    """The diffuse surface's thickness: points on radius a - 0.3 h (Breugem 2012) against a."""
    out = {}
    for retraction in (0.0, 0.3):
        common = {"numerics.ib.cells_per_diameter": cells, "numerics.ib.retraction": retraction}
        drag = run("sphere-drag-re100", common)
        settle = run("tencate2002-e4", common)
        bounce = impacts(run("li2011-case3", {**common, "run.bounces": 2}))
        out[f"{retraction:g}"] = {"Cd100": round(drag["ib"]["drag_coefficient"], 4),
                                  "recirculation_100": round(drag["ib"]["recirculation_length_over_D"], 3),
                                  "tencate_peak_speed": round(float(-settle["_trajectory"]["velocity"].min()), 5),
                                  "case3_impact_speed": bounce["impact_speed"], "case3_Re": bounce["Re"]}
    return out


def check_speed(cells):
    ode = run("li2011-case3", {}, model="ode")
    ib = run("li2011-case3", {"numerics.ib.cells_per_diameter": cells}, model="ib")
    return {"ode_wall_time_s": round(ode["wall_time_s"], 2), "ib_wall_time_s": round(ib["wall_time_s"], 2),
            "ratio_ib_over_ode": round(ib["wall_time_s"] / ode["wall_time_s"], 1),
            "ib_unknowns": ib["sizes"]["unknowns"], "ib_steps": ib["steps"]}


CHECKS = {"drag": check_drag, "tencate": check_tencate, "case3": check_case3, "cases": check_cases,
          "density": check_density, "resolution": check_resolution, "domain": check_domain,
          "timestep": check_timestep, "speed": check_speed, "retraction": check_retraction}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("checks", nargs="*", help=f"any of {', '.join(CHECKS)} (default: all)")
    parser.add_argument("--cells", type=float, default=32.0, help="cells per diameter (default 32)")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    unknown = set(args.checks) - set(CHECKS)
    if unknown:
        parser.error(f"unknown checks {sorted(unknown)}; choose from {', '.join(CHECKS)}")
    results = json.loads(args.out.read_text()) if args.out.exists() else {}
    results["machine"] = {"node": platform.node(), "processor": platform.processor() or platform.machine(),
                          "cpus": os.cpu_count(), "python": platform.python_version()}
    for name in args.checks or list(CHECKS):
        start = time.perf_counter()
        print(f"{name} ...", file=sys.stderr, flush=True)
        value = CHECKS[name](args.cells)
        results.setdefault(name, {})[f"{args.cells:g}"] = {
            "result": value, "date": time.strftime("%Y-%m-%d %H:%M"), "seconds": round(time.perf_counter() - start, 1)}
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(results, indent=1) + "\n")
        print(json.dumps(value, indent=1), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
