"""Which numerical parameter the fd model's error on case 3 follows.

    python benchmarks/fd_sensitivity.py                       # every sweep at the default 8 cells/D (~3 minutes)
    python benchmarks/fd_sensitivity.py --cells 12 --only cfl,collision_steps
    python benchmarks/fd_sensitivity.py --cells 8 --only default   # the default row alone (a ladder: 6, 8, 12, 16)
    python benchmarks/fd_sensitivity.py --variant model=ib    # side by side, one after the other
    python benchmarks/fd_sensitivity.py --fit 6,8,12,16       # order and limit of the ladder's errors (no runs)
    python benchmarks/fd_sensitivity.py --fit 12,16,24 --fit-set numerics.fd.peak_cfl=0.2  # the same, half the step
    python benchmarks/fd_sensitivity.py --fit 8,12,16,24,32 --fit-order 1 --fit-set ...  # the order held at 1
    python benchmarks/fd_sensitivity.py --cells 32 --step 1 --only default  # the step held at the reference's
    python benchmarks/fd_sensitivity.py --fit 8,16,32 --fit-step 1          # the mesh's own order (step held)

Li case 3 to the second impact (run.bounces = 2), serial, with one parameter changed at a time from the fd
default at a fixed resolution; V_i, Re_II, e_1 and the first apex against the converged ALE reference
(benchmarks/near_wall.py reference, with the tension limit: docs/validation.md section 1, read from
history/near_wall.json).  A parameter whose change moves the error by as much as the error itself is
where the error lives.  Results are merged into history/fd_sensitivity.json with the date, machine,
commit and the 1-minute load average (wall times are only comparable within one run).
"""
from __future__ import annotations

import argparse
import json
import os
import time
import warnings
from pathlib import Path

import numpy as np

import fem_bounce as fb
from provenance import stamp

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "history" / "fd_sensitivity.json"
# near_wall.py reference: ALE, 16 cells/D, the surface at D / 96, cfl 0.125, each collision resolved in time
REFERENCE_ROW = "case3-ale16s6-cfl0.125-c0.05"
# its step, 0.125 (D / 16) / U, as the fd model's peak_cfl at N cells/D (dt = peak_cfl (D / N) / (1.5 U),
# domain.time_step)
REFERENCE_STEP_CFL_PER_CELL = 0.125 * 1.5 / 16
STILL = 0.02  # [%] errors that move less than this across a ladder have no order to fit

# one parameter at a time: name -> the --set values tried (the fd default is the first row, "default")
SWEEPS = {
    "cfl": ["numerics.fd.peak_cfl=1.6", "numerics.fd.peak_cfl=0.4"],  # the step doubled and halved (the default: 0.8)
    "mesh": ["numerics.fd.mesh=fixed"],  # the fixed mesh at the same fine size (the default before the moving one)
    "collision_steps": ["numerics.fd.min_step_factor=0.0125", "numerics.fd.gap_fraction=0.2"],
    "constant_step": ["numerics.fd.adaptive_step=false", "numerics.fd.adaptive_step=false,numerics.fd.peak_cfl=0.4"],
    "penalty_strength": ["numerics.fd.penalty_strength=1e4", "numerics.fd.penalty_strength=1e6"],
    "interface_width": ["numerics.fd.interface_width=1", "numerics.fd.interface_width=4"],
    "delta_sl": ["contact.delta_sl=0.1", "contact.delta_sl=0.3"],
    "far_field": ["numerics.fd.far_field=20"],
    # the moving mesh's surface triangles 1.25 times coarser and 1.2 times finer (the default 5: D / 40)
    "surface": ["numerics.fd.surface_refinement=4", "numerics.fd.surface_refinement=6"],
    # the path's triangles 1.5 times finer, the surface's as the default's (at the default 8 cells/D: D / 40)
    "path": ["numerics.fd.cells_per_diameter=12,numerics.fd.surface_refinement=3.33333"],
    "grading": ["numerics.fd.grading=0.1"],  # the moving mesh's growth away from the fine region, as the fixed one's
    # the one-shot penalty on the fixed mesh (its own sweeps: forcing_number, peak_cfl, radius_offset)
    "penalty": ["numerics.fd.mesh=fixed,numerics.fd.constraint=penalty,numerics.fd.patch=false"],
}


