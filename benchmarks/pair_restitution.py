"""Restitution of a head-on pair against the binary Stokes number, with the ODE model.

    PYTHONPATH=. python benchmarks/pair_restitution.py            # ~45 s of CPU (100 s on the loaded machine)
    PYTHONPATH=. python benchmarks/pair_restitution.py --model ale [--jobs N]   # + the ALE points, ~2 min
    PYTHONPATH=. python benchmarks/pair_restitution.py --forces   # only the ODE-ALE force budget, ~2-3 min

The yang-hunt2006-pair preset (a 12.7 mm steel projectile onto an identical target at rest, no gravity, no
wall; Li et al. 2011's steel and glycerol-water stand in for Yang & Hunt's materials and liquids, which we
could not read) swept two ways, as the pendulum experiments vary St:
- the liquid: the viscosity from 0.8 to 0.004 Pa s at the preset's 0.3 m/s (a glycerol-water fraction
  changes the density too, 1000-1260 kg/m3; the density is held at 1203 kg/m3 here because no table of
  Yang & Hunt's mixtures was available, which changes St only through the drag on the approach);
- the speed (the pendulum's release angle): the projectile's speed one diameter before contact from 0.06
  to 1 m/s in the preset's liquid (50.2 mPa s).
St = m* V / (6 pi mu a*^2) and e both use the relative speeds where the gap passes delta_sl 2a*
(docs/physics.md section 6).  Also the momentum check: the liquid switched off (a liquid of density
1e-6 kg/m3 and viscosity 1e-12 Pa s), the pair's momentum m1 V1 + m2 V2 through the contact and e.

With --model ale, also the boundary-fitted ALE model at 8 of the viscosities (St ~5 to ~1400), each a
`run.simulate` run through the study runner and cache (fem_bounce.studies.runner; --jobs N runs N at
once), cached in results/pair_restitution/ale/ so that a re-run skips the finished ones: 10 cells/D
(the spot check at 6 and 14 cells/D, at St ~5, ~10 and ~1400, is in the record), end time 0.12 s (a rebounding
pair stops itself when its gap passes delta_sl 2a* outward; one that does not separate, at the low St,
runs on to 0.12 s, about 35 ms past its collision).

Writes results/pair_restitution/{pair_restitution.csv, pair_restitution.png} and
benchmarks/history/pair_restitution.json (each model's part replaced by its own run, the other kept);
with --model ale the figure also goes to docs/figures/pair_restitution.png.  Yang & Hunt's data, figure
and correlation could not be read (only the paper's abstract and the thesis's abstract were available),
so the figure draws what is stated, as statements, never as data points:
- Yang & Hunt (2006), abstract: the normal relative motion is characterised by an effective coefficient
  of restitution and a binary Stokes number, "with a correlation that follows the particle-wall results";
  F.-L. Yang (2006, thesis), abstract: e decreases monotonically as the binary Stokes number diminishes;
- the particle-wall results (Joseph et al. 2001, abstract): no rebound below St ~ 10, and above St ~ 500
  e appears to asymptote to its dry value; Gondret et al. (2002, abstract): e = 0 at small St, rising
  monotonically above a critical St to the dry value e_max, one master curve e / e_max = f(St).
"""
from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from fem_bounce import scene as scenes
from fem_bounce.integrator import BodyIntegrator
from fem_bounce.output import read_summary
from fem_bounce.studies.runner import Runner

