"""The ale model's time-step error on case 3 at its 1 % mesh: the constant step at cfl 0.5,
0.25, 0.125 and 0.0625 and the adaptive step (numerics.ale.adaptive_step), side by side.

    python benchmarks/ale_time_step.py            # about 6 minutes serial on a quiet core, 10 under load

Li case 3 at 8 cells/D, surface_refinement 3, to the apex after the second impact (run.bounces = 2), the
reused factorisation (the default).  Prints, for each run, the steps, the wall time, V_i (first impact),
Re_II (second impact) and e_1 (first rebound) and their relative differences from the finest constant step
(cfl 0.0625, taken as converged: it is within 0.3 % of cfl 0.125 in all three), and the steps by the mesh
gap.  Runs land in runs/ale-time-step/, the record in benchmarks/history/ale_time_step.json.
"""
from __future__ import annotations

import argparse
import csv
import json
import os
import time
import warnings
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fem_bounce import scene
from fem_bounce.run import run_logged
from provenance import commit

HERE = Path(__file__).resolve().parent
RECORD = HERE / "history" / "ale_time_step.json"
SETTING = {"numerics.ale.cells_per_diameter": 8, "numerics.ale.surface_refinement": 3, "run.bounces": 2}
RUNS = {f"cfl {cfl:g}": {"numerics.ale.cfl": cfl} for cfl in (0.5, 0.25, 0.125, 0.0625)}
RUNS["adaptive (cfl 0.5, x1/8 to x4)"] = {"numerics.ale.adaptive_step": True}
GAP_BINS = (0.0, 0.1, 0.5, 1.0, np.inf)  # mesh gap / D


def run(name: str, out: Path) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        case = scene.load("li2011-case3", {**SETTING, **RUNS[name]})
    start = time.perf_counter()
    summary = run_logged(case, "ale", MPI.COMM_WORLD, out, force=True, progress=False, plots=False)
    wall = time.perf_counter() - start
    with open(out / "ale_forces.csv") as stream:
        gaps = np.array([float(row["mesh_gap"]) for row in csv.DictReader(stream)]) / case.sphere.diameter
    counts = np.histogram(gaps, bins=GAP_BINS)[0]
    impacts, rebounds = summary["impacts"], summary["rebounds"]
    return {"wall_time_s": wall, "steps": summary["steps"], "longest_step_s": summary["ale"]["longest_step_s"],
            "cfl_step_s": summary["sizes"]["dt"], "krylov_iterations": summary["ale"]["krylov_iterations"],
            "steps_by_gap": {f"{lo:g}-{hi:g} D": int(n) for lo, hi, n in zip(GAP_BINS, GAP_BINS[1:], counts)},
            "V_i": impacts[0]["impact_speed"], "Re_II": impacts[1]["Re"], "e_1": rebounds[0]["restitution"]}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("runs/ale-time-step"))
    args = parser.parse_args()
    load = os.getloadavg()[0]
    found = {name: run(name, args.out / name.split(" (")[0].replace(" ", "-")) for name in RUNS}
    finest = found["cfl 0.0625"]
    for name, r in found.items():
        r["relative_to_finest"] = {key: r[key] / finest[key] - 1.0 for key in ("V_i", "Re_II", "e_1")}
        errors = ", ".join(f"{key} {100 * v:+.2f} %" for key, v in r["relative_to_finest"].items())
        print(f"{name:32s} {r['steps']:4d} steps {r['wall_time_s']:6.1f} s  V_i {r['V_i']:.5f}  "
              f"Re_II {r['Re_II']:.3f}  e_1 {r['e_1']:.5f}  ({errors}); steps by mesh gap {r['steps_by_gap']}")
    RECORD.write_text(json.dumps({"date": time.strftime("%Y-%m-%d"), "commit": commit(), "load_average_before": load,
                                  "load_average_after": os.getloadavg()[0], "setting": SETTING, "runs": found},
                                 indent=1) + "\n")


if __name__ == "__main__":
    main()