def reference() -> dict:
    """The latest reference row of history/near_wall.json (the tension-limited one is the last)."""
    rows = [row for record in json.loads((HERE / "history" / "near_wall.json").read_text())
            for row in record.get("rows", []) if row.get("name") == REFERENCE_ROW]
    row = rows[-1]
    return {"V_i": row["V_i"], "Re_II": row["Re_II"], "e_1": row["e_1"], "apex_1": row["apex_1"]}


def measure(cells: float, settings: list[str], step: float | None = None) -> dict:
    """One run; a setting "model=NAME" runs that model at its own default resolution instead of fd at `cells`;
    `step`: the fd step held at that many times the reference's, whatever `cells` (numerics.fd.peak_cfl set to it)."""
    model = next((item.split("=", 1)[1] for item in settings if item.startswith("model=")), "fd")
    settings = [item for item in settings if not item.startswith("model=")]
    resolution = [f"numerics.fd.cells_per_diameter={cells:g}"] if model == "fd" else []
    if step is not None and model == "fd":
        resolution.append(f"numerics.fd.peak_cfl={step_cfl(cells, step):.6g}")
    overrides = ["run.bounces=2", *resolution, *settings]  # as --set takes them
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        result = fb.simulate(fb.load("li2011-case3", overrides), model)
    impacts, rebounds = result.impacts, result.rebounds
    row = {"set": settings, "status": result.status, "wall_time_s": result.wall_time,
           "steps": result.summary["steps"]}
    if len(impacts) >= 2 and rebounds:
        row.update(V_i=impacts[0].impact_speed, Re_II=impacts[1].Re, e_1=rebounds[0].restitution,
                   apex_1=rebounds[0].apex_gap)
    return row


def step_cfl(cells: float, step: float) -> float:
    """The fd model's peak_cfl at `cells` cells/D whose step is `step` times the reference's."""
    return step * REFERENCE_STEP_CFL_PER_CELL * cells


def _renamed(setting: str) -> str:
    """A history row's key=value as it is spelled now: numerics.fd.cfl is numerics.fd.peak_cfl, the same number."""
    return "numerics.fd.peak_cfl=" + setting.split("=", 1)[1] if setting.startswith("numerics.fd.cfl=") else setting


def default_mesh() -> str:
    """The fd default's numerics.fd.mesh (records before it was a setting are the fixed mesh's)."""
    return fb.load("li2011-case3").numerics.fd.mesh


