"""Oblique impacts: the 3-D resolved model (fd3d) against the reduced one (ode) on case 3's sphere falling from rest
onto a wall inclined at each angle (gravity_angle), wet steel on Zerodur (contact.friction 0.02, Joseph & Hunt 2004's
wet steel), to 5 ms after the rebound has crossed delta_sl D.

    mpiexec -n 2 python benchmarks/oblique_resolved.py --angles 30,60 --out results/oblique-resolved   # ~11 min
    python benchmarks/oblique_resolved.py --angles 30,60 --out results/oblique-resolved --reuse         # the table
    mpiexec -n 2 python benchmarks/oblique_resolved.py --angles 30 --set numerics.fd3d.box=whole \
        --out results/oblique-resolved-whole --record oblique_resolved_whole                          # the check

A fall from rest, not a launch: a resolved model starts its launched sphere in liquid at rest (the sphere gives the
liquid its added mass's momentum at once), the reduced model with its added mass moving with it, so that a launched
sphere reaches the wall 12 % slower in the resolved models (docs/validation.md section 14); from rest both start alike.
For each angle the ode run comes first (a second): its path gives the end time (its outward crossing of delta_sl D plus
5 ms, rounded up to a millisecond).  Then the fd3d run at its defaults (its box follows the sphere along the wall) on
every rank of the communicator (`--reuse`: a finished run in OUT/fd3d-ANGLE is read, not run again).  Printed, and
written to benchmarks/history/oblique_resolved.json: per angle, at both stations of summary.json's oblique_impacts
(delta_sl D and the contact gap), psi_in, psi_out, e_n, e_t, the effective friction and the spin after, each model's and
their difference, with the fd3d run's cost.  `--set KEY=VALUE` changes both models' scenes (numerics.fd3d.box = "whole":
the half box's symmetry check, its out_of_plane force and torque recorded; contact.inertial_speed = "whole": the reduced
model's drag at the whole speed's Re); `--record NAME` writes benchmarks/history/NAME.json instead.  `--resolved-from
RECORD` takes each angle's fd3d stations and cost from an earlier record instead of running fd3d (the reduced model
re-measured against the same 3-D runs), and writes a record only when `--record` names one (so that it never rewrites
the record it reads unasked):

    python benchmarks/oblique_resolved.py --resolved-from benchmarks/history/oblique_resolved.json   # seconds, printed
    python benchmarks/oblique_resolved.py --resolved-from benchmarks/history/oblique_resolved.json \
        --set contact.inertial_speed=whole --record oblique_resolved_whole_speed
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fem_bounce import output, scene
from fem_bounce.run import simulate

QUANTITIES = ("incidence_deg", "psi_in", "psi_out", "normal_restitution", "tangential_restitution",
              "effective_friction", "spin_out")
HISTORY = Path(__file__).parent / "history"


def inclined(angle: float, **changes) -> scene.Scene:
    return scene.load("li2011-case3", {"gravity_angle": angle, "contact.friction": 0.02, **changes})


def plan(angle: float, out: Path, changes: dict) -> dict:
    """The ode run (rank 0) and the fd3d run's end time from its path."""
    comm = MPI.COMM_WORLD
    found = None
    if comm.rank == 0:
        run_dir = out / f"ode-{angle:g}"
        summary = simulate(inclined(angle, **{"run.bounces": 1, **changes}), "ode", MPI.COMM_SELF, run_dir, force=True,
                           progress=False, plots=False)
        trajectory = output.read_trajectory(run_dir)
        diameter = 0.0127
        rising = (trajectory["velocity"] > 0.0) & (trajectory["gap"] > 0.2 * diameter)
        leaves = float(trajectory["t"][np.argmax(rising)])
        end = math.ceil((leaves + 0.005) * 1000.0) / 1000.0
        found = {"summary": summary, "end_time": end}
    return comm.bcast(found, root=0)


def stations(summary: dict) -> dict:
    impact = summary["oblique_impacts"][0]
    return {station: {key: impact[station][key] for key in QUANTITIES} for station in ("outer", "contact")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--angles", default="30,60")
    parser.add_argument("--out", default="results/oblique-resolved")
    parser.add_argument("--reuse", action="store_true", help="read a finished fd3d run instead of running it")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                        help="a change to both models' scenes, e.g. numerics.fd3d.box=whole (repeatable)")
    parser.add_argument("--record", help="the record's name in benchmarks/history (default oblique_resolved; with "
                        "--resolved-from none is written unless this names one)")
    parser.add_argument("--resolved-from", type=Path, help="a record whose fd3d runs are taken, not run again")
    args = parser.parse_args()
    changes = dict(scene.parse_override(text) for text in args.overrides)
    out, comm = Path(args.out), MPI.COMM_WORLD
    earlier = ({run["angle_deg"]: run for run in json.loads(args.resolved_from.read_text())["runs"]}
               if args.resolved_from else {})
    records = []
    for angle in (float(a) for a in args.angles.split(",")):
        ode = plan(angle, out, changes)
        b = stations(ode["summary"])
        if earlier:  # the 3-D run as recorded (its settings: the end time and box its own ode run gave)
            if angle not in earlier:
                raise SystemExit(f"{args.resolved_from} has no run at {angle:g} degrees")
            settings, a, cost = (earlier[angle][key] for key in ("settings", "fd3d", "fd3d_cost"))
        else:
            run_dir = out / f"fd3d-{angle:g}"
            settings = {"run.end_time": ode["end_time"], **changes}
            if args.reuse and (run_dir / "summary.json").is_file():
                resolved = json.loads((run_dir / "summary.json").read_text())
            else:
                resolved = simulate(inclined(angle, **settings), "fd3d", comm, run_dir, force=True,
                                    progress=comm.rank == 0, plots=False)
            a = stations(resolved)
            cost = {"wall_time_s": resolved["wall_time_s"], "ranks": resolved["ranks"], "steps": resolved["steps"],
                    "unknowns": resolved["sizes"]["unknowns"],
                    "peak_memory_bytes": resolved["fd3d"]["peak_memory_bytes"],
                    "cross_coupling": resolved["fd3d"].get("cross_coupling"),
                    "out_of_plane": resolved["fd3d"].get("out_of_plane")}
        records.append({"angle_deg": angle, "settings": settings, "fd3d": a, "ode": b,
                        "difference": {s: {k: b[s][k] / a[s][k] - 1.0 if a[s][k] else None for k in QUANTITIES}
                                       for s in a},
                        "fd3d_cost": cost})
    if comm.rank != 0:
        return
    for record in records:
        cost = record["fd3d_cost"]
        print(f"{record['angle_deg']:g} degrees ({record['settings']}; fd3d {cost['wall_time_s']:.0f} s on "
              f"{cost['ranks']} rank(s), {cost['unknowns']} unknowns, {cost['peak_memory_bytes'] / 1e9:.1f} GB):")
        for station in ("outer", "contact"):
            cells = [f"{k} {record['fd3d'][station][k]:.4g} / {record['ode'][station][k]:.4g} "
                     f"({100 * record['difference'][station][k]:+.1f} %)" for k in QUANTITIES]
            print(f"  {station} (fd3d / ode, ode against fd3d): " + "; ".join(cells))
    name = args.record or (None if args.resolved_from else "oblique_resolved")
    if name is None:
        print("no record written (--resolved-from without --record)")
        return
    record = HISTORY / f"{name}.json"
    command = " ".join(["benchmarks/oblique_resolved.py", *sys.argv[1:]])
    record.write_text(json.dumps({"command": command, "runs": records}, indent=1) + "\n")
    print(f"written to {record}")


if __name__ == "__main__":
    main()
