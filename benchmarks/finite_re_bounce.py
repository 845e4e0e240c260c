"""The reduced model's bounce at higher Reynolds number, judged by the resolved flow.

    PYTHONPATH=. python benchmarks/finite_re_bounce.py      # ale runs cached in results/finite_re_bounce/

Li et al.'s case 3 (falling from rest under gravity, to the apex after the second impact) in a less viscous
liquid, so that the first impact comes at Re ~ 100-300 where the screened inertial drag (docs/physics.md 3.7) was
not calibrated: the ode model at its default against the ale model at its default (8 cells/D, the surface D / 40,
collisions resolved) and at 12 cells/D (the resolved answer's own mesh error).  For each run: Re and V_i of the
first impact, e_1 (the 2 ms means) and the first two apexes.  Prints a table and writes
benchmarks/history/finite_re_bounce.json.
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

VISCOSITIES = (0.05, 0.04, 0.03, 0.02)  # Pa s; case 3's own is 0.05 (Re_I ~ 90)
ALE_CELLS = (8, 12)
RECORD = ROOT / "benchmarks" / "history" / "finite_re_bounce.json"


def measured(run_dir: Path) -> dict:
    summary = read_summary(run_dir)
    impacts, rebounds = summary["impacts"], summary["rebounds"]
    return {"Re": impacts[0]["Re"], "St": impacts[0]["St"], "impact_speed": impacts[0]["impact_speed"],
            "restitution": rebounds[0]["restitution"],
            "apexes": [rebound["apex_gap"] for rebound in rebounds[:2]], "wall_time": summary.get("wall_time_s")}


def relative(value: float, reference: float) -> str:
    return f"({value / reference - 1:+.1%})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=ROOT / "results" / "finite_re_bounce")
    parser.add_argument("--viscosities", type=lambda text: [float(v) for v in text.split(",")],
                        default=list(VISCOSITIES), help="Pa s, comma-separated")
    args = parser.parse_args()
    rows = {}
    for viscosity in args.viscosities:
        base = {"liquid.viscosity": viscosity, "run.bounces": 2}
        runs = {"ode": (fb.load("li2011-case3", base), "ode")}
        runs |= {f"ale {c}": (fb.load("li2011-case3", {**base, "numerics.ale.cells_per_diameter": c}), "ale")
                 for c in ALE_CELLS}
        rows[viscosity] = {name: measured(cached_run(sc, model, MPI.COMM_SELF, root=args.root))
                           for name, (sc, model) in runs.items()}
        reference = rows[viscosity][f"ale {ALE_CELLS[-1]}"]
        print(f"mu = {viscosity} Pa s: Re_I {reference['Re']:.0f}, St {reference['St']:.0f} (ale {ALE_CELLS[-1]} "
              f"cells/D); against it:")
        for name, row in rows[viscosity].items():
            apexes = "  ".join(f"apex {k} {1e3 * a:.3f} mm {relative(a, r)}"
                               for k, (a, r) in enumerate(zip(row["apexes"], reference["apexes"]), 1))
            speed, e = row["impact_speed"], row["restitution"]
            print(f"  {name:5s} V_i {speed:.4f} {relative(speed, reference['impact_speed'])}  "
                  f"e_1 {e:.3f} {relative(e, reference['restitution'])}  {apexes}")
    if args.viscosities != list(VISCOSITIES):
        print(f"(other viscosities than the record's: {RECORD} left as it is)")
        return
    RECORD.write_text(json.dumps({**stamp(), "runs": {str(k): v for k, v in rows.items()}}, indent=1) + "\n")
    print(f"-> {RECORD}")


if __name__ == "__main__":
    main()
