"""The near-wall force: a converged resolved reference, insensitivity to delta_sl, Fig. 7, delta_ss.

    python benchmarks/near_wall.py reference --surface-refinement 3 --finer-step   # ALE, delta_sl = 0.05,
        mesh and dt ladders for cases 1, 3, 4, 7 (--cases), the sphere's surface 3 times finer  ~1.5 h
    python benchmarks/near_wall.py insensitivity [--models ale,fd,ib]   # case 3, delta_sl = 0.1 / 0.2 / 0.3  ~15 min
    python benchmarks/near_wall.py fig7                         # f_thr against the converged ALE force (Fig. 7) ~20 min
    python benchmarks/near_wall.py dss [--model ale]            # cases 1-2 (St 20-40) against delta_ss (Fig. 12b)

Each simulation is a `fem-bounce run` in its own process (`--jobs N` runs N at once; the machine has two
cores), its run directory under results/near_wall/<study>/runs/ reused unless --force.  Each study writes
a Markdown table and JSON under results/near_wall/<study>/ and appends its rows, with date, machine and
commit, to benchmarks/history/near_wall.json.
"""
from __future__ import annotations

import argparse
import json
import math
import platform
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np

from fem_bounce import output, reference, theory
from fem_bounce import scene as scenes
from provenance import commit

ROOT = Path("results") / "near_wall"
HISTORY = Path(__file__).parent / "history" / "near_wall.json"
CFL = "numerics.ale.cfl"
# the paper's spring with the package's correction and additive f_thr: the paper's contact as the package first ran it
SPRING = {"contact.model": "li2011", "contact.near_wall": "correction", "contact.inertial_factor": "additive"}
SURFACE = "numerics.ale.surface_refinement"
CELLS = {"ale": "numerics.ale.cells_per_diameter", "fd": "numerics.fd.cells_per_diameter",
         "ib": "numerics.ib.cells_per_diameter"}


def say(message: str) -> None:
    print(message, file=sys.stderr, flush=True)


def finished(run_dir: Path) -> bool:
    """The run directory holds a run that completed (an interrupted or failed one is done again)."""
    try:
        return json.loads((run_dir / "summary.json").read_text())["status"] == "completed"
    except (OSError, ValueError, KeyError):
        return False


def run(study: str, name: str, scene: str, model: str, changes: dict, force: bool) -> Path:
    """A `fem-bounce run` of `model` on the preset with `changes`, unless its directory has a completed run."""
    run_dir = ROOT / study / "runs" / name
    if force or not finished(run_dir):
        command = [sys.executable, "-m", "fem_bounce", "run", scene, "--model", model, "--out", str(run_dir),
                   "--force", "--quiet"]
        for key, value in changes.items():
            command += ["--set", f"{key}={value}"]
        start = time.perf_counter()
        done = subprocess.run(command, capture_output=True, text=True)
        say(f"  {study}/{name}: {time.perf_counter() - start:.0f} s"
            + ("" if done.returncode == 0 else f", exit {done.returncode}: {done.stderr.strip()[-300:]}"))
    return run_dir


def run_all(study: str, jobs: list[tuple], args) -> dict[str, Path]:
    """Run (name, scene, model, changes) tuples, `args.jobs` at a time; name -> run directory.  With
    --report-only nothing runs: the tables show the completed runs there are, "-" for the others."""
    if args.report_only:
        return {name: ROOT / study / "runs" / name for name, *_ in jobs}
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = {name: pool.submit(run, study, name, sc, model, changes, args.force)
                   for name, sc, model, changes in jobs}
    return {name: future.result() for name, future in futures.items()}


def measures(run_dir: Path) -> dict:
    """V_i, Re_I, Re_II, first restitution and apex of a run [SI]; only the status if it did not complete."""
    if not finished(run_dir):
        return {"status": "not run", "wall_time_s": None, "steps": 0}
    summary = json.loads((run_dir / "summary.json").read_text())
    impacts, rebounds = summary["impacts"], summary["rebounds"]
    found = {"status": summary["status"], "wall_time_s": summary["wall_time_s"], "steps": summary["steps"]}
    if impacts:
        found.update(V_i=impacts[0]["impact_speed"], Re_I=impacts[0]["Re"])
    if len(impacts) > 1:
        found["Re_II"] = impacts[1]["Re"]
    if rebounds:
        found.update(e_1=rebounds[0]["restitution"], apex_1=rebounds[0]["apex_gap"])
    return found


