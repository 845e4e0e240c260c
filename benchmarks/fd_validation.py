"""Full-resolution validation of the fd model: the numbers of docs/validation.md's summary and section 7.

    python benchmarks/fd_validation.py                       # every section, 16 cells per diameter
    python benchmarks/fd_validation.py brenner drag --cells 32
    python benchmarks/fd_validation.py brenner --set numerics.fd.constraint=implicit
    mpiexec -n 2 python benchmarks/fd_validation.py cases

Sections (each a function of fem_bounce.studies.validation, runs under runs/fd-validation/):
  brenner   Stokes wall drag lambda at delta = 1, 0.5, 0.25 vs Brenner (1961)      ~1 min
  drag      Cd of a held sphere at Re = 100, 200 vs 1.087, 0.77, 3 s of flow       ~10 min at 16 cells
  tencate   ten Cate E4 peak speed vs 0.1226 m/s                                     ~5 min
  case3     Li case 3 (3 bounces), also with contact.inertial_factor = "none"       ~5 min
  cases     Li cases 1-7 to the second impact: V_i, Re_I, Re_II vs Table 2          ~15 min
Results are merged into benchmarks/history/fd_validation.json with the date, machine,
commit and resolution (small, committed); the cases table also goes to fd_cases.csv.
"""
from __future__ import annotations

import argparse
import csv
import json
import platform
import time
from pathlib import Path

from mpi4py import MPI

from fem_bounce import scene
from fem_bounce.studies import validation
from provenance import stamp

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "history" / "fd_validation.json"


def provenance(cells: float) -> dict:
    return {**stamp(), "processor": platform.processor(), "ranks": MPI.COMM_WORLD.size, "cells_per_diameter": cells}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("sections", nargs="*", default=["brenner", "drag", "tencate", "case3", "cases"])
    parser.add_argument("--cells", type=float, default=16.0, help="numerics.fd.cells_per_diameter")
    parser.add_argument("--out", type=Path, default=Path("runs/fd-validation"))
    parser.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                        help="a scene setting for every section (recorded in the history key)")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    changes = dict(scene.parse_override(item) for item in args.set)  # read as fem-bounce's --set reads them
    resolution = {"numerics.fd.cells_per_diameter": args.cells, **changes}
    tag = f"{args.cells:g}cpd" + "".join(f",{k}={v}" for k, v in sorted(changes.items()))
    found: dict = {}
    started = time.perf_counter()
    if "brenner" in args.sections:
        found["brenner"] = validation.brenner_drag(comm, args.out / f"brenner-{tag}", overrides=resolution)
    if "drag" in args.sections:
        found["drag"] = [validation.drag_coefficient(comm, args.out / f"drag{re}-{tag}", re,
                                                     overrides={**resolution, "run.end_time": 3.0})
                         for re in (100, 200)]
    if "tencate" in args.sections:
        found["tencate"] = validation.settling(comm, args.out / f"tencate-{tag}", overrides=resolution)
    if "case3" in args.sections:
        found["case3"] = validation.bouncing(comm, args.out / f"case3-{tag}", 3, overrides=resolution)
        found["case3_inertial_factor_none"] = validation.bouncing(
            comm, args.out / f"case3-sn-none-{tag}", 3, overrides={**resolution, "contact.inertial_factor": "none"})
    if "cases" in args.sections:
        rows = []
        for case in range(1, 8):
            extra = {"numerics.fd.output_every": 20} if case == 7 else {}
            rows.append(validation.bouncing(comm, args.out / f"case{case}-{tag}", case,
                                            overrides={**resolution, "run.bounces": 2, **extra}))
        found["cases"] = rows
        if comm.rank == 0:
            from fem_bounce import fields

            found["case7_vorticity_figure"] = str(fields.vorticity_figure(args.out / f"case7-{tag}"))
            with open(HERE / "history" / "fd_cases.csv", "w", newline="") as stream:
                writer = csv.writer(stream)
                writer.writerow(["case", "V_i", "V_i_table2", "Re_I", "Re_I_table2", "Re_II", "Re_II_table2", "St_I",
                                 "rebounds", "cells_per_diameter"])
                for r in rows:
                    writer.writerow([r["case"], f"{r['impact_speed']:.4f}", r["impact_speed_reference"],
                                     f"{r['Re_I']:.1f}", r["Re_I_reference"],
                                     f"{r['Re_II']:.1f}" if r["Re_II"] is not None else "", r["Re_II_reference"],
                                     f"{r['St_I']:.1f}", r["rebounds"], args.cells])
    if comm.rank == 0:
        RESULTS.parent.mkdir(exist_ok=True)
        stored = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
        for key, value in found.items():
            stored[f"{key}@{tag}"] = {"provenance": {**provenance(args.cells), "settings": changes}, "result": value}
        RESULTS.write_text(json.dumps(stored, indent=1) + "\n")
        print(json.dumps(found, indent=1))
        print(f"{time.perf_counter() - started:.0f} s; results in {RESULTS}")


if __name__ == "__main__":
    main()
