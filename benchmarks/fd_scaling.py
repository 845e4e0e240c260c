"""Parallel scaling of the fd model's flow solve: 1 against 2 ranks, direct (MUMPS) against the
field-split iterative solver (numerics.fd.solver), on the case-3 geometry at three mesh sizes.

    python benchmarks/fd_scaling.py run --cells 24,48,87               # serial
    mpiexec -n 2 python benchmarks/fd_scaling.py run --cells 24,48,87   # 2 ranks
    python benchmarks/fd_scaling.py table                              # speedups from the history

Each run marches Li case 3 from release for --steps steps (the same steps at every rank count) and
records the set-up time (mesh, assembly, factorisation) and the time per step; 24, 48 and 87 cells
per diameter give about 47k, 150k and 500k unknowns.  Results are merged into
benchmarks/history/fd_scaling.json with the date, machine, ranks and the load average (timings
taken on a busy machine say so).  About 10 min for the whole ladder on 2 cores.
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import time
import warnings
from pathlib import Path

from mpi4py import MPI

from fem_bounce import scene
from fem_bounce.models.fd.domain import time_step
from fem_bounce.run import run_logged as simulate  # the libraries' output goes to the run's run.log

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "history" / "fd_scaling.json"


def one(comm, cells: float, solver: str, steps: int, out: Path) -> dict:
    # the fixed mesh: the moving one factorises its changing matrix directly every step (no field split)
    overrides = {"numerics.fd.cells_per_diameter": cells, "numerics.fd.solver": solver, "numerics.fd.mesh": "fixed",
                 "numerics.fd.checkpoint_every": 0}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sc = scene.load("li2011-case3", overrides)
        sc = scene.load("li2011-case3", {**overrides, "run.end_time": steps * time_step(sc)})
    start = time.perf_counter()
    summary = simulate(sc, "fd", comm, out, force=True, progress=False, plots=False)
    fd = summary["fd"]
    return {"cells_per_diameter": cells, "solver": solver, "ranks": comm.size, "steps": summary["steps"],
            "unknowns": summary["sizes"]["unknowns"], "wall_time_s": time.perf_counter() - start,
            "setup_s": fd["timings_s"]["setup"], "time_per_step_s": fd["time_per_step_s"],
            "back_solve_s": fd["back_solve_s"], "krylov_iterations_per_solve": fd.get("krylov_iterations_per_solve")}


def table(stored: dict) -> str:
    lines = ["| unknowns | solver | step, 1 rank (s) | step, 2 ranks (s) | speedup | set-up 1 / 2 ranks (s) |",
             "|---|---|---|---|---|---|"]
    keys = sorted({(v["result"]["cells_per_diameter"], v["result"]["solver"]) for v in stored.values()})
    for cells, solver in keys:
        runs = {v["result"]["ranks"]: v["result"] for v in stored.values()
                if v["result"]["cells_per_diameter"] == cells and v["result"]["solver"] == solver}
        if 1 in runs and 2 in runs:
            a, b = runs[1], runs[2]
            lines.append(f"| {a['unknowns']:,} | {solver} | {a['time_per_step_s']:.3f} | {b['time_per_step_s']:.3f} | "
                         f"{a['time_per_step_s'] / b['time_per_step_s']:.2f} | "
                         f"{a['setup_s']:.1f} / {b['setup_s']:.1f} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("section", choices=["run", "table"])
    parser.add_argument("--cells", default="24,48,87")
    parser.add_argument("--solvers", default="direct,fieldsplit")
    parser.add_argument("--steps", type=int, default=20)
    parser.add_argument("--out", type=Path, default=Path("runs/fd-scaling"))
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    stored = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    if args.section == "table":
        if comm.rank == 0:
            print(table(stored))
        return
    for cells in (float(c) for c in args.cells.split(",")):
        for solver in args.solvers.split(","):
            result = one(comm, cells, solver, args.steps, args.out / f"{solver}-{cells:g}-{comm.size}")
            if comm.rank == 0:
                stored = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
                stored[f"{solver}@{cells:g}cpd-{comm.size}ranks"] = {
                    "date": time.strftime("%Y-%m-%dT%H:%M:%S"), "machine": platform.node(),
                    "load_average_1min": os.getloadavg()[0], "result": result}
                RESULTS.parent.mkdir(exist_ok=True)
                RESULTS.write_text(json.dumps(stored, indent=1) + "\n")
                print(json.dumps(result), flush=True)


if __name__ == "__main__":
    main()
