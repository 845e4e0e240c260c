"""Demo: drag coefficient of a sphere held in a uniform stream at Re = 100 and 200.

What it solves.  Axisymmetric flow past a fixed sphere: a uniform stream U enters
through z = 0, leaves through the top (do-nothing), slip at r = R = 10 D.  The fd
model marches its time step (BDF2, extrapolated convection, immersed forcing of the
sphere's interior) from an impulsive start until the drag settles, on the same mesh
rules and time step rules the bouncing runs use.

    Cd = F / (rho U^2 pi a^2 / 2)    vs 1.087 (Re 100, Johnson & Patel 1999) and 0.77 (Re 200, Fornberg 1988)

Run (at the fd default, triangles D/8 along the path and D/40 on the surface, on one core; `--toy` about 20 s):

    mpiexec -n 2 python demos/sphere_drag.py --out runs/demo-drag
    python demos/sphere_drag.py --toy

The check at the end: Cd within 3 % of the reference (10 % at toy size: 8 cells per
diameter, Re = 100 only, 1 s of flow).
"""
import argparse
import json
import sys
from pathlib import Path

from mpi4py import MPI

from fem_bounce.studies import validation

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--toy", action="store_true", help="8 cells per diameter, Re = 100, 1 s: for the test suite")
parser.add_argument("--out", type=Path, default=Path("runs/demo-drag"))
args = parser.parse_args()

# 3 s of flow is 30 passages of the stream past the sphere: Cd then changes by < 0.1 % per second.
overrides = {"numerics.fd.cells_per_diameter": 8, "run.end_time": 1.0} if args.toy else {"run.end_time": 3.0}
tolerance = 0.10 if args.toy else 0.03
results = [validation.drag_coefficient(MPI.COMM_WORLD, args.out / f"re{re}", reynolds=re, overrides=overrides)
           for re in ((100,) if args.toy else (100, 200))]

checks = [validation.Check(f"Cd at Re = {r['Re']:.0f}", r["Cd"], r["reference"], tolerance) for r in results]
if MPI.COMM_WORLD.rank == 0:
    (args.out / "result.json").write_text(json.dumps(results, indent=1))
    for r in results:
        print(f"Re = {r['Re']:.0f}: Cd changed by {r['settling']:.1e} over the last 10 % of the run")
passed = validation.report(checks) if MPI.COMM_WORLD.rank == 0 else True
sys.exit(0 if MPI.COMM_WORLD.bcast(passed, root=0) else 1)
