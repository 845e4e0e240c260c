"""Wall time of a restitution sweep with 1 and 2 jobs (`--jobs N`, one process per run), on a fresh cache.

    python benchmarks/study_jobs.py            # both sweeps, 1 then 2 jobs: ~5-10 min on 2 quiet cores
    python benchmarks/study_jobs.py ode        # the ODE sweep only (~1 min)

Each sweep is the command a user types, run in an empty temporary directory (so no run is reused) and
timed from outside, start-up included:

- ode: `fem-bounce restitution --model ode --points 40 [--jobs 2]`: 49 cached ODE runs (40 points and
  the delta_ss + 5 % set's 9) after the ODE planning of the 9 material sets' Stokes bands;
- fd8: `fem-bounce restitution --model fd --points 6 --st-min 30 --set numerics.fd.cells_per_diameter=8
  [--jobs 2]`: fd at 8 cells/D on the six planned points of St 30-1000 (the high-St sets, whose fd
  runs take seconds, not the viscous ones) and the 60-point ODE curve drawn beside them.

Both job counts must give the same restitution.csv (wall times aside), which the benchmark checks.
Appends to benchmarks/history/study_jobs.json with date, machine, commit and load average: the machine
is shared, so read a timing taken with a load average above ~1 as "under load".
"""
from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from provenance import stamp

SWEEPS = {
    "ode": ["restitution", "--model", "ode", "--points", "40"],
    "fd8": ["restitution", "--model", "fd", "--points", "6", "--st-min", "30",
            "--set", "numerics.fd.cells_per_diameter=8"],
}
JOBS = (1, 2)
SAME_COLUMNS = ("scene", "target_St", "gap_over_D", "status", "St", "Re", "restitution", "apex_over_D")


def _load() -> list[str] | None:
    path = Path("/proc/loadavg")
    return path.read_text().split()[:3] if path.exists() else None


def time_sweep(arguments: list[str], jobs: int) -> dict:
    command = [sys.executable, "-m", "fem_bounce", *arguments, "--jobs", str(jobs), "--out", "sweep"]
    with tempfile.TemporaryDirectory() as tmp:
        load_before = _load()
        start = time.perf_counter()
        done = subprocess.run(command, cwd=tmp, capture_output=True, text=True)
        wall = time.perf_counter() - start
        if done.returncode != 0:
            raise RuntimeError(f"{' '.join(command)} failed ({done.returncode}):\n{done.stderr[-2000:]}")
        with open(Path(tmp) / "sweep" / "restitution.csv") as stream:
            found = list(csv.DictReader(stream))
    rows = [{k: row[k] for k in SAME_COLUMNS} for row in found]
    return {"command": "fem-bounce " + " ".join(arguments + ["--jobs", str(jobs)]), "jobs": jobs,
            "wall_time_s": wall, "runs": len(rows),
            "sum_of_run_wall_times_s": sum(float(r["wall_time_s"]) for r in found),
            "loadavg_before": load_before, "loadavg_after": _load(), "rows": rows}


def main(names: list[str]) -> None:
    record = {**stamp(), "cores": os.cpu_count(), "sweeps": {}}
    for name in names:
        timed = [time_sweep(SWEEPS[name], jobs) for jobs in JOBS]
        same = all(t["rows"] == timed[0]["rows"] for t in timed)
        for t in timed:
            print(f"{name}: {t['command']}: {t['wall_time_s']:.1f} s for {t['runs']} runs "
                  f"(load {t['loadavg_before']} -> {t['loadavg_after']})", flush=True)
        print(f"{name}: speed-up with {JOBS[-1]} jobs {timed[0]['wall_time_s'] / timed[-1]['wall_time_s']:.2f}; "
              f"same results: {same}", flush=True)
        record["sweeps"][name] = {"same_results": same, "speedup": timed[0]["wall_time_s"] / timed[-1]["wall_time_s"],
                                  "timings": [{k: v for k, v in t.items() if k != "rows"} for t in timed]}
        if not same:
            raise SystemExit(f"{name}: the sweep with {JOBS[-1]} jobs differs from 1 job")
    path = Path(__file__).parent / "history" / "study_jobs.json"
    history = json.loads(path.read_text()) if path.exists() else []
    history.append(record)
    path.write_text(json.dumps(history, indent=2) + "\n")
    print(f"-> {path}")


if __name__ == "__main__":
    main(sys.argv[1:] or list(SWEEPS))
