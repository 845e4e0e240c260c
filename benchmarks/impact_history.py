"""The history force across an impact, judged by the resolved flow.

    PYTHONPATH=. python benchmarks/impact_history.py          # ~10 min serial on the first call (ale runs
                                                              # cached in results/impact_history/; ode: s)
    PYTHONPATH=. python benchmarks/impact_history.py --ode-only   # the ode rows against the recorded ale rows

Li et al.'s case 3 with the liquid's viscosity set so that the first impact comes at St ~15, 25, 40 and 80
(0.165, 0.112, 0.076 and 0.0405 Pa s; the sphere falls from rest under gravity), to the first apex.  Each
scene runs with the ode model under each history treatment (contact.history_across_contact) and with the
ale model at 12 and 16 cells per diameter (the converged reference: the two differ by about 1 %).  For each
run: e (the 2 ms means), the first apex, and from the loss audit (fem_bounce.losses) the liquid's impulse in
the approach, contact and rebound phases, by term, as a share of the momentum brought in.  Prints a table
and writes benchmarks/history/impact_history.json.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

from mpi4py import MPI

import fem_bounce as fb
from fem_bounce.cache import cached_run
from fem_bounce.output import read_summary
from provenance import ROOT, stamp

VISCOSITIES = {15: 0.165, 25: 0.112, 40: 0.076, 80: 0.0405}  # Pa s: the first impact's St, ode
ALE_CELLS = (12, 16)
TREATMENTS = ("keep", "pause")
RECORD = ROOT / "benchmarks" / "history" / "impact_history.json"


def scene(viscosity: float, **changes) -> fb.Scene:
    return fb.load("li2011-case3", {"liquid.viscosity": viscosity, "run.bounces": 1, **changes})


def measured(run_dir: Path) -> dict:
    summary = read_summary(run_dir)
    impact, rebound = summary["impacts"][0], summary["rebounds"][0]
    audit = impact.get("losses") or {}
    return {"St": impact["St"], "impact_speed": impact["impact_speed"], "restitution": rebound["restitution"],
            "apex_gap": rebound["apex_gap"], "share": audit.get("share"), "phases": audit.get("phases")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=ROOT / "results" / "impact_history")
    parser.add_argument("--ode-only", action="store_true",
                        help="run the ode rows only, against the ale rows of the record (which is left as it is)")
    args = parser.parse_args()
    recorded = json.loads(RECORD.read_text())["runs"] if args.ode_only else {}
    rows = {}
    for target, viscosity in VISCOSITIES.items():
        runs = {f"ode {t}": (scene(viscosity, **{"contact.history_across_contact": t}), "ode") for t in TREATMENTS}
        if not args.ode_only:
            runs |= {f"ale {c}": (scene(viscosity, **{"numerics.ale.cells_per_diameter": c}), "ale")
                     for c in ALE_CELLS}
        rows[target] = {name: measured(cached_run(sc, model, MPI.COMM_SELF, root=args.root))
                        for name, (sc, model) in runs.items()}
        rows[target] |= {name: row for name, row in recorded.get(str(target), {}).items() if name.startswith("ale")}
        reference = rows[target][f"ale {ALE_CELLS[-1]}"]
        print(f"St ~{target} (mu = {viscosity} Pa s): ale {ALE_CELLS[-1]} cells/D e {reference['restitution']:.3f} "
              f"apex {1e3 * reference['apex_gap']:.3f} mm")
        for name, row in rows[target].items():
            e, apex = row["restitution"], row["apex_gap"]
            print(f"  {name:10s} St {row['St']:6.1f}  e {e:.3f} ({e / reference['restitution'] - 1:+.1%})  apex "
                  f"{1e3 * apex:.3f} mm ({apex / reference['apex_gap'] - 1:+.1%})")
            for term, shares in (row["share"] or {}).items():
                print(f"      {term:14s} " + " ".join(f"{x:+.3f}" for x in shares))
        print("  the liquid's impulse on the way out: " + ", ".join(
            f"{name} {outward(row):+.3f}" for name, row in rows[target].items()))
    if not args.ode_only:
        RECORD.write_text(json.dumps({**stamp(), "viscosities": VISCOSITIES, "runs": rows}, indent=1) + "\n")
        print(f"-> {RECORD}")


def outward(row: dict) -> float:
    """The liquid's impulse in the rebound phase, over the momentum brought in (every term but contact and weight)."""
    return sum(shares[2] for term, shares in (row["share"] or {}).items() if term not in ("contact", "weight"))


if __name__ == "__main__":
    main()