def record(study: str, rows: list[dict], table: str) -> None:
    folder = ROOT / study
    folder.mkdir(parents=True, exist_ok=True)
    (folder / f"{study}.md").write_text(table)
    entry = {"study": study, "date": time.strftime("%Y-%m-%d"), "machine": platform.node(), "commit": commit(),
             "rows": rows}
    (folder / f"{study}.json").write_text(json.dumps(entry, indent=1) + "\n")
    history = json.loads(HISTORY.read_text()) if HISTORY.exists() else []
    HISTORY.write_text(json.dumps(history + [entry], indent=1) + "\n")
    print(table)


def fmt(value, spec: str) -> str:
    return "-" if value is None else format(value, spec)


def change(a: float | None, b: float | None) -> float | None:
    return None if a is None or not b else 100.0 * (a / b - 1.0)


# -- the resolved reference -----------------------------------------------------------------------------

REFERENCE_DELTA_SL = 0.05
CFL_LADDER = (0.5, 0.25, 0.125)
FINER_STEPS = (0.0625, 0.03125)


MESH_LADDER = (8, 16, 24, 32)


def ladders(case: int, finest: int = 16, surface: float = 1) -> tuple[tuple, int]:
    """Cells per diameter of the mesh ladder up to `finest`, and the mesh of the time-step ladder.  With the
    sphere's surface refined (`surface` > 1) every case climbs to `finest` with the steps at 8.  Without it,
    case 3 climbs to at least 24 cells/D with the steps at 16; the other cases, whose case-3 ladder moved
    V_i by 0.03 % from 8 to 16 cells/D, stop at 16 unless asked, with the steps at 8 (a 24-cell run costs
    half an hour, a 32-cell one over an hour)."""
    top = max(finest, 24) if case == 3 and surface == 1 else finest
    return tuple(n for n in MESH_LADDER if n <= top), 16 if case == 3 and surface == 1 else 8


def run_name(case: int, cells: int, cfl: float, surface: float = 1, collision: float | None = None) -> str:
    return (f"case{case}-ale{cells}" + (f"s{surface:g}" if surface != 1 else "") + f"-cfl{cfl:g}"
            + (f"-c{collision:g}" if collision else ""))


def collision_steps(collision: float | None) -> dict:
    """The scene values that resolve each collision in time: adaptive steps down to `collision` times the cfl
    step near the wall and never longer than it elsewhere (the fall keeps the cfl step); none if None."""
    if not collision:
        return {}
    return {"numerics.ale.adaptive_step": "true", "numerics.ale.max_step_factor": 1,
            "numerics.ale.min_step_factor": collision}


def reference_runs(case: int, cfls=CFL_LADDER, finest: int = 16, surface: float = 1,
                   mesh_cfl: float = 0.125, collision: float | None = None) -> list[tuple]:
    """The mesh ladder at `mesh_cfl` and the step ladder (`cfls`) on its mesh, as (name, scene, model,
    changes)."""
    base = {"contact.delta_sl": REFERENCE_DELTA_SL, "run.bounces": 2, **({SURFACE: surface} if surface != 1 else {}),
            "numerics.ale.factorisation": "every-step", **collision_steps(collision)}  # every step solved directly
    meshes, step_mesh = ladders(case, finest, surface)
    jobs = [(run_name(case, n, mesh_cfl, surface, collision), f"li2011-case{case}", "ale",
             {**base, CELLS["ale"]: n, CFL: mesh_cfl}) for n in meshes]
    jobs += [(run_name(case, step_mesh, c, surface, collision), f"li2011-case{case}", "ale",
              {**base, CELLS["ale"]: step_mesh, CFL: c}) for c in cfls if c != mesh_cfl]
    return jobs


