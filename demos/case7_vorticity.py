"""Demo: vorticity around a bouncing sphere, like Li, Hunt & Colonius (2011) Fig. 11 (case 7).

What it solves.  Case 7 of Table 2 (steel sphere released 3.75 D above the wall,
Re ~ 130 at impact) with the fd model, writing velocity, pressure and vorticity to
XDMF every few steps.  The figure is then drawn from those files only
(fem_bounce.fields): (a) the trajectory with the snapshot instants, (b) contours of
omega sqrt(D/g) from -0.5 to 0.5 every 0.05 before the first impact, rebounding
through the primary ring, at the apex, falling again, before the second impact.

Run (about 4 minutes at 16 cells per diameter on one core; `--toy` about 20 s):

    mpirun -n 2 python demos/case7_vorticity.py --out runs/demo-case7
    python demos/case7_vorticity.py --toy

The check at the end: the snapshots exist and show the primary ring: in the first
snapshot (just before impact) vorticity of both signs, the wall's opposite-sign layer
and the ring beside the sphere, each beyond the lowest contour level.
"""
import argparse
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fem_bounce import fields, validation

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--toy", action="store_true", help="8 cells per diameter, one bounce: for the test suite")
parser.add_argument("--out", type=Path, default=Path("runs/demo-case7"))
args = parser.parse_args()

overrides = {"numerics.fd.output_every": 10, "run.bounces": 2}
if args.toy:
    overrides.update({"numerics.fd.cells_per_diameter": 8, "run.bounces": 1})
result = validation.bouncing(MPI.COMM_WORLD, args.out, case=7, overrides=overrides)

if MPI.COMM_WORLD.rank == 0:
    figure = fields.vorticity_figure(args.out)
    print(f"impact Re = {result['Re_I']:.0f} (Table 2: {result['Re_I_reference']}); figure: {figure}")
    snapshots = fields.read_snapshots(args.out)
    summary_time = result and validation.plots.read_summary(args.out)["impacts"][0]["time"]
    before = min(snapshots, key=lambda s: abs(s.time - (summary_time - 1e-3)))
    omega = before.fields["vorticity"] * (0.0095 / 9.81) ** 0.5
    if not (omega.max() > 0.05 and omega.min() < -0.05):
        sys.exit(f"no vortex ring before the impact: omega sqrt(D/g) in [{omega.min():.3f}, {omega.max():.3f}]")
    print(f"before the impact omega sqrt(D/g) spans [{np.min(omega):.2f}, {np.max(omega):.2f}]")