PRESET = "yang-hunt2006-pair"
VISCOSITIES = np.geomspace(0.8, 0.004, 16)  # Pa s, at the preset's speed
SPEEDS = np.geomspace(0.06, 1.0, 10)  # m/s one diameter before contact, in the preset's liquid
OUT = Path("results") / "pair_restitution"
HISTORY = Path(__file__).parent / "history" / "pair_restitution.json"
FIGURE = Path(__file__).parent.parent / "docs" / "figures" / "pair_restitution.png"
ALE_VISCOSITIES = VISCOSITIES[[2, 3, 4, 5, 7, 9, 12, 15]]  # the ODE's St 7 to 1600, below and above rebound
ALE_CELLS = 10  # the sweep's resolution; the spot check: 6 cells/D at St ~5, ~10, ~1400 and 14 at St ~10, ~1400
ALE_CHECKS = [(VISCOSITIES[k], cells) for k, cells in ((2, 6), (3, 6), (15, 6), (3, 14), (15, 14))]
ALE_SETTINGS = {"run.end_time": 0.12, "numerics.ale.checkpoint_every": 0}


# --forces: the ODE and the ALE model collide the same pair; the relative velocity's change is split by
# force term over three phases (pair gap from delta_sl 2a* down to the contact, the Hertz contact, back out
# to delta_sl 2a*).  The ODE's launch speeds below bring its projectile in at the ALE's relative speed
# (the resolved projectile starts impulsively in liquid at rest and loses ~12 % of its speed at once; the
# ODE's starts as if it had been moving steadily), found by trial, not fitted to anything.
FORCE_RUNS = [  # (label, model, changes)
    ("ode, preset", "ode", {}),
    ("ode, launched at 0.255 m/s", "ode", {"second_sphere.velocity": -0.255}),
    ("ale 8 cells/D, preset", "ale", {"numerics.ale.cells_per_diameter": 8}),
    ("ale 12 cells/D, preset", "ale", {"numerics.ale.cells_per_diameter": 12}),
    ("ode, 67.5 mPa s, launched at 0.246 m/s", "ode",
     {"liquid.viscosity": VISCOSITIES[7], "second_sphere.velocity": -0.246}),
    ("ale 8 cells/D, 67.5 mPa s", "ale", {"liquid.viscosity": VISCOSITIES[7], "numerics.ale.cells_per_diameter": 8}),
]


def force_budget(run_dir: Path, model: str, scene) -> dict:
    """The relative velocity's change [m/s] from each force term in the three phases of the collision
    (in: delta_sl 2a* to the contact, contact, out: the contact to delta_sl 2a*), integrated from
    trajectory.csv.  For the ODE the liquid force is also split as the ALE's is: the increment below the
    hold -6 pi mu a_i sum_j [X_ij(h) - X_ij(hold)] V_j (what the ALE's correction adds) and the rest (what
    the ALE's held flow supplies)."""
    from fem_bounce.output import read_trajectory
    from fem_bounce.pair_contact import PairContactModel

    d = read_trajectory(run_dir)
    t, gap = d["t"], d["pair_gap"]
    masses = [s.mass for s in scene.spheres]
    hold = scene.contact.delta_sl * scenes.pair_diameter(scene.sphere, scene.second_sphere) * (1.0 - 1e-6)
    closest = int(np.argmin(gap))
    start = np.flatnonzero(gap[:closest] > hold)[-1]
    end = closest + np.flatnonzero(gap[closest:] > hold)[0]
    touching = np.flatnonzero(d["f_elastic_2"] != 0.0)
    phases = ((start, touching[0]), (touching[0], touching[-1]), (touching[-1], end))

    def pair_of(name):
        return np.array([d[f"{name}_1"], d[f"{name}_2"]])
    if model == "ode":
        held = PairContactModel(scene, resolved=True)
        engaged = read_summary(run_dir)["collisions"][0]["contact_gap"]
        velocities = pair_of("velocity")
        films = [held.law.film(gap[k], engaged if touching[0] <= k <= touching[-1] else None) for k in range(len(t))]
        increment = np.array([held.correction(h, velocities[:, k], film) for k, (h, film) in enumerate(films)]).T
        history = pair_of("f_theory") - pair_of("f_drag") - pair_of("f_pair") - pair_of("f_added_mass")
        terms = {"drag": pair_of("f_drag"), "pair Stokes": pair_of("f_pair"), "added mass": pair_of("f_added_mass"),
                 "history": history, "increment below the hold": increment,
                 "rest (the held flow's share)": pair_of("f_liquid") - increment}
    else:
        terms = {"increment below the hold": pair_of("f_correction"), "rest (the held flow's share)": pair_of("f_sim")}
    terms.update({"liquid": pair_of("f_liquid"), "elastic": pair_of("f_elastic")})
    budget = {}
    for name, force in terms.items():
        rate = force[1] / masses[1] - force[0] / masses[0]
        budget[name] = [float(np.trapezoid(rate[a:b + 1], t[a:b + 1])) for a, b in phases]
    relative = d["velocity_2"] - d["velocity_1"]
    budget["velocity change"] = [float(relative[b] - relative[a]) for a, b in phases]
    budget["contact duration [s]"] = float(t[touching[-1]] - t[touching[0]])
    return budget


