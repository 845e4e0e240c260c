"""Speed, memory and robustness of the fd model on Li case 3: the issue's benchmark numbers.

    python benchmarks/fd_speed.py resolution            # which resolution meets the 2 % apex criterion
    mpiexec -n 2 python benchmarks/fd_speed.py timing --cells 16
    python benchmarks/fd_speed.py density               # lowest stable density ratio, implicit vs explicit

resolution  case 3 to the apex after the second impact at 8, 12, 16, 24, 32 cells per
            diameter; the first rebound's apex gap against the next finer mesh.  Serial.
timing      case 3 to the apex after the second impact at one resolution: wall time, cost per
            step as a multiple of one back-solve, back-solves per step, peak memory (all ranks).
            Run it under mpiexec -n 2 and serially to compare.
density     ten Cate's box with the sphere's density at ratio x the oil's, 8 cells per diameter,
            0.3 s: does the run complete without the speed oscillating?  Implicit and explicit.
Results are merged into benchmarks/history/fd_speed.json with the date and machine.
Timings are only meaningful on a quiet machine.
"""
from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fem_bounce import output, scene
from fem_bounce.errors import RunDiverged
from fem_bounce.run import run_logged as simulate  # the libraries' output goes to the run's run.log

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "history" / "fd_speed.json"
TO_SECOND_APEX = {"run.bounces": 2}


def case3(comm, out: Path, cells: float, **extra) -> dict:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = scene.load("li2011-case3", {**TO_SECOND_APEX, "numerics.fd.cells_per_diameter": cells, **extra})
    start = time.perf_counter()
    summary = simulate(sc, "fd", comm, out, force=True, progress=False, plots=False)
    wall = time.perf_counter() - start
    return {"cells_per_diameter": cells, "wall_time_s": wall, "steps": summary["steps"], "sizes": summary["sizes"],
            "apex_gaps": [r["apex_gap"] for r in summary["rebounds"]],
            "impact_speeds": [i["impact_speed"] for i in summary["impacts"]], "fd": summary["fd"],
            "ranks": comm.size}


def resolution(comm, out: Path, ladder=(8, 12, 16, 24, 32)) -> dict:
    runs = [case3(comm, out / f"case3-{c}", c) for c in ladder]
    for coarse, fine in zip(runs, runs[1:]):
        coarse["apex_change_to_next"] = coarse["apex_gaps"][0] / fine["apex_gaps"][0] - 1.0
    meets = [r["cells_per_diameter"] for r in runs[:-1] if abs(r["apex_change_to_next"]) <= 0.02]
    return {"runs": runs, "coarsest_within_2_percent": meets[0] if meets else None}


def density(comm, out: Path, ratios=(1.167, 1.1, 1.01, 0.5, 0.3, 0.1, 0.01, 0.001)) -> list[dict]:
    rows = []
    for coupling in ("implicit", "explicit"):
        for ratio in ratios:
            sc = scene.load("tencate2002-e4", {"sphere.density": 960.0 * ratio, "run.end_time": 0.3,
                                               "numerics.fd.cells_per_diameter": 8, "numerics.fd.coupling": coupling})
            folder = out / f"{coupling}-{ratio:g}"
            try:
                status = simulate(sc, "fd", comm, folder, force=True, progress=False, plots=False)["status"]
            except RunDiverged as err:
                status = f"diverged: {err}"
            velocity = output.read_trajectory(folder)["velocity"]
            accel = np.diff(velocity)
            turns = int(np.sum(np.diff(np.sign(accel[np.abs(accel) > 1e-12])) != 0))
            rows.append({"coupling": coupling, "density_ratio": ratio, "status": status[:200],
                         "acceleration_sign_changes": turns, "final_velocity": float(velocity[-1])})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("section", choices=["resolution", "timing", "density"])
    parser.add_argument("--cells", type=float, default=16.0)
    parser.add_argument("--out", type=Path, default=Path("runs/fd-speed"))
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    if args.section == "resolution":
        result = resolution(comm, args.out)
        key = "resolution"
    elif args.section == "timing":
        result = case3(comm, args.out / f"timing-{args.cells:g}-{comm.size}ranks", args.cells)
        key = f"timing@{args.cells:g}cpd-{comm.size}ranks"
    else:
        result = density(comm, args.out)
        key = "density"
    if comm.rank == 0:
        RESULTS.parent.mkdir(exist_ok=True)
        stored = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
        stored[key] = {"date": time.strftime("%Y-%m-%dT%H:%M:%S"), "ranks": comm.size, "result": result}
        RESULTS.write_text(json.dumps(stored, indent=1) + "\n")
        print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