def reference_study(args) -> None:
    """ALE with delta_sl = 0.05: a mesh ladder at cfl --mesh-cfl (0.125) and a time-step ladder (`ladders`),
    with the sphere's surface --surface-refinement times finer than the mesh; the finest mesh is the
    reference, converged when the two finest levels of each ladder agree within 0.5 %."""
    cases = [int(c) for c in args.cases.split(",")]
    surface = args.surface_refinement
    cfls = CFL_LADDER if surface == 1 else (0.125,)  # with a refined surface: cfl 0.125 and --finer-step only
    collision = args.collision_step
    jobs = [job for case in cases
            for job in reference_runs(case, cfls, args.finer_mesh, surface, args.mesh_cfl, collision)]
    if args.finer_step:  # the step ladder further down, where the coarser steps moved more than 0.5 %
        jobs += [job for case in cases for cfl in FINER_STEPS if cfl >= args.finer_step
                 for job in reference_runs(case, (cfl,), args.finer_mesh, surface, args.mesh_cfl, collision)[-1:]]
    if args.case3_extra:  # a finer step, and delta_sl halved again: is the reference itself converged?
        jobs += reference_runs(3, (0.0625,))[-1:]
        jobs.append(("case3-ale16-cfl0.125-dsl0.025", "li2011-case3", "ale",
                     {"contact.delta_sl": 0.025, "run.bounces": 2, CELLS["ale"]: 16, CFL: 0.125}))
    dirs = run_all("reference", jobs, args)
    measured = {int(r["case"]): r for r in reference.table("li2011_table2_experiments")}
    rows, lines = [], ["| case | ladder | level | V_i (m/s) | Re_I | Re_II | e_1 | apex / D | steps | wall time |",
                       "|---|---|---|---|---|---|---|---|---|---|"]
    for name, run_dir in dirs.items():
        found = measures(run_dir)
        case = int(name.split("-")[0][4:])
        diameter = scenes.load(f"li2011-case{case}").sphere.diameter
        rows.append({"name": name, "case": case, **found})
        lines.append(f"| {case} | {name.split('-', 1)[1]} | | {fmt(found.get('V_i'), '.4f')} | "
                     f"{fmt(found.get('Re_I'), '.2f')} | {fmt(found.get('Re_II'), '.2f')} | "
                     f"{fmt(found.get('e_1'), '.3f')} | "
                     f"{fmt(found['apex_1'] / diameter if 'apex_1' in found else None, '.4f')} | {found['steps']} | "
                     f"{fmt(found['wall_time_s'], '.0f')} s |")
    lines += ["", "Convergence (the two finest levels of each ladder) and the reference against Table 2:", "",
              "| case | mesh (two finest): V_i, Re_II | dt (two finest): V_i, Re_II | reference V_i | Re_I | Re_II | "
              "e_1 | V_i vs Table 2 | Re_II vs Table 2 |", "|---|---|---|---|---|---|---|---|---|"]
    by_name = {r["name"]: r for r in rows}
    for case in cases:
        meshes, step_mesh = ladders(case, args.finer_mesh, surface)
        fine, mid = ([by_name.get(run_name(case, n, args.mesh_cfl, surface, collision), {})
                      for n in meshes[::-1]] + [{}])[:2]
        steps = [by_name[name] for c in FINER_STEPS[::-1] + (0.125, 0.25, 0.5)
                 if (name := run_name(case, step_mesh, c, surface, collision)) in by_name and "V_i" in by_name[name]]
        step_fine, coarse_step = (steps + [{}, {}])[:2]
        ref = measured[case]
        lines.append(
            f"| {case} | {fmt(change(fine.get('V_i'), mid.get('V_i')), '+.2f')} %, "
            f"{fmt(change(fine.get('Re_II'), mid.get('Re_II')), '+.2f')} % | "
            f"{fmt(change(step_fine.get('V_i'), coarse_step.get('V_i')), '+.2f')} %, "
            f"{fmt(change(step_fine.get('Re_II'), coarse_step.get('Re_II')), '+.2f')} % | "
            f"{fmt(fine.get('V_i'), '.4f')} | "
            f"{fmt(fine.get('Re_I'), '.1f')} | {fmt(fine.get('Re_II'), '.1f')} | {fmt(fine.get('e_1'), '.3f')} | "
            f"{fmt(change(fine.get('V_i'), ref['V_i_m_per_s']), '+.1f')} % | "
            f"{fmt(change(fine.get('Re_II'), ref['Re_II']), '+.1f')} % |")
    lines += models_against(by_name, cases, args.finer_mesh, surface, args.mesh_cfl, collision)
    record("reference", rows, "\n".join(lines) + "\n")