def force_check() -> dict:
    """Run FORCE_RUNS (simulate, serial) and print each one's e, St and force budget."""
    from mpi4py import MPI

    from fem_bounce.run import run_logged as simulate  # the libraries' output goes to the run's run.log

    out = []
    for label, model, changes in FORCE_RUNS:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            scene = scenes.load(PRESET, {**ALE_SETTINGS, **changes} if model == "ale" else changes)
        run_dir = OUT / "forces" / label.replace(" ", "_").replace(",", "").replace("/", "")
        summary = simulate(scene, model, MPI.COMM_SELF, run_dir, force=True, progress=False, plots=False)
        c = summary["collisions"][0]
        budget = force_budget(run_dir, model, scene)
        entry = {"label": label, "model": model, "changes": changes, "St": c["St"], "impact_speed": c["impact_speed"],
                 "restitution": c["restitution"], "wall_time_s": summary["wall_time_s"],
                 "contact_duration_s": budget.pop("contact duration [s]"), "budget_in_contact_out": budget}
        out.append(entry)
        print(f"{label}: V = {c['impact_speed']:.4f} m/s, St = {c['St']:.1f}, e = {c['restitution']:.3f}, "
              f"Hertz contact {entry['contact_duration_s'] * 1e6:.0f} us")
        for name, values in entry["budget_in_contact_out"].items():
            print(f"    {name:30s}" + "".join(f"{v:+9.4f}" for v in values))
    return {"command": "PYTHONPATH=. python benchmarks/pair_restitution.py --forces", "runs": out,
            "date": time.strftime("%Y-%m-%d")}


def collide(changes: dict) -> tuple[BodyIntegrator, dict | None]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Reynolds-number warning of the thin liquids
        scene = scenes.load(PRESET, changes)
    integrator = BodyIntegrator(scene)
    integrator.advance(scene.run.end_time)
    integrator.finish()
    collisions = integrator.collisions()
    return integrator, (collisions[0] if collisions else None)


