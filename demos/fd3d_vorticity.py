"""Demo: the vorticity in the plane of incidence around a sphere bouncing in 3-D.

What it solves. Li, Hunt & Colonius (2011) case 3 (steel in glycerol-water, released 1.6 D above the wall, Re ~ 90 at
impact) with the 3-D fictitious-domain model (fd3d: Taylor-Hood tetrahedra of the half box y >= 0, the mesh moving
with the sphere) at 6 cells/D, its surface unrefined (a fifth of the default's cost), to the first apex, writing
velocity, pressure and omega_y = du_x/dz - du_z/dx to XDMF every two steps. The figure is then drawn from those files
only (fem_bounce.fields reads a 3-D run in its symmetry plane y = 0, the moving mesh's displacement added): (a) the
trajectory with the snapshot instants, then contours of omega_y sqrt(D/g) from -0.5 to 0.5 every 0.05, as
demos/case7_vorticity.py draws the axisymmetric models', on both sides of the axis: approaching (gap 1 D), just
before contact, rebounding, at the apex. The sphere's outline is where the flow has it: below delta_sl D = 0.2 D the
flow holds it there and the contact model adds what it misses (docs/physics.md section 3.3); dashed, where the sphere
is then. The PNG is saved with 128 colours (a fifth of the size, the same look).

Run (at 6 cells/D on the moving mesh, about 1.5 minutes on one core; `--toy`: 4 cells/D to t = 0.02 s, a few seconds):

    python demos/fd3d_vorticity.py --out runs/demo-fd3d-vorticity --figure docs/figures/fd3d_vorticity_case3.png
    python demos/fd3d_vorticity.py --toy

(`--redraw` draws the figure and runs the checks again from an existing OUT.)

The check at the end: the primary ring beside the falling sphere has omega_y beyond the lowest contour level 0.05,
negative at x > 0 and positive at x < 0 (the two sides of one axisymmetric ring), and, just before contact, the
opposite-sign layer the fluid squeezed out along the wall makes is there on both sides.
"""
import argparse
import json
import sys
from pathlib import Path

import numpy as np
from mpi4py import MPI

import fem_bounce as fb
from fem_bounce import contact, fields, output

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--toy", action="store_true", help="4 cells per diameter to t = 0.02 s: for the test suite")
parser.add_argument("--out", type=Path, default=Path("runs/demo-fd3d-vorticity"))
parser.add_argument("--figure", type=Path, default=None, help="the figure's path (default OUT/vorticity.png)")
parser.add_argument("--redraw", action="store_true", help="no run: the figure and the checks from OUT's files")
args = parser.parse_args()

settings = {"numerics.fd3d.mesh": "moving", "numerics.fd3d.cells_per_diameter": 6,
            "numerics.fd3d.surface_refinement": 1, "numerics.fd3d.output_every": 2, "run.bounces": 1}
if args.toy:
    settings.update({"numerics.fd3d.cells_per_diameter": 4, "run.end_time": 0.02})
if not args.redraw:
    fb.simulate("li2011-case3", "fd3d", out=args.out, force=True, plots=not args.toy, **settings)

passed = True
if MPI.COMM_WORLD.rank == 0:
    summary, trajectory = output.read_summary(args.out), output.read_trajectory(args.out)
    scene = fb.load(args.out / "scene.toml")
    diameter, t_unit = scene.sphere.diameter, (scene.sphere.diameter / scene.gravity) ** 0.5
    t, gap = trajectory["t"], trajectory["gap"]
    impacts, rebounds = summary["impacts"], summary["rebounds"]
    if impacts:  # approaching at a gap of 1 D, just before contact, rebounding, at the apex
        impact = impacts[0]["time"]
        times = [float(t[np.argmax(gap <= diameter)]), impact - 1e-3]
        if rebounds and rebounds[0]["apex_time"] is not None:
            apex = rebounds[0]["apex_time"]
            times += [impact + (apex - impact) / 3.0, apex]
    else:  # the toy: the start of the fall
        times = list(np.linspace(0.3, 1.0, 3) * summary["final"]["time"])
    figure = fields.vorticity_figure(args.out, times=times, path=args.figure, extent=(1.75, 3.5), dpi=100)
    from PIL import Image  # matplotlib's own dependency

    Image.open(figure).convert("RGB").quantize(colors=128).save(figure, optimize=True)
    result = {"cells": summary["sizes"]["cells"], "steps": summary["steps"], "wall_time_s": summary["wall_time_s"],
              "final_velocity": summary["final"]["velocity"],
              "impact_speed": impacts[0]["impact_speed"] if impacts else None, "figure": str(figure)}
    print(f"{result['cells']} tetrahedra, {result['steps']} steps, {result['wall_time_s']:.0f} s; figure: {figure}")

    # The checks, on the snapshot just before contact (the toy: the last one)
    snapshots = fields.read_snapshots(args.out)
    when = impact - 1e-3 if impacts else snapshots[-1].time
    snap = min(snapshots, key=lambda s: abs(s.time - when))
    center = max(np.interp(snap.time, t, gap), contact.ContactModel(scene).hold_gap) + diameter / 2  # the flow's
    x, z = snap.points[:, 0], snap.points[:, 1]
    omega = snap.fields["vorticity_y"] * t_unit
    side = (np.hypot(x, z - center) > diameter / 2) & (np.abs(x) < 0.8 * diameter) & (np.abs(z - center) <
                                                                                       0.3 * diameter)
    wall = (z < 0.1 * diameter) & (np.abs(x) > 0.3 * diameter) & (np.abs(x) < 1.5 * diameter)
    found = {"ring_right": omega[side & (x > 0)].min(), "ring_left": omega[side & (x < 0)].max()}
    passed = bool(found["ring_right"] < -0.05 and found["ring_left"] > 0.05)
    if impacts:
        found.update(wall_right=omega[wall & (x > 0)].max(), wall_left=omega[wall & (x < 0)].min())
        passed &= bool(found["wall_right"] > 0.05 and found["wall_left"] < -0.05)
    result["omega_sqrt_D_g"] = {key: float(value) for key, value in found.items()}
    (args.out / "result.json").write_text(json.dumps(result, indent=1))
    print(f"t = {snap.time:.4f} s: omega_y sqrt(D/g) beside the sphere {found['ring_right']:.2f} at x > 0, "
          f"{found['ring_left']:.2f} at x < 0" + (f"; in the wall layer {found['wall_right']:.2f} at x > 0, "
                                                  f"{found['wall_left']:.2f} at x < 0" if impacts else ""))
    print(f"check {'PASS' if passed else 'FAIL'}  the ring beside the sphere (and before contact the opposite-sign "
          "wall layer) on both sides of the axis, beyond the lowest contour level 0.05")
sys.exit(0 if MPI.COMM_WORLD.bcast(passed, root=0) else 1)
