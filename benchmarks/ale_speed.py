"""The ale model's speed at its 1 % setting: case 3 with both factorisation paths side by side.

    python benchmarks/ale_speed.py                  # serial
    mpiexec -n 2 python benchmarks/ale_speed.py      # two ranks
    python benchmarks/ale_speed.py --compilations   # forms compiled from an empty cache, then by a second run

Runs Li case 3 (8 cells/D, surface_refinement 3) to the apex after the second impact (run.bounces = 2)
with numerics.ale.factorisation = "every-step" (one MUMPS factorisation a step) and = "reuse" (flexible
GMRES preconditioned by the factors of an earlier step), in one process, one after the
other, each on a warm form cache (a first short run compiles whatever is missing; its compilations are
reported).  Prints V_i (first impact), Re_II (second impact) and e_1 (first rebound) of each, their
relative differences, the wall time and its breakdown: matrix assembly, factorisation, solves (back-solves
or GMRES), remeshing, form compilation, the sphere integrator, and the rest (set-up, Python, forces,
outputs).  Then the floor: one assembly, one factorisation, one back-solve and one product
with the matrix timed on the first mesh, and the time a step would take with one assembly and two
back-solves.  The machine's load average is recorded: timings compare only within one run.

The runs go through fem_bounce.run.run_logged, as `fem-bounce run` makes them: on a cold form cache the
compiler's log goes to each run's run.log, not the terminal.  --compilations runs, with an empty form
cache (XDG_CACHE_HOME in a new temporary folder), case 3 at 4 cells/D to its first apex, then at 5 cells/D
with another density and step: the form compiler's compilations and seconds in each (the second should
compile nothing: every number is a Constant).  Results are merged into
benchmarks/history/ale_speed.json (key: date and ranks).
"""
from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

from mpi4py import MPI

import ffcx.codegeneration.jit as ffcx_jit
import numpy as np
from fem_bounce import scene
from fem_bounce.run import run_logged
from provenance import commit

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "history" / "ale_speed.json"
SETTING = {"numerics.ale.cells_per_diameter": 8, "numerics.ale.surface_refinement": 3, "run.bounces": 2}
PATHS = ("every-step", "reuse")


class CompileClock:
    """Times and counts the form compiler's compilations (ffcx, cffi, gcc) while installed."""

    def __init__(self):
        self.seconds, self.count = 0.0, 0
        self._original = ffcx_jit._compile_objects

    def __enter__(self):
        def timed(*args, **kwargs):
            start = time.perf_counter()
            try:
                return self._original(*args, **kwargs)
            finally:
                self.seconds += time.perf_counter() - start
                self.count += 1
        ffcx_jit._compile_objects = timed
        return self

    def __exit__(self, *exc):
        ffcx_jit._compile_objects = self._original


def load(changes: dict):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return scene.load("li2011-case3", {**SETTING, **changes})


def run(comm, out: Path, path: str) -> dict:
    with CompileClock() as clock:
        start = time.perf_counter()
        summary = run_logged(load({"numerics.ale.factorisation": path}), "ale", comm, out / path, force=True,
                             progress=False, plots=False)
        wall = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
    ale = summary["ale"]
    t = ale["timings_s"]
    parts = {"assembly": t["assembly"], "factorisation": t["factorisation"], "solves": t["solves"],
             "remesh": t["remesh"], "compile": clock.seconds, "integrator": t["integrator"]}
    parts["rest"] = wall - sum(parts.values())
    impacts, rebounds = summary["impacts"], summary["rebounds"]
    return {"path": path, "wall_time_s": wall, "steps": summary["steps"], "breakdown_s": parts,
            "compilations": clock.count, "factorisations": ale["factorisations"],
            "krylov_iterations": ale["krylov_iterations"],
            "remeshes": ale["remesh_count"], "unknowns": summary["sizes"]["unknowns"],
            "V_i": impacts[0]["impact_speed"], "Re_II": impacts[1]["Re"] if len(impacts) > 1 else None,
            "e_1": rebounds[0]["restitution"]}


def floor(comm) -> dict:
    """One assembly, factorisation, back-solve and matrix product of the step matrix on the first mesh [s]."""
    from fem_bounce.models.ale.model import AleModel

    model = AleModel(load({"numerics.ale.factorisation": "reuse"}), comm)
    _, _, flow = model.moving.build_mesh(np.array(model.moving.domain.initial_centers))
    try:
        flow.factorise()
        operator, A = flow.operator, flow.matrix
        b, x = A.createVecs()
        b.setRandom()
        repeats = 10
        timings = {}
        start = time.perf_counter()
        for _ in range(repeats):
            flow.factorise()  # assembles; not stale: no factorisation
        timings["assembly"] = (time.perf_counter() - start) / repeats
        start = time.perf_counter()
        for _ in range(repeats):
            operator.stale = True
            flow.factorise()  # assembles and factorises
        timings["factorisation"] = (time.perf_counter() - start) / repeats - timings["assembly"]
        pc = operator.ksp.getPC()
        start = time.perf_counter()
        for _ in range(repeats):
            pc.apply(b, x)
        timings["back_solve"] = (time.perf_counter() - start) / repeats
        start = time.perf_counter()
        for _ in range(repeats):
            A.mult(b, x)
        timings["matrix_product"] = (time.perf_counter() - start) / repeats
        return {k: comm.allreduce(v, op=MPI.MAX) for k, v in timings.items()}
    finally:
        flow.destroy()