def fit(cells: list[float], setting: str | None = None, order: float | None = None,
        step: float | None = None) -> None:
    """Print the order p and the limit E_0 of E = E_0 + C h^p (h = D / cells, least squares; exact through three
    levels) for each error, through the latest default row at each of `cells` in the history, on the default's
    mesh, or the latest row run with `setting` (comma-separated key=value, as --variant takes it), against the
    reference as it is now (a row keeps its values, not its errors).  With `order` p is held there (linear least
    squares; the largest distance of a level from the line is printed).  With `step` only the rows run with the
    step held at that many times the reference's (--step), without it only the rows run at their peak_cfl.  A row
    of the history run before numerics.fd.cfl was named peak_cfl (the same number) counts as set with peak_cfl."""
    from scipy.optimize import curve_fit

    latest, mesh = {}, default_mesh()
    wanted = setting.split(",") if setting else []
    for record in json.loads(RESULTS.read_text()):
        for row in record["rows"]:
            chosen = [_renamed(s) for s in row["set"]] == wanted if wanted else row["sweep"] == "default"
            if (chosen and "V_i" in row and record.get("mesh", "fixed") == mesh
                    and record.get("step_of_reference") == step):
                latest[record["cells_per_diameter"]] = (record["date"], row)
    missing = [n for n in cells if n not in latest]
    if missing:
        held = "" if step is None else f" with the step at {step:g} times the reference's"
        raise SystemExit(f"no {setting or 'default'} row{held} at {missing} cells/D in {RESULTS}: run it first")
    h = 1.0 / np.array(cells)
    print("cells/D: " + ", ".join(f"{n:g} ({latest[n][0]})" for n in cells))
    ref = reference()
    for key in ref:
        errors = np.array([100.0 * (latest[n][1][key] / ref[key] - 1.0) for n in cells])
        listed = " / ".join(f"{e:+.2f}" for e in errors)
        if np.ptp(errors) < STILL:  # nothing to fit an order to
            print(f"{key:6s} errors {listed} %: moves by {np.ptp(errors):.3f} % across the levels (below {STILL} %)")
            continue
        if order is not None:
            basis = np.column_stack([np.ones_like(h), (h / h[0]) ** order])
            (limit, slope), *_ = np.linalg.lstsq(basis, errors, rcond=None)
            apart = np.abs(basis @ (limit, slope) - errors).max()
            print(f"{key:6s} errors {listed} %: order {order:g} (held), limit {limit:+.2f} %, levels within "
                  f"{apart:.3f} % of the line")
            continue
        (limit, _, p), _ = curve_fit(lambda x, e0, c, p: e0 + c * (x / h[0]) ** p, h, errors,
                                     p0=(0.0, errors[0], 1.0), maxfev=20000)
        print(f"{key:6s} errors {listed} %: order {p:.2f}, limit {limit:+.2f} %")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cells", type=float, default=8.0, help="numerics.fd.cells_per_diameter (default 8)")
    parser.add_argument("--only", help="comma-separated sweeps (default: all; 'default': the default row alone): "
                        + ", ".join(SWEEPS))
    parser.add_argument("--variant", action="append", default=[],
                        help="an extra row: comma-separated key=value settings (repeatable)")
    parser.add_argument("--no-default", action="store_true", help="skip the default row")
    parser.add_argument("--fit", help="comma-separated cells/D: fit order and limit to the history's default rows "
                        "there (no runs)")
    parser.add_argument("--fit-order", type=float, help="with --fit: hold the order there (e.g. 1)")
    parser.add_argument("--fit-set", help="with --fit: the rows run with these settings instead (e.g. "
                        "numerics.fd.peak_cfl=0.2)")
    parser.add_argument("--step", type=float, help="hold the fd step at this many times the reference's (0.125 D / "
                        "16 / U) at any --cells: numerics.fd.peak_cfl = step * 0.1875 * cells / 16")
    parser.add_argument("--fit-step", type=float, help="with --fit: the rows run with --step at this value")
    args = parser.parse_args()
    for name, value in (("--step", args.step), ("--fit-step", args.fit_step)):
        if value is not None and not value > 0:
            parser.error(f"{name} {value:g}: the step factor must be above 0 (1: the reference's step)")
    if args.fit_order is not None and not args.fit_order > 0:
        parser.error(f"--fit-order {args.fit_order:g}: the order must be above 0 (e.g. 1)")
    if args.fit:
        return fit([float(n) for n in args.fit.split(",")], args.fit_set, args.fit_order, args.fit_step)
    names = args.only.split(",") if args.only else ([] if args.variant else list(SWEEPS))
    names = [name for name in names if name != "default"]
    rows = [] if args.no_default else [("default", [])]
    rows += [(name, setting.split(",")) for name in names for setting in SWEEPS[name]]
    rows += [("variant", variant.split(",")) for variant in args.variant]
    if args.step is not None:
        clash = [",".join(settings) for _, settings in rows
                 if any(s.startswith("numerics.fd.peak_cfl=") for s in settings)]
        if clash:
            parser.error(f"--step holds numerics.fd.peak_cfl (at {step_cfl(args.cells, args.step):.4g} here): drop the "
                         f"rows that set it ({'; '.join(clash)}), e.g. --only with other sweeps")
    ref = reference()
    record = {**stamp(), "load_1min": os.getloadavg()[0], "cells_per_diameter": args.cells, "mesh": default_mesh(),
              "reference": ref, "rows": [], **({} if args.step is None else {"step_of_reference": args.step})}
    print(f"reference (ALE {REFERENCE_ROW}): " + ", ".join(f"{k} {v:.4g}" for k, v in ref.items()))
    print(f"{'sweep':16s} {'setting':48s} " + " ".join(f"{k:>7s}" for k in ("V_i", "Re_II", "e_1", "apex", "steps"))
          + f" {'wall':>7s}")
    for name, settings in rows:
        start = time.perf_counter()
        row = measure(args.cells, settings, args.step)
        row["sweep"] = name
        record["rows"].append(row)
        errors = [100.0 * (row[k] / ref[k] - 1.0) if k in row else float("nan") for k in ref]
        print(f"{name:16s} {','.join(settings) or '(fd default)':48s} "
              + " ".join(f"{e:+6.2f}%" for e in errors)
              + f" {row['steps']:6d} {time.perf_counter() - start:6.1f}s", flush=True)
    history = json.loads(RESULTS.read_text()) if RESULTS.exists() else []
    RESULTS.write_text(json.dumps(history + [record], indent=1) + "\n")


if __name__ == "__main__":
    main()
