"""How the sphere integrator fares as the density ratio nears 1: the measurement behind the scene
check that refuses free spheres within NEUTRAL_BUOYANCY (1e-5) of neutral buoyancy.

    python benchmarks/neutral_buoyancy.py        # ~1 min

li2011-case3 (0.6 s) at density ratios 1 + 1e-3 ... 1 + 1e-7, built without the scene check; each run is
capped at MAX_STEPS steps.  Released from rest, the sphere's velocity stays within the event tolerance
of zero for ~0.015 / |ratio - 1| steps, each of the post-event size 1e-7 sqrt(D/g): the step count grows
as 1 / |ratio - 1| and the run (and its trajectory file) crawls.  Appends to
benchmarks/history/neutral_buoyancy.json (date, machine, commit, load average).
"""
from __future__ import annotations

import dataclasses
import json
import time
from pathlib import Path

from fem_bounce import scene
from fem_bounce.integrator import BodyIntegrator
from provenance import stamp

RATIO_OFFSETS = (1e-3, 1e-4, 1e-5, 1e-6, 1e-7)
MAX_STEPS = 50_000


def run(offset: float) -> dict:
    base = scene.load("li2011-case3")
    sphere = dataclasses.replace(base.sphere, density=base.liquid.density * (1.0 + offset))
    sc = dataclasses.replace(base, sphere=sphere)  # not validated: the check would refuse the small offsets
    integrator = BodyIntegrator(sc)
    integrator.ts.setMaxSteps(MAX_STEPS)
    start = time.perf_counter()
    integrator.advance(sc.run.end_time)
    return {"ratio_minus_one": offset, "steps": integrator.steps, "reached_s": integrator.time,
            "end_time_s": sc.run.end_time, "wall_time_s": time.perf_counter() - start}


def main() -> None:
    record = {**stamp(),
              "loadavg": Path("/proc/loadavg").read_text().split()[:3] if Path("/proc/loadavg").exists() else None,
              "max_steps": MAX_STEPS, "runs": []}
    for offset in RATIO_OFFSETS:
        result = run(offset)
        record["runs"].append(result)
        print(f"ratio 1 + {offset:g}: {result['steps']:7d} steps, reached t = {result['reached_s']:.3g} of "
              f"{result['end_time_s']:g} s in {result['wall_time_s']:.1f} s", flush=True)
    path = Path(__file__).parent / "history" / "neutral_buoyancy.json"
    previous = json.loads(path.read_text()) if path.exists() else []
    path.write_text(json.dumps(previous + [record], indent=2) + "\n")
    print(f"-> {path}")


if __name__ == "__main__":
    main()
