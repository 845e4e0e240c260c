"""The approach to the wall at finite Re: the resolved (ALE) force against the reduced model's terms.

    PYTHONPATH=. python benchmarks/near_wall_map.py --fit    # ~20 min serial the first time (runs reused from
                                                              # results/near_wall/map/runs/; --force redoes them)
    PYTHONPATH=. python benchmarks/near_wall_map.py --report-only   # the table and figure from the runs there are

Two families of paths, each resolved by the ALE model at 12 and 16 cells/D:

- **prescribed**: Li's case-3 sphere and liquid (D = 9.5 mm, 1203 kg/m3, 50.2 mPa s) started from rest 4 D above
  the wall, brought to the speed U of Re = rho U D / mu = 5, 20, 50, 150 over its first half diameter
  (V = -U sin^2(pi t / 2 t_r), t_r = D / U) and driven at U toward the wall down to 0.012 D (the mesh follows
  it to hold_delta 0.01; near_wall = blend, so f_sim is the resolved force at the true gap);
- **free**: case 3 falling from rest in MU = 0.05, 0.07, 0.12, 0.18 Pa s (first impact at St 64, 44, 24, 14), the
  hold at delta_sl = 0.05 so that the flow is resolved down to 0.05 D (below it f_liquid is the held flow plus
  the Stokes increment, which is the theory's own; only gaps >= 0.05 D are mapped), and with the ALE model's
  defaults (hold at 0.2 D, the cfl step).

The prescribed and the first free runs take steps that move the sphere by at most 5 % of its gap: at the cfl
step the ALE model's rebound is not converged below St ~ 25 (e 10 % high at St 14, docs/physics.md 3.7).
Then case 3 with the ode model (its default and the additive law) against both ALE families: V_i, e, apex.

Along each resolved path the reduced model's terms are evaluated on the same (t, h, V, dV/dt)
(fem_bounce.theory.forces_along: quasi-steady drag with Brenner's wall factor, added mass, history), for the
variants of LAWS; the table gives f_thr / f_resolved at each gap.  Writes
benchmarks/history/near_wall_map.json and docs/figures/near_wall_map.png.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

import fem_bounce as fb
from fem_bounce import output, theory
from near_wall import ROOT as RUNS_ROOT, finished, run
from provenance import ROOT, stamp

PRESCRIBED_RE = (5, 20, 50, 150)
FREE_MU = (0.05, 0.07, 0.12, 0.18)  # Pa s
CELLS = (12, 16)
GAPS = (2.0, 1.0, 0.7, 0.5, 0.35, 0.25, 0.2, 0.15, 0.1, 0.07, 0.05, 0.03, 0.02)  # h / D
START, END = 4.0, 0.012  # the prescribed paths' first and last gap / D
# the reduced model's variants evaluated along each path: the unscreened law, its default, and the default
# with the exact potential-flow added mass (Milne-Thomson's image sum) in place of the first image
LAWS = {"additive": {"contact.inertial_factor": "additive"}, "screened": {"contact.inertial_factor": "screened"},
        "screened+exact": {"contact.inertial_factor": "screened", "contact.added_mass": "exact"}}
# steps that move the sphere by at most 5 % of its gap (numerics.ale.adaptive_step), down to 1/50 of the cfl step
ADAPTIVE = {"numerics.ale.adaptive_step": "true", "numerics.ale.max_step_factor": 1,
            "numerics.ale.min_step_factor": 0.02}
RECORD = ROOT / "benchmarks" / "history" / "near_wall_map.json"
FIGURE = ROOT / "docs" / "figures" / "near_wall_map.png"


def prescribed_changes(reynolds: float, folder: Path) -> dict:
    """Scene changes for the constant-speed approach at this Re (its series written into folder)."""
    sc = fb.load("li2011-case3")
    diameter = sc.sphere.diameter
    speed = reynolds * sc.liquid.viscosity / (sc.liquid.density * diameter)
    ramp = diameter / speed
    end = ramp + (START - END - 0.5) * diameter / speed
    t = np.concatenate([np.linspace(0.0, ramp, 41), np.linspace(ramp, 1.2 * end, 40)[1:]])
    velocity = -speed * np.where(t < ramp, np.sin(0.5 * math.pi * np.minimum(t / ramp, 1.0)) ** 2, 1.0)
    series = (folder / f"approach-re{reynolds:g}.csv").resolve()
    folder.mkdir(parents=True, exist_ok=True)
    series.write_text("t,velocity\n" + "".join(f"{a:.10g},{b:.10g}\n" for a, b in zip(t, velocity)))
    return {"motion.mode": "prescribed", "motion.series": str(series), "initial_gap": START * diameter,
            "run.end_time": end, "run.bounces": 0, "contact.near_wall": "blend", "numerics.ale.hold_delta": 0.01,
            **ADAPTIVE}


def paths(args) -> dict[str, Path]:
    """name -> run directory, every path at every resolution (run here unless done or --report-only)."""
    folder = RUNS_ROOT / "map"
    jobs = {}
    for reynolds in PRESCRIBED_RE:
        for cells in CELLS:
            jobs[f"re{reynolds}-c{cells}"] = {**prescribed_changes(reynolds, folder),
                                             "numerics.ale.cells_per_diameter": cells}
    for mu in FREE_MU:
        for cells in CELLS:
            free = {"liquid.viscosity": mu, "run.bounces": 1, "numerics.ale.cells_per_diameter": cells}
            jobs[f"mu{mu}-c{cells}"] = {**free, "contact.delta_sl": 0.05, **ADAPTIVE}
            jobs[f"default-mu{mu}-c{cells}"] = free  # the ALE model's defaults: hold at 0.2 D, the cfl step
    dirs = {}
    for name, changes in jobs.items():
        dirs[name] = (folder / "runs" / name if args.report_only else
                      run("map", name, "li2011-case3", "ale", changes, args.force))
    return {name: d for name, d in dirs.items() if finished(d)}


def targets(dirs: dict[str, Path]) -> dict:
    """Case 3 at each MU: the ode model (its default and the additive law) against the ALE runs, the 2 ms impact
    speed V_i [m/s], e and the first apex [mm]; prints the table."""
    found = {}
    print("\n| MU [Pa s] | run | V_i [m/s] | e | apex [mm] |\n|---|---|---|---|---|")
    for mu in FREE_MU:
        rows = {}
        for law in ("default", "additive"):
            sc = fb.load("li2011-case3", {"liquid.viscosity": mu, "run.bounces": 1}
                         | ({} if law == "default" else {"contact.inertial_factor": law}))
            impact, rebound = (lambda r: (r.impacts[0], r.rebounds[0]))(fb.simulate(sc, "ode"))
            rows[f"ode {law}"] = {"impact_speed": impact.impact_speed, "restitution": rebound.restitution,
                                  "apex_gap": rebound.apex_gap}
        for family, label in (("mu", "ale, hold 0.05 D, adaptive step"), ("default-mu", "ale, its defaults")):
            for cells in CELLS:
                if f"{family}{mu}-c{cells}" in dirs:
                    rows[f"{label}, {cells} cells/D"] = summary(dirs[f"{family}{mu}-c{cells}"])
        for name, row in rows.items():
            print(f"| {mu} | {name} | {row['impact_speed']:.4f} | {row['restitution']:.3f} | "
                  f"{1e3 * row['apex_gap']:.3f} |")
        found[str(mu)] = rows
    return found


def approach(run_dir: Path) -> dict[str, np.ndarray]:
    """The resolved path up to its first contact (or its end), with the reduced terms along it for each law."""
    data = output.read_trajectory(run_dir)
    sc = fb.load(run_dir / "scene.toml")
    touching = np.flatnonzero(data["f_elastic"] != 0.0)
    keep = slice(0, touching[0] if len(touching) else len(data["t"]))
    path = {k: data[k][keep] for k in ("t", "gap", "velocity", "acceleration", "f_sim", "f_liquid")}
    path["resolved"] = path["f_sim"] if sc.contact.near_wall == "blend" else path["f_liquid"]
    for law in LAWS:
        terms = theory.forces_along(sc.replace(**LAWS[law]), *(path[k] for k in (
            "t", "gap", "velocity", "acceleration")))
        path.update({f"{law}:{k}": v for k, v in terms.items()})
    path["delta"] = path["gap"] / sc.sphere.diameter
    path["mu_a"] = sc.liquid.viscosity * sc.sphere.radius
    path["Re"] = np.array([sc.reynolds(abs(v)) for v in path["velocity"]])
    return path


def at(path: dict, key: str, delta: float) -> float | None:
    """The mean of a column over the rows with h/D within 12 % of delta (None where the path has none there): the
    resolved force moves by a few per cent from one step to the next as the mesh is rebuilt."""
    near = (path["delta"] > delta / 1.12) & (path["delta"] < delta * 1.12)
    return float(path[key][near].mean()) if near.any() else None


def fit(curves: dict) -> None:
    """The two constants of theory.wall_screening that bring the screened law nearest the prescribed paths at
    Re <= 50 (16 cells/D, h/D 0.05-2; the Re-150 path is left out to show how far the form carries): least
    squares on f_thr / f_resolved - 1 over a grid.  Prints them; nothing is written."""
    samples = []
    for name, path in curves.items():
        if name.startswith("re") and name.endswith("-c16") and int(name[2:].split("-")[0]) <= 50:
            path["unit"] = 6.0 * math.pi * path["mu_a"] * np.abs(path["velocity"])  # the Stokes drag [N]
            path["phi"] = np.array([theory.schiller_naumann(re) for re in path["Re"]])
            samples += [[delta, *(at(path, k, delta) for k in ("resolved", "additive:theory", "phi", "unit"))]
                        for delta in np.geomspace(0.05, 2.0, 16)]
    delta, resolved, additive, phi, unit = np.array(samples).T
    best = min(((np.sqrt(np.mean(((additive - unit * np.minimum(phi - 1.0, d0 / (1.0 + (delta / g0) ** 2)))
                                   / resolved - 1.0) ** 2)), d0, g0)
                for d0 in np.arange(0.30, 0.71, 0.02) for g0 in np.arange(0.5, 2.01, 0.05)))
    print(f"fit: rms {best[0]:.4f} at Delta_0 = {best[1]:.2f}, delta_0 = {best[2]:.2f} "
          f"(theory.SCREENED_DRAG, SCREENED_GAP: {theory.SCREENED_DRAG}, {theory.SCREENED_GAP})")


def summary(run_dir: Path) -> dict:
    found = output.read_summary(run_dir)
    impact, rebound = found["impacts"][0], found["rebounds"][0]
    return {"impact_speed": impact["impact_speed"], "St": impact["St"], "restitution": rebound["restitution"],
            "apex_gap": rebound["apex_gap"], "wall_time_s": found["wall_time_s"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--force", action="store_true", help="redo the runs")
    parser.add_argument("--report-only", action="store_true", help="run nothing; report the runs there are")
    parser.add_argument("--fit", action="store_true", help="also print the screened law's best constants")
    args = parser.parse_args()
    dirs = paths(args)
    curves = {name: approach(run_dir) for name, run_dir in dirs.items() if not name.startswith("default")}
    rows = {}
    for name, path in curves.items():
        floor = 0.05 if name.startswith("mu") else 0.02  # the hold (free) or the last gap resolved
        rows[name] = [{"delta": d, "Re": at(path, "Re", d), "resolved": at(path, "resolved", d),
                       **{law: at(path, f"{law}:theory", d) for law in LAWS}}
                      for d in GAPS if d >= floor and at(path, "resolved", d) is not None]
    # the table: f_thr / f_resolved per path at the finer mesh, and the mesh's own change (16 against 12)
    print("| path | " + " | ".join(f"{d:g}" for d in GAPS) + " |\n|---|" + "---|" * len(GAPS))
    for name in dict.fromkeys(n.rsplit("-", 1)[0] for n in rows):
        fine, coarse = ({r["delta"]: r for r in rows.get(f"{name}-c{c}", [])} for c in (16, 12))
        table = {"Re": [f"{fine[d]['Re']:.0f}" if d in fine else "" for d in GAPS],
                 "ALE 16/12": [f"{fine[d]['resolved'] / coarse[d]['resolved']:.3f}" if d in fine and d in coarse
                               else "" for d in GAPS]}
        table |= {law: [f"{fine[d][law] / fine[d]['resolved']:.3f}" if d in fine else "" for d in GAPS]
                  for law in LAWS}
        for label, cells in table.items():
            print(f"| {name} {label} | " + " | ".join(cells) + " |")
    record = {**stamp(), "laws": LAWS, "paths": rows, "case3": targets(dirs)}
    RECORD.write_text(json.dumps(record, indent=1) + "\n")
    print(f"-> {RECORD}")
    if args.fit:
        fit(curves)
    figure(curves)


def figure(curves: dict) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fine = [n for n in curves if n.endswith("-c16")]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), sharey=True)
    for ax, family in zip(axes, ("re", "mu")):
        for k, name in enumerate(n for n in fine if n.startswith(family)):
            path, colour = curves[name], f"C{k}"
            grid = np.geomspace(0.05 if family == "mu" else 0.015, min(2.5, 0.85 * path["delta"].max()), 60)
            resolved = np.array([at(path, "resolved", d) for d in grid])
            for law, style in zip(LAWS, ("--", "-", ":")):
                ax.plot(grid, [at(path, f"{law}:theory", d) for d in grid] / resolved, style, color=colour,
                        lw=1.1, label=f"{name.rsplit('-', 1)[0]}: {law}")
        ax.axhline(1.0, color="0.5", lw=0.6)
        ax.axhspan(0.97, 1.03, color="0.92", zorder=0)
        ax.set_xscale("log")
        ax.set_xlim(0.01, 3.0)
        ax.set_xlabel(r"$\delta = h/D$")
        ax.set_title("prescribed approach at constant Re" if family == "re" else "free case-3 sphere, MU [Pa s]",
                     fontsize=9)
        ax.legend(fontsize=6.5, ncol=2)
    axes[0].set_ylim(0.7, 1.3)
    axes[0].set_ylabel(r"$f_{thr} / f_{resolved}$ (ALE, 16 cells/D; means over $\pm$12 % in h)")
    fig.tight_layout()
    FIGURE.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(FIGURE, dpi=130)
    plt.close(fig)
    print(f"-> {FIGURE}")


if __name__ == "__main__":
    main()