def row(sweep: str, changes: dict, key: str, value: float) -> dict:
    integrator, c = collide(changes)
    integrator.destroy()
    out = {"sweep": sweep, "viscosity": None, "launch_speed": None}
    out[key] = float(value)
    for name in ("St", "Re", "impact_speed", "restitution", "rebounded", "min_gap"):
        out[name] = None if c is None else c[name]
    print(f"{sweep} {key} = {value:.4g}: " + (f"St = {c['St']:.4g}, e = {c['restitution']:.4f}" if c
                                              else "no collision"))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--model", choices=("ode", "ale"), default="ode",
                        help="ode: the ODE sweeps only; ale: also the ALE points beside them")
    parser.add_argument("--jobs", type=int, default=1, help="ALE runs at once (one process each)")
    parser.add_argument("--forces", action="store_true",
                        help="only the ODE-ALE force budget of one collision (FORCE_RUNS), recorded as 'forces'")
    args = parser.parse_args()
    if args.forces:
        record = json.loads(HISTORY.read_text()) if HISTORY.exists() else {}
        record["forces"] = force_check()
        HISTORY.write_text(json.dumps(record, indent=1) + "\n")
        print(f"-> {HISTORY}")
        return
    start = time.perf_counter()
    rows = [row("viscosity", {"liquid.viscosity": float(mu)}, "viscosity", mu) for mu in VISCOSITIES]
    # a slow projectile needs longer than the preset's 0.2 s to cross its one diameter and come back
    rows += [row("speed", {"second_sphere.velocity": -float(v), "run.end_time": max(0.2, 0.03 / float(v))},
                 "launch_speed", v) for v in SPEEDS]
    dry, c = collide({"liquid.density": 1e-6, "liquid.viscosity": 1e-12})
    masses = np.array([s.mass for s in dry.scene.spheres])
    before = masses @ np.array([0.0, dry.scene.second_sphere.velocity])
    after = float(masses @ dry.velocity)
    dry_check = {"momentum_before": float(before), "momentum_after": after,
                 "momentum_relative_change": abs(after - before) / abs(before), "restitution": c["restitution"],
                 "relative_speed_after": float(dry.velocity[1] - dry.velocity[0]),
                 "dry_restitution_setting": dry.scene.contact.dry_restitution}
    dry.destroy()
    print(f"liquid off: momentum changed by {dry_check['momentum_relative_change']:.2e} of itself, "
          f"e = {dry_check['restitution']:.6f}")
    OUT.mkdir(parents=True, exist_ok=True)
    with open(OUT / "pair_restitution.csv", "w") as stream:
        stream.write(",".join(rows[0]) + "\n")
        for r in rows:
            stream.write(",".join("" if v is None else (v if isinstance(v, str) else f"{v:.6g}")
                                  for v in r.values()) + "\n")
    record = json.loads(HISTORY.read_text()) if HISTORY.exists() else {}
    record.update({"command": "PYTHONPATH=. python benchmarks/pair_restitution.py", "preset": PRESET,
                   "resistance": "pair_theory.PairResistance (exact two-sphere series, tabulated)",
                   "rows": rows, "liquid_off": dry_check, "wall_time_s": time.perf_counter() - start,
                   "date": time.strftime("%Y-%m-%d")})
    if args.model == "ale":
        record["ale"] = ale_sweep(rows, args.jobs)
    elif "ale" in record and record["ale"].get("date") != record["date"]:
        # the ALE points are kept from an earlier run: their ode_* columns are that day's ODE, not these rows
        record["ale"]["stale"] = (f"measured {record['ale']['date']}, before the ODE rows of {record['date']} "
                                  "(the code may have changed since): re-run with --model ale")
    figure(rows, record["ale"]["rows"] if args.model == "ale" else [])
    HISTORY.write_text(json.dumps(record, indent=1) + "\n")
    print(f"-> {OUT}/pair_restitution.csv, {OUT}/pair_restitution.png, {HISTORY}"
          + (f", {FIGURE}" if args.model == "ale" else ""))


