"""Demo: vorticity around a bouncing sphere, like Li, Hunt & Colonius (2011) Fig. 11 (case 7).

What it solves.  Case 7 of Table 2 (steel sphere released 3.75 D above the wall,
Re ~ 130 at impact) with the fd model, writing velocity, pressure and vorticity to
XDMF every few steps.  The figure is then drawn from those files only
(fem_bounce.fields): (a) the trajectory with the snapshot instants, (b) contours of
omega sqrt(D/g) from -0.5 to 0.5 every 0.05 before the first impact, rebounding
through the primary ring, at the apex, falling again, before the second impact.

Run (at the fd default, triangles D/8 along the path and D/40 on the surface, on one core; `--toy` about 20 s):

    mpiexec -n 2 python demos/case7_vorticity.py --out runs/demo-case7
    python demos/case7_vorticity.py --toy

The check at the end: just before the first impact the primary ring beside the sphere and
the opposite-sign layer at the wall both exceed the lowest contour level, 0.05.
"""
import argparse
import json
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fem_bounce import fields, output
from fem_bounce.studies import validation

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--toy", action="store_true", help="8 cells per diameter, one bounce: for the test suite")
parser.add_argument("--out", type=Path, default=Path("runs/demo-case7"))
args = parser.parse_args()

overrides = {"numerics.fd.output_every": 10, "run.bounces": 2}
if args.toy:
    overrides.update({"numerics.fd.cells_per_diameter": 8, "run.bounces": 1})
result = validation.bouncing(MPI.COMM_WORLD, args.out, case=7, overrides=overrides)

if MPI.COMM_WORLD.rank == 0:
    (args.out / "result.json").write_text(json.dumps(result, indent=1))
    figure = fields.vorticity_figure(args.out)
    print(f"impact Re = {result['Re_I']:.0f} (Table 2: {result['Re_I_reference']}); figure: {figure}")
    # Just before the first impact (paper: first snapshot) the wake's primary ring sits beside the
    # sphere with negative omega (u_z < 0 at its surface, 0 far away), and the fluid squeezed out
    # along the wall has made a layer of the opposite sign there.
    diameter, t_unit = 0.0095, (0.0095 / 9.81) ** 0.5
    summary = output.read_summary(args.out)
    impact = summary["impacts"][0]["time"]
    trajectory = output.read_trajectory(args.out)
    snap = min(fields.read_snapshots(args.out), key=lambda s: abs(s.time - (impact - 1e-3)))
    center = np.interp(snap.time, trajectory["t"], trajectory["gap"]) + diameter / 2
    r, z = snap.points[:, 0], snap.points[:, 1]
    omega = snap.fields["vorticity"] * t_unit
    side = (np.hypot(r, z - center) > diameter / 2) & (r < 0.8 * diameter) & (np.abs(z - center) < 0.3 * diameter)
    wall = (z < 0.1 * diameter) & (r > 0.3 * diameter) & (r < 1.5 * diameter)
    print(f"t = {snap.time:.4f} s: beside the sphere omega sqrt(D/g) >= {omega[side].min():.2f}, "
          f"in the wall layer <= {omega[wall].max():.2f}")
    passed = bool(omega[side].min() < -0.05 and omega[wall].max() > 0.05)
    print(f"check {'PASS' if passed else 'FAIL'}  ring beside the sphere and opposite-sign wall layer "
          "beyond the lowest contour level 0.05")
else:
    passed = True
sys.exit(0 if MPI.COMM_WORLD.bcast(passed, root=0) else 1)