# benchmarks/table2.py's records with the issue-23 contact, history/table2-NAME.json
TABLE2_RUNS = ("ode", "fd", "ib", "ale")


def models_against(by_name: dict, cases: list[int], finest: int, surface: float, mesh_cfl: float,
                   collision: float | None) -> list[str]:
    """Each model's Table 2 run (`python benchmarks/table2.py --model M`, the scene defaults) against the
    reference: the error in V_i, Re_II and e_1, in percent."""
    lines = ["", "Each model's Table 2 run (benchmarks/history/table2-M.json) against the reference: V_i, Re_II, "
             "e_1 (%):", "", "| case | " + " | ".join(TABLE2_RUNS) + " |", "|---" * (len(TABLE2_RUNS) + 1) + "|"]
    records = {}
    for name in TABLE2_RUNS:
        path = HISTORY.parent / f"table2-{name}.json"
        if path.exists():
            records[name] = {r["case"]: r for r in json.loads(path.read_text())["rows"]}
    for case in cases:
        meshes, _ = ladders(case, finest, surface)
        ref = by_name.get(run_name(case, meshes[-1], mesh_cfl, surface, collision), {})
        cells = []
        for name in TABLE2_RUNS:
            got = records.get(name, {}).get(case, {})
            cells.append(", ".join(fmt(change(got.get(key), ref.get(mine)), "+.1f")
                                   for key, mine in (("V_i_model", "V_i"), ("Re_II_model", "Re_II"),
                                                     ("restitution_1", "e_1"))))
        lines.append(f"| {case} | " + " | ".join(cells) + " |")
    return lines


# -- insensitivity to delta_sl ---------------------------------------------------------------------------

INSENSITIVITY_DELTA_SL = (0.1, 0.2, 0.3)


def insensitivity_study(args) -> None:
    """Case 3 with each resolved model at its default and delta_sl = 0.1, 0.2, 0.3, under the default correction
    and, for comparison, the paper's blend."""
    models = args.models.split(",")
    modes = args.modes.split(",")
    jobs = []
    for model in models:
        settings = dict(scenes.parse_override(t) for t in args.overrides)  # each model at its default but for --set
        for mode in modes:
            for delta_sl in INSENSITIVITY_DELTA_SL:
                jobs.append((f"{model}-{mode}-dsl{delta_sl}", "li2011-case3", model,
                             {**settings, "contact.near_wall": mode, "contact.delta_sl": delta_sl, "run.bounces": 2}))
    dirs = run_all("insensitivity", jobs, args)
    rows = [{"name": name, **measures(d)} for name, d in dirs.items()]
    lines = ["| model | near_wall | delta_sl | V_i (m/s) | Re_I | Re_II | e_1 | wall time |",
             "|---|---|---|---|---|---|---|---|"]
    for r in rows:
        model, mode, dsl = r["name"].split("-")
        lines.append(f"| {model} | {mode} | {dsl[3:]} | {fmt(r.get('V_i'), '.4f')} | {fmt(r.get('Re_I'), '.2f')} | "
                     f"{fmt(r.get('Re_II'), '.2f')} | {fmt(r.get('e_1'), '.3f')} | {fmt(r['wall_time_s'], '.0f')} s |")
    lines += ["", "Change from delta_sl = 0.1 to 0.3 (targets: V_i < 1 %, Re_II < 3 %):", "",
              "| model | near_wall | V_i | Re_II |", "|---|---|---|---|"]
    by_name = {r["name"]: r for r in rows}
    for model in models:
        for mode in modes:
            lo, hi = by_name[f"{model}-{mode}-dsl0.1"], by_name[f"{model}-{mode}-dsl0.3"]
            lines.append(f"| {model} | {mode} | {fmt(change(hi.get('V_i'), lo.get('V_i')), '+.2f')} % | "
                         f"{fmt(change(hi.get('Re_II'), lo.get('Re_II')), '+.2f')} % |")
    record("insensitivity", rows, "\n".join(lines) + "\n")


