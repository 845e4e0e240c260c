"""Did a refactor move any number?  Runs every model on small scenes and prints, per run, the impacts,
rebounds, final state, step count and a hash of trajectory.csv (rows to 10 digits), as JSON.

    python benchmarks/refactor_check.py > before.json     # on the old code
    python benchmarks/refactor_check.py --compare before.json   # on the new code: lists what moved

About 2 minutes serial on the 2-core development machine.  Runs land in results/refactor_check/.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import sys
from pathlib import Path

from mpi4py import MPI

from fem_bounce import scene as scenes
from fem_bounce.errors import RunDiverged
from fem_bounce.run import simulate

CASES = {
    "ode-case3": ("li2011-case3", "ode", {"run.bounces": 2}),
    "fd-case3": ("li2011-case3", "fd", {"numerics.fd.cells_per_diameter": 8, "run.bounces": 1,
                                        "numerics.fd.checkpoint_every": 0}),
    "fd-brenner": ("brenner-approach", "fd", {"numerics.fd.cells_per_diameter": 8}),
    "ib-case3": ("li2011-case3", "ib", {"numerics.ib.cells_per_diameter": 8, "run.bounces": 1}),
    "ib-drag": ("sphere-drag-re100", "ib", {"numerics.ib.cells_per_diameter": 8, "run.end_time": 0.3}),
    "ale-case3": ("li2011-case3", "ale", {"numerics.ale.cells_per_diameter": 6, "run.bounces": 1}),
    "ale-brenner": ("brenner-approach", "ale", {"numerics.ale.cells_per_diameter": 6}),
}
ROOT = Path("results") / "refactor_check"


def fingerprint(name: str) -> dict:
    preset, model, changes = CASES[name]
    out = ROOT / name
    try:
        summary = simulate(scenes.load(preset, changes), model, MPI.COMM_WORLD, out, force=True, progress=False,
                           plots=False)
    except RunDiverged:
        summary = json.loads((out / "summary.json").read_text())
    digest = hashlib.sha256((out / "trajectory.csv").read_bytes()).hexdigest()[:16]
    return {"status": summary["status"], "steps": summary["steps"], "final": summary["final"],
            "impacts": summary["impacts"], "rebounds": summary["rebounds"], "trajectory_sha256": digest,
            "rows": len((out / "trajectory.csv").read_text().splitlines()) - 1}


def moved(before, after, path="") -> list[str]:
    if isinstance(before, dict) and isinstance(after, dict):
        return [m for k in sorted(before.keys() | after.keys())
                for m in moved(before.get(k), after.get(k), f"{path}.{k}")]
    if isinstance(before, list) and isinstance(after, list) and len(before) == len(after):
        return [m for k, (a, b) in enumerate(zip(before, after)) for m in moved(a, b, f"{path}[{k}]")]
    if before != after:
        return [f"{path}: {before!r} -> {after!r}"]
    return []


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--compare", type=Path, help="a JSON this script printed before")
    parser.add_argument("--only", help="comma-separated case names")
    args = parser.parse_args()
    names = args.only.split(",") if args.only else list(CASES)
    found = {name: fingerprint(name) for name in names}
    if args.compare is None:
        print(json.dumps(found, indent=1))
        return 0
    before = json.loads(args.compare.read_text())
    changes = [m for name in names for m in moved(before.get(name), found[name], name)
               if not m.split(": ")[0].endswith("wall_time_s")]
    print("\n".join(changes) if changes else f"unchanged: {', '.join(names)}")
    return 1 if changes else 0


if __name__ == "__main__":
    sys.exit(main())