def ale_sweep(ode_rows: list[dict], jobs: int) -> dict:
    """The ALE points (and the spot check, ALE_CHECKS), each beside the ODE's row of its viscosity."""
    from mpi4py import MPI

    points = [(float(mu), ALE_CELLS) for mu in ALE_VISCOSITIES]
    points += [(float(mu), cells) for mu, cells in ALE_CHECKS]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the Reynolds-number warning of the thin liquids
        tasks = [(scenes.load(PRESET, {**ALE_SETTINGS, "liquid.viscosity": mu,
                                       "numerics.ale.cells_per_diameter": cells}), "ale") for mu, cells in points]
    rows: list = [None] * len(points)
    with Runner(MPI.COMM_WORLD, jobs=jobs, root=OUT / "ale") as runner:
        for k, run_dir in runner.run(tasks):
            mu, cells = points[k]
            summary = read_summary(run_dir)
            c = summary["collisions"][0] if summary.get("collisions") else {}
            ode = next(r for r in ode_rows if r["sweep"] == "viscosity" and np.isclose(r["viscosity"], mu))
            rows[k] = {"viscosity": mu, "cells_per_diameter": cells, "status": summary["status"],
                       **{name: c.get(name) for name in ("St", "Re", "impact_speed", "restitution", "min_gap")},
                       "wall_time_s": summary["wall_time_s"], "steps": summary["steps"],
                       "cells": summary["sizes"]["cells"], "run_dir": run_dir.name,
                       **{f"ode_{name}": ode[name] for name in ("St", "impact_speed", "restitution")}}
            print(f"ale {cells} cells/D, viscosity {mu:.4g}: "
                  + (f"V = {c['impact_speed']:.4f} m/s, St = {c['St']:.4g}, e = {c['restitution']:.4f}" if c
                     else "no collision") + f" ({summary['wall_time_s']:.1f} s)")
    return {"command": "PYTHONPATH=. python benchmarks/pair_restitution.py --model ale --jobs 1 (under nice)",
            "settings": {**ALE_SETTINGS, "numerics.ale.cells_per_diameter": ALE_CELLS},
            "rows": rows, "runs_wall_time_s": sum(r["wall_time_s"] for r in rows),  # as run, not as read
            "date": time.strftime("%Y-%m-%d")}


def figure(rows: list[dict], ale_rows: list[dict]) -> None:
    fig, ax = plt.subplots(figsize=(7.5, 4.8))
    for sweep, style, label in (("viscosity", "o-", "ODE model, viscosity swept (0.3 m/s)"),
                                ("speed", "s--", "ODE model, speed swept (50.2 mPa s)")):
        done = [r for r in rows if r["sweep"] == sweep and r["St"] is not None]
        ax.semilogx([r["St"] for r in done], [r["restitution"] for r in done], style, ms=4, label=label)
    for cells, style in ((ALE_CELLS, "D"), (6, "x"), (14, "+")):
        done = [r for r in ale_rows if r["cells_per_diameter"] == cells and r["St"] is not None]
        if done:
            label = f"ALE model, viscosity swept, {cells} cells/D" + ("" if cells == ALE_CELLS else " (check)")
            ax.semilogx([r["St"] for r in done], [r["restitution"] for r in done], style, color="k", ms=6,
                        mfc="none", label=label)
    ax.axvspan(1.0, 10.0, color="0.85", lw=0)
    ax.text(3.2, 0.95, "particle-wall:\nno rebound below\nSt ~ 10\n(Joseph et al.\n2001, abstract)",
            ha="center", va="top", fontsize=7)
    ax.axvspan(500.0, 3000.0, color="0.92", lw=0)
    ax.text(1200.0, 0.3, "particle-wall:\ne appears to\nasymptote to its\ndry value above\nSt ~ 500\n"
            "(Joseph et al.\n2001, abstract)", ha="center", fontsize=7)
    ax.annotate("Yang & Hunt (2006, abstract) and Yang (2006, thesis abstract), pair collisions:\n"
                "e decreases monotonically as the binary St diminishes, with a correlation that\n"
                "follows the particle-wall results (stated; their data could not be read)",
                xy=(12.0, 0.04), fontsize=7)
    ax.set_xlim(1.0, 3000.0)
    ax.set_ylim(0.0, 1.05)
    ax.set_xlabel(r"binary Stokes number $St = m^* V / (6 \pi \mu a^{*2})$")
    ax.set_ylabel(r"e (relative speeds where the gap passes $\delta_{sl}\,2a^*$)")
    ax.legend(loc="center left", bbox_to_anchor=(0.36, 0.33), fontsize=7)
    fig.tight_layout()
    fig.savefig(OUT / "pair_restitution.png", dpi=130)
    if ale_rows:
        fig.savefig(FIGURE, dpi=90)  # the committed copy, small
    plt.close(fig)


if __name__ == "__main__":
    main()
