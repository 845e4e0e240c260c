"""Time the standard cases and record the result, so that performance history stays visible.

    python benchmarks/speed.py                       # ODE cases, ~1 min
    mpiexec -n 2 python benchmarks/speed.py fd ib ale # resolved models, ~10 min on 2 cores

Each case is timed in-process (imports excluded) and appended to
benchmarks/history/YYYY-MM-DD-MACHINE.json, which is committed (a record taken on a busy machine is not:
each case keeps the load average before and after it).  The ode cases are the ode model's speed targets, serial on a
quiet machine: case 3 to the third impact under 1 s, `fem-bounce restitution --points 40 --jobs 2` under
20 s, three-spheres-wall under 10 s, a column of five spheres to 0.2 s and pair-settling-wall with a
500 kg/m3 upper sphere under 30 s each.
"""
from __future__ import annotations

import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

from mpi4py import MPI

from fem_bounce import api, scene
from fem_bounce.studies import restitution_planning as restitution
from fem_bounce.run import run_logged as simulate  # the libraries' output goes to the run's run.log
from fem_bounce.integrator import BodyIntegrator


def ode_case3_three_impacts(comm) -> dict:
    """Issues 2 and 38: the ODE model on li2011-case3 to the third impact in under 1 s (the integrator
    alone, its tables built inside the timing as a first run builds them)."""
    sc = scene.load("li2011-case3", {"run.end_time": 1.0})
    start = time.perf_counter()
    integrator = BodyIntegrator(sc, stop_after_impacts=3)
    integrator.advance(sc.run.end_time)
    wall = time.perf_counter() - start
    return {"wall_time_s": wall, "target_s": 1.0, "sphere_steps": integrator.steps,
            "impacts": len(integrator.impacts)}


def ode_restitution_sweep(comm) -> dict:
    """Issue 38: `fem-bounce restitution --points 40 --jobs 2` in under 20 s: the band tabulation, the 43
    runs on two local processes and the figure, with an empty run cache (nothing reused)."""
    restitution.forget_bands()  # the planning runs count
    with tempfile.TemporaryDirectory() as tmp:
        start = time.perf_counter()
        table = api.restitution("ode", points=40, jobs=2, out=Path(tmp) / "out", cache=Path(tmp) / "cache")
        wall = time.perf_counter() - start
    return {"wall_time_s": wall, "target_s": 20.0, "runs": len(table), "jobs": 2}


def five_sphere_column() -> scene.Scene:
    """three-spheres-wall with two more equal spheres on top, one diameter apart, to t = 0.2 s."""
    data = scene.to_dict(scene.load("three-spheres-wall", {"run.end_time": 0.2}))
    data["further_spheres"] = [data["further_spheres"][0]] * 3
    data["name"] = "five-spheres-wall"
    return scene.from_dict(data)


def ode_run(label: str, make_scene, target: float, issue: str):
    """A case that runs the ode model as `fem-bounce run` does (trajectory written, no figures)."""
    def case(comm) -> dict:
        sc = make_scene()
        with tempfile.TemporaryDirectory() as tmp:
            start = time.perf_counter()
            summary = simulate(sc, "ode", comm, Path(tmp) / "run", progress=False, plots=False)
            wall = time.perf_counter() - start
        return {"wall_time_s": wall, "target_s": target, "steps": summary["steps"],
                "end_time": summary["final"]["time"], "collisions": len(summary.get("collisions", summary["impacts"])),
                "stop_reason": summary.get("stop_reason")}
    case.__name__ = f"ode_{label}"
    case.__doc__ = f"{issue}: {label.replace('_', ' ')} with the ode model in under {target:g} s."
    return case


def case3_to_second_apex(model: str, cells: float | None = None):
    """Issues 3 and 4: li2011-case3 to the apex after the second impact, timed with its outputs."""
    def case(comm) -> dict:
        changes = {"run.bounces": 2}
        if cells is not None:
            changes[f"numerics.{model}.cells_per_diameter"] = cells
        sc = scene.load("li2011-case3", changes)
        with tempfile.TemporaryDirectory() as tmp:
            out = Path(comm.bcast(tmp if comm.rank == 0 else None))
            start = time.perf_counter()
            summary = simulate(sc, model, comm, out / "run", progress=False, plots=False)
            wall = time.perf_counter() - start
            comm.barrier()
        resolution = getattr(sc.numerics, model).cells_per_diameter
        return {"wall_time_s": wall, "cells_per_diameter": resolution, "steps": summary["steps"],
                "sizes": summary.get("sizes"), "first_apex_gap": summary["rebounds"][0]["apex_gap"],
                "impact_speed": summary["impacts"][0]["impact_speed"], "model_report": summary.get(model)}
    case.__name__ = f"{model}_case3_second_apex" + (f"_{cells:g}cpd" if cells is not None else "")
    return case


CASES = {"ode": [ode_case3_three_impacts, ode_restitution_sweep,
                 ode_run("three_spheres_wall", lambda: scene.load("three-spheres-wall"), 10.0, "Issue 38"),
                 ode_run("five_sphere_column", five_sphere_column, 30.0, "Issue 38"),
                 ode_run("pair_settling_wall_light_upper",
                         lambda: scene.load("pair-settling-wall", {"second_sphere.density": 500.0}), 30.0, "Issue 38")],
         "fd": [case3_to_second_apex("fd", 8.0), case3_to_second_apex("fd")],
         "ib": [case3_to_second_apex("ib")],
         "ale": [case3_to_second_apex("ale")]}


def main(models: list[str]) -> None:
    comm = MPI.COMM_WORLD
    record = {"date": time.strftime("%Y-%m-%dT%H:%M:%S"), "machine": platform.node(), "ranks": comm.size,
              "python": platform.python_version(), "cases": {}}
    for model in models:
        for case in CASES[model]:
            load_before = os.getloadavg()
            result = case(comm)
            # 1, 5 and 15-minute load averages before and after: the machine is shared, and a busy one slows a run
            result["load_average"] = {"before": load_before, "after": os.getloadavg()}
            record["cases"][case.__name__] = result
            if comm.rank == 0:
                print(f"{case.__name__:32s} {result['wall_time_s']:8.2f} s  (load average {load_before[0]:.2f} "
                      f"before, {result['load_average']['after'][0]:.2f} after)", flush=True)
    if comm.rank == 0:
        folder = Path(__file__).parent / "history"
        folder.mkdir(exist_ok=True)
        path = folder / f"{time.strftime('%Y-%m-%d')}-{platform.node()}.json"
        previous = json.loads(path.read_text()) if path.exists() else []
        path.write_text(json.dumps(previous + [record], indent=2) + "\n")
        print(f"-> {path}")


if __name__ == "__main__":
    main(sys.argv[1:] or ["ode"])