# -- Fig. 7: the theory force against the converged resolved force ---------------------------------------

def prescribed_approach(ode_dir: Path, folder: Path) -> dict:
    """Scene changes that prescribe the case-3 approach of the ODE run in `ode_dir` (its velocity series,
    written to folder/case3-approach.csv, up to delta_ss; the run ends at delta = 0.03), with the paper's
    blend so that f_sim is the resolved force at the true gap.  Shared with benchmarks/fd_near_wall.py."""
    import csv

    ode = output.read_trajectory(ode_dir)
    sc = scenes.load("li2011-case3")
    diameter = sc.sphere.diameter
    series_end = float(ode["t"][np.argmax(ode["gap"] <= sc.contact.delta_ss * diameter)])
    end = float(ode["t"][np.argmax(ode["gap"] <= 0.03 * diameter)])
    keep = ode["t"] <= series_end
    series = (folder / "case3-approach.csv").resolve()
    with open(series, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(["t", "velocity"])
        writer.writerows(zip(ode["t"][keep], ode["velocity"][keep]))
    return {"motion.mode": "prescribed", "motion.series": str(series), "run.end_time": end, "run.bounces": 0,
            "contact.near_wall": "blend"}


def fig7_study(args) -> None:
    """The paper's Fig. 7.  The case-3 approach (the ODE model's path to its first contact) is prescribed;
    the ALE model resolves the flow along it at two meshes and two steps (no hold, near_wall = blend so
    that the runs carry f_thr's history modes); f_thr is the default theory force along the same path."""
    folder = ROOT / "fig7"
    folder.mkdir(parents=True, exist_ok=True)
    ode_dir = run("fig7", "ode", "li2011-case3", "ode", {"run.bounces": 1}, args.force)
    path = {**prescribed_approach(ode_dir, folder), "numerics.ale.hold_delta": 0.01}
    sc = scenes.load("li2011-case3")
    diameter = sc.sphere.diameter
    variants = {"ale16": {CELLS["ale"]: 16, CFL: 0.125}, "ale24": {CELLS["ale"]: 24, CFL: 0.125},
                "ale16-dt/2": {CELLS["ale"]: 16, CFL: 0.0625}}
    if args.fd:
        variants["fd"] = {}
    jobs = [(name.replace("/", "-"), "li2011-case3", "fd" if name == "fd" else "ale", {**path, **extra})
            for name, extra in variants.items()]
    dirs = run_all("fig7", jobs, args)
    unit = sc.displaced_mass * sc.gravity  # the paper's force unit (4/3) pi a^3 rho_l g
    curves = {name: output.read_trajectory(d) for name, d in dirs.items()}
    along = curves[next(iter(curves))]  # every run follows the same path: f_thr from any of them
    stokes_unit = 6.0 * math.pi * sc.liquid.viscosity * sc.sphere.radius
    stokes = np.array([-stokes_unit * v * theory.brenner_lambda(h / diameter)
                       for h, v in zip(along["gap"], along["velocity"])])
    multiplied = scenes.load("li2011-case3", {"contact.inertial_factor": "schiller-naumann"})
    old_drag = theory.TheoryForces(multiplied)
    f_thr_old = along["f_theory"] - along["f_drag"] + np.array([old_drag.drag(h, v) for h, v in
                                                                 zip(along["gap"], along["velocity"])])

    def at(delta, data, values):
        return float(np.interp(delta, data["gap"][::-1] / diameter, values[::-1])) / unit

    reference_run = "ale24"
    rows, lines = [], ["| delta | f_thr (default) | f_thr, Schiller-Naumann multiplied | Brenner Stokes drag | "
                       + " | ".join(f"f_sim {n}" for n in curves) + f" | f_thr / f_sim {reference_run} |",
                       "|---|---|---|---|" + "---|" * len(curves) + "---|"]
    for delta in (1.0, 0.5, 0.35, 0.25, 0.2, 0.15, 0.1, 0.07, 0.05, 0.04):
        values = {n: at(delta, c, c["f_sim"]) for n, c in curves.items()}
        thr = at(delta, along, along["f_theory"])
        rows.append({"delta": delta, "f_thr": thr, "f_thr_multiplied": at(delta, along, f_thr_old),
                     "stokes": at(delta, along, stokes), **{f"f_sim_{n}": v for n, v in values.items()}})
        lines.append(f"| {delta:g} | {thr:.3f} | {at(delta, along, f_thr_old):.3f} | {at(delta, along, stokes):.3f} | "
                     + " | ".join(f"{v:.3f}" for v in values.values())
                     + f" | {thr / values[reference_run]:.3f} |")
    lines.append("\nForces in units of (4/3) pi a^3 rho_l g, positive away from the wall.")
    record("fig7", rows, "\n".join(lines) + "\n")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.8, 4.6))
    delta = along["gap"] / diameter
    ax.plot(delta, along["f_theory"] / unit, "k-", lw=1.6, label=r"$f_{thr}$, default (additive inertia)")
    ax.plot(delta, f_thr_old / unit, "k:", lw=1.2, label=r"$f_{thr}$, Brenner $\times$ Schiller-Naumann (before)")
    ax.plot(delta, stokes / unit, "k--", lw=1.0, label=r"$6\pi\mu a|V|\lambda_{Brenner}$ (Stokes)")
    lubrication = -stokes_unit * along["velocity"] * 0.5 / np.maximum(delta, 1e-9) / unit
    ax.plot(delta, lubrication, color="0.6", lw=0.8, label=r"lubrication limit $6\pi\mu a|V|/(2\delta)$")
    colors = {"ale16": "C0", "ale24": "C1", "ale16-dt/2": "C2", "fd": "C3"}
    for name, data in curves.items():
        ax.plot(data["gap"] / diameter, data["f_sim"] / unit, color=colors.get(name, "C4"), lw=1.2,
                label=rf"$f_{{sim}}$ {name}")
    ax.axvspan(0.1, 0.35, color="0.93", zorder=0, label="where the paper found overlap")
    ax.set_xlim(0.0, 1.0)
    ax.set_ylim(0.0, 1.25 * at(0.04, along, along["f_theory"]))
    ax.set_xlabel(r"$\delta = h/D$")
    ax.set_ylabel(r"force $/ (\frac{4}{3}\pi a^3 \rho_l g)$")
    ax.set_title("Fig. 7 of Li et al. (2011): case-3 approach prescribed", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(folder / "fig7.png", dpi=130)
    plt.close(fig)
    say(f"figure: {folder / 'fig7.png'}")


# -- delta_ss at low Stokes number (Fig. 12b) ------------------------------------------------------------

DSS_FACTORS = (0.9, 1.0, 1.05, 1.1)


def dss_study(args) -> None:
    """Cases 1 and 2 (second impacts at St 20-30) with the paper's spring (SPRING) at
    delta_ss = 0.017 times each factor: the error of the rebound apex and of Re_II against Table 2, as the
    paper's Fig. 12(b)."""
    model = args.model
    settings = {"ale": {CELLS["ale"]: 8, CFL: 0.25}}.get(model, {})
    jobs = [(f"case{case}-{model}-dss{factor}", f"li2011-case{case}", model,
             {**settings, **SPRING, "contact.delta_ss": round(0.017 * factor, 6), "run.bounces": 2})
            for case in (1, 2) for factor in DSS_FACTORS]
    dirs = run_all("dss", jobs, args)
    measured = {int(r["case"]): r for r in reference.table("li2011_table2_experiments")}
    rows, lines = [], ["| case | delta_ss | V_i | Re_I | Re_II | Re_II vs Table 2 | e_1 | St of 2nd impact |",
                       "|---|---|---|---|---|---|---|---|"]
    for name, run_dir in dirs.items():
        case, factor = int(name.split("-")[0][4:]), float(name.rsplit("dss", 1)[1])
        found = measures(run_dir)
        summary = json.loads((run_dir / "summary.json").read_text())
        st_2 = summary["impacts"][1]["St"] if len(summary["impacts"]) > 1 else None
        rows.append({"name": name, "case": case, "delta_ss_factor": factor, **found, "St_II": st_2})
        lines.append(f"| {case} | 0.017 x {factor:g} | {fmt(found.get('V_i'), '.4f')} | "
                     f"{fmt(found.get('Re_I'), '.1f')} | "
                     f"{fmt(found.get('Re_II'), '.1f')} | "
                     f"{fmt(change(found.get('Re_II'), measured[case]['Re_II']), '+.1f')} % | "
                     f"{fmt(found.get('e_1'), '.3f')} | {fmt(st_2, '.1f')} |")
    record("dss", rows, "\n".join(lines) + "\n")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5.6, 3.8))
    for case, marker, colour in ((1, "o", "C0"), (2, "s", "C1")):
        mine = sorted((r for r in rows if r["case"] == case and r.get("Re_II")), key=lambda r: r["delta_ss_factor"])
        for key, style in (("Re_I", "--"), ("Re_II", "-")):
            ax.plot([0.017 * r["delta_ss_factor"] for r in mine],
                    [change(r.get(key), measured[case][key]) for r in mine], style, marker=marker, color=colour,
                    label=f"case {case}, {key.replace('_', ' ')}")
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.axvline(0.017 * 1.05, color="0.7", ls=":", label=r"the paper's $\delta_{ss}$ + 5 %")
    ax.set_xlabel(r"$\delta_{ss}$")
    ax.set_ylabel("error against Table 2 (%)")
    ax.set_title(f"Fig. 12(b) of Li et al. (2011): {model} model", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(ROOT / "dss" / "dss.png", dpi=130)
    plt.close(fig)
    say(f"figure: {ROOT / 'dss' / 'dss.png'}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("study", choices=["reference", "insensitivity", "fig7", "dss"])
    parser.add_argument("--jobs", type=int, default=1, help="simulations at once (default 1)")
    parser.add_argument("--force", action="store_true", help="re-run simulations that have a summary")
    parser.add_argument("--report-only", action="store_true", help="tabulate the completed runs, run nothing")
    parser.add_argument("--cases", default="1,3,4,7", help="reference: Table 2 cases")
    parser.add_argument("--case3-extra", action="store_true",
                        help="reference: also case 3 at cfl 0.0625 and at delta_sl = 0.025")
    parser.add_argument("--finer-mesh", type=int, nargs="?", const=24, default=16, choices=MESH_LADDER,
                        metavar="CELLS", help="reference: the mesh ladder up to CELLS cells/D (24 if no value; "
                        f"one of {MESH_LADDER}) for every case (case 3 climbs to 24 anyway)")
    parser.add_argument("--mesh-cfl", type=float, default=0.125, choices=(0.125,) + FINER_STEPS,
                        help="reference: the mesh ladder's step (default 0.125)")
    parser.add_argument("--surface-refinement", type=float, default=1.0, metavar="S",
                        help="reference: the sphere's surface triangles S times finer than the mesh's "
                             "(numerics.ale.surface_refinement); the runs' names end in sS")
    parser.add_argument("--finer-step", type=float, nargs="?", const=0.0625, default=None, choices=FINER_STEPS,
                        metavar="CFL", help="reference: also the steps down to cfl CFL (0.0625 if no value; one of "
                        f"{FINER_STEPS}) on each case's step-ladder mesh")
    parser.add_argument("--collision-step", type=float, default=None, metavar="F",
                        help="reference: adaptive steps that resolve each collision in time, down to F times the "
                             "cfl step near the wall and never longer than it (the runs' names end in -cF); "
                             "without it every step has the cfl length, and one step spans a collision")
    parser.add_argument("--models", default="ale,fd,ib", help="insensitivity: resolved models")
    parser.add_argument("--modes", default="correction,blend", help="insensitivity: contact.near_wall values")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="insensitivity: extra scene values for every run")
    parser.add_argument("--fd", action="store_true", help="fig7: also the fd model along the same path")
    parser.add_argument("--model", default="ale", help="dss: the model")
    args = parser.parse_args()
    {"reference": reference_study, "insensitivity": insensitivity_study, "fig7": fig7_study,
     "dss": dss_study}[args.study](args)


if __name__ == "__main__":
    main()
