"""The fd model's resolved force along the paper's Fig. 7 path, against the converged ALE force.

    python benchmarks/fd_near_wall.py                      # baseline and wall-refined fd variants
    python benchmarks/fd_near_wall.py --variants wall48,wall48-band1 --ale results/near_wall/fig7/fig7.json
    python benchmarks/fd_near_wall.py --ale results/near_wall/fig7/runs/ale24     # the ALE run itself

The path is the one of benchmarks/near_wall.py fig7: the ODE model's case-3 approach to its first
contact, prescribed (motion.mode = "prescribed", contact.near_wall = "blend", no hold) down to
delta = 0.03.  Each variant is one fd run along it (24 cells per diameter unless it says); the table
gives f_sim in units of (4/3) pi a^3 rho_l g at the Fig. 7 gaps and, when the ALE study's fig7.json
is given, the relative difference from its finest run (ale24).  Variants:

  base           the defaults
  wall48         + a wall box r <= 0.6 D, z <= 0.25 D at 48 cells per diameter (the gap's squeeze flow)
  wall48-band1   + the interface band one fine cell wide (radius_offset 0.25: the effective surface at
                 a quarter band inside the indicator's edge, as for the two-cell band; see immersed.py)
  wall96-band1   the same with the wall box at 96 cells per diameter

Results go to benchmarks/history/fd_near_wall.json (and the runs to results/fd_near_wall/).
About 3-6 min per variant on one core.
"""
from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from fem_bounce import plots
from fem_bounce import scene as scenes
from near_wall import prescribed_approach  # benchmarks/ is on the path of a script run from it

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "history" / "fd_near_wall.json"
ROOT = Path("results") / "fd_near_wall"
DELTAS = (1.0, 0.5, 0.35, 0.25, 0.2, 0.15, 0.1, 0.07, 0.05, 0.04)
FIXED = {"numerics.fd.mesh": "fixed"}  # the wall box and the band's edge are the fixed mesh's settings
VARIANTS = {
    "base": {},
    "wall48": {**FIXED, "numerics.fd.wall_cells_per_diameter": 48},
    "wall48-band1": {**FIXED, "numerics.fd.wall_cells_per_diameter": 48, "numerics.fd.interface_width": 1.0,
                     "numerics.fd.radius_offset": 0.25},
    "wall96-band1": {**FIXED, "numerics.fd.wall_cells_per_diameter": 96, "numerics.fd.interface_width": 1.0,
                     "numerics.fd.radius_offset": 0.25},
}


def fem_bounce(args: list[str]) -> None:
    done = subprocess.run([sys.executable, "-m", "fem_bounce", "run", *args, "--force", "--quiet"],
                          capture_output=True, text=True)
    if done.returncode != 0:
        raise SystemExit(f"fem-bounce run {' '.join(args)} failed: {done.stderr.strip()[-500:]}")


def path_overrides() -> dict:
    """The prescribed Fig. 7 path (as benchmarks/near_wall.py fig7 builds it)."""
    ode_dir = ROOT / "ode"
    if not (ode_dir / "summary.json").exists():
        fem_bounce(["li2011-case3", "--model", "ode", "--set", "run.bounces=1", "--out", str(ode_dir)])
    return prescribed_approach(ode_dir, ROOT)


def forces_along(run_dir: Path) -> dict:
    sc = scenes.load("li2011-case3")
    unit = sc.displaced_mass * sc.gravity
    data = plots.read_trajectory(run_dir)
    gap = data["gap"][::-1] / sc.sphere.diameter
    return {delta: float(np.interp(delta, gap, data["f_sim"][::-1])) / unit for delta in DELTAS}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--variants", default="base,wall48,wall48-band1")
    parser.add_argument("--cells", type=float, default=24.0)
    parser.add_argument("--ale", type=Path, default=None,
                        help="fig7.json of benchmarks/near_wall.py fig7, or its ale24 run directory")
    parser.add_argument("--force", action="store_true", help="re-run variants that have a summary")
    args = parser.parse_args()
    ROOT.mkdir(parents=True, exist_ok=True)
    path = path_overrides()
    stored = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    ale = None
    if args.ale is not None and args.ale.is_dir():
        ale = forces_along(args.ale)
    elif args.ale is not None and args.ale.exists():
        ale = {row["delta"]: row["f_sim_ale24"] for row in json.loads(args.ale.read_text())["rows"]}
    for name in args.variants.split(","):
        run_dir = ROOT / f"{name}-{args.cells:g}"
        changes = {**path, "numerics.fd.cells_per_diameter": args.cells, **VARIANTS[name]}
        if args.force or not (run_dir / "summary.json").exists():
            start = time.perf_counter()
            fem_bounce(["li2011-case3", "--model", "fd", "--out", str(run_dir),
                        *[a for k, v in changes.items() for a in ("--set", f"{k}={v}")]])
            print(f"{name}: {time.perf_counter() - start:.0f} s", flush=True)
        summary = json.loads((run_dir / "summary.json").read_text())
        forces = forces_along(run_dir)
        entry = {"variant": name, "changes": VARIANTS[name], "cells_per_diameter": args.cells,
                 "unknowns": summary["sizes"]["unknowns"], "wall_time_s": summary["wall_time_s"],
                 "f_sim": {f"{d:g}": f for d, f in forces.items()}}
        if ale is not None:
            entry["error_vs_ale24"] = {f"{d:g}": forces[d] / ale[d] - 1.0 for d in DELTAS if d in ale}
        stored[f"{name}@{args.cells:g}cpd"] = {"date": time.strftime("%Y-%m-%dT%H:%M:%S"), "result": entry}
        RESULTS.parent.mkdir(exist_ok=True)
        RESULTS.write_text(json.dumps(stored, indent=1) + "\n")
    lines = ["| variant | unknowns | wall s | " + " | ".join(f"{d:g}" for d in DELTAS) + " |",
             "|---|---|---|" + "---|" * len(DELTAS)]
    for key, value in stored.items():
        r = value["result"]
        errors = r.get("error_vs_ale24", {})
        cells = " | ".join(f"{r['f_sim'][f'{d:g}']:.3f}" + (f" ({100 * errors[f'{d:g}']:+.1f} %)" if f"{d:g}" in errors
                                                             else "") for d in DELTAS)
        lines.append(f"| {key} | {r['unknowns']:,} | {r['wall_time_s']:.0f} | {cells} |")
    print("\n".join(lines))
    print("f_sim in units of (4/3) pi a^3 rho_l g; in parentheses the difference from ALE at 24 cells/D.")


if __name__ == "__main__":
    main()