def compilations(out: Path) -> list[dict]:
    """Two toy runs in this process (started with an empty form cache): compilations and seconds of each."""
    runs = []
    for k, changes in enumerate(({"numerics.ale.cells_per_diameter": 4},
                                 {"numerics.ale.cells_per_diameter": 5, "liquid.density": 1100.0,
                                  "numerics.ale.cfl": 0.45})):
        with CompileClock() as clock:
            summary = run_logged(load({**changes, "run.bounces": 1}), "ale", MPI.COMM_WORLD, out / f"compile-{k}",
                                 force=True, progress=False, plots=False)
        runs.append({"changes": changes, "compilations": clock.count, "compile_s": clock.seconds,
                     "remeshes": summary["ale"]["remesh_count"]})
    return runs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("runs/ale-speed"))
    parser.add_argument("--compilations", action="store_true",
                        help="count the form compilations of two runs from an empty cache (a child process)")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    if args.child:  # started by --compilations with an empty XDG_CACHE_HOME
        print(json.dumps(compilations(args.out)))
        return
    if args.compilations:
        with tempfile.TemporaryDirectory() as cache:
            done = subprocess.run([sys.executable, __file__, "--child", "--out", str(args.out)], capture_output=True,
                                  text=True, env={**os.environ, "XDG_CACHE_HOME": cache}, check=True)
        runs = json.loads(done.stdout.strip().splitlines()[-1])
        for r in runs:
            print(f"{r['changes']}: {r['compilations']} compilations, {r['compile_s']:.1f} s, {r['remeshes']} remeshes")
        stored = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
        stored[f"{time.strftime('%Y-%m-%dT%H:%M:%S')}-compilations"] = {"commit": commit(), "runs": runs}
        RESULTS.write_text(json.dumps(stored, indent=1) + "\n")
        return
    load_before = os.getloadavg()
    with CompileClock() as warm:  # fill the form cache (both schemes, the projections) on a short run
        run_logged(load({"numerics.ale.factorisation": "reuse", "run.bounces": 1,
                         "numerics.ale.cells_per_diameter": 4}),
                   "ale", comm, args.out / "warm-up", force=True, progress=False, plots=False)
    runs = {path: run(comm, args.out, path) for path in PATHS}
    costs = floor(comm)
    old, new = runs["every-step"], runs["reuse"]
    result = {
        "commit": commit(), "machine": platform.node(), "cores": os.cpu_count(),
        "ranks": comm.size, "load_average_before": load_before, "load_average_after": os.getloadavg(),
        "warm_up_compilations": warm.count, "runs": runs,
        "relative_difference": {key: new[key] / old[key] - 1.0 for key in ("V_i", "Re_II", "e_1")},
        "speed_up": old["wall_time_s"] / new["wall_time_s"], "one_operation_s": costs,
        "floor_step_s": costs["assembly"] + 2 * costs["back_solve"],
        "floor_run_s": new["steps"] * (costs["assembly"] + 2 * costs["back_solve"]),
    }
    if comm.rank == 0:
        for r in runs.values():
            parts = ", ".join(f"{k} {v:.2f}" for k, v in r["breakdown_s"].items())
            print(f"{r['path']:10s}: {r['wall_time_s']:6.2f} s, {r['steps']} steps, "
                  f"{r['factorisations']} factorisations, "
                  f"{r['krylov_iterations']} GMRES iterations, "
                  f"{r['compilations']} compilations; V_i {r['V_i']:.5f} m/s, Re_II {r['Re_II']:.3f}, "
                  f"e_1 {r['e_1']:.5f}")
            print(f"{'':10s}  [s] {parts}")
        diffs = ", ".join(f"{k} {v:+.1e}" for k, v in result["relative_difference"].items())
        print(f"reuse against every-step, relative: {diffs}; speed-up {result['speed_up']:.2f}x")
        c = costs
        print(f"one assembly {1e3 * c['assembly']:.1f} ms, factorisation {1e3 * c['factorisation']:.1f} ms, back-solve "
              f"{1e3 * c['back_solve']:.2f} ms, matrix product {1e3 * c['matrix_product']:.2f} ms: floor "
              f"{1e3 * result['floor_step_s']:.1f} ms a step (one assembly, two back-solves), "
              f"{result['floor_run_s']:.2f} s for {new['steps']} steps")
        print(f"load average before {load_before[0]:.2f}, after {result['load_average_after'][0]:.2f} "
              f"(on {os.cpu_count()} cores); {warm.count} forms compiled by the warm-up")
        RESULTS.parent.mkdir(exist_ok=True)
        stored = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
        stored[f"{time.strftime('%Y-%m-%dT%H:%M:%S')}-{comm.size}ranks"] = result
        RESULTS.write_text(json.dumps(stored, indent=1) + "\n")


if __name__ == "__main__":
    main()
