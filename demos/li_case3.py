"""Demo: a steel sphere bouncing on a glass wall in glycerol-water, Li, Hunt & Colonius (2011) case 3.

What it solves.  The paper's section 4 model with the resolved flow: a steel sphere
(rho_p / rho_l = 6.5) released from rest 1.6 D above a Zerodur wall in 78 %
glycerol.  The fd model resolves the flow around the falling and rebounding sphere;
below delta_sl = 0.2 its flow holds the sphere there and the contact model adds the unresolved
lubrication and wall added-mass forces (docs/physics.md section 3.3).  The default contact,
contact.model = "lubricated-hertz" (docs/physics.md section 2.1; fem_bounce/contact.py), makes it
rebound: the lubrication film is carried down to a contact gap computed from the surfaces' roughness
and the elastohydrodynamic gap, where a damped Hertz contact with the materials' modulus takes over.
(The paper's elastic force f_ss, with the preset's delta_ss = 0.017, acts only with
`--set contact.model=li2011`.)  The run stops at the apex after the third impact (the preset's
run.bounces).

    first impact speed (2 ms mean) vs 0.393 m/s, Re of the second impact vs 55 (Table 2)

Run (at the fd default: triangles D/8 along the path and D/40 on the surface, numerics.fd
cells_per_diameter 8 and surface_refinement 5, on one core; `--toy` about 20 s):

    mpiexec -n 2 python demos/li_case3.py --out runs/demo-case3
    python demos/li_case3.py --toy

The checks at the end: at least two rebounds and the first impact speed within 15 % of
Table 2 (required); the validation targets, impact speed within 5 % and Re_II within 10 %,
are reported as PASS or MISS; docs/validation.md has the measured numbers at each
resolution.
"""
import argparse
import json
import sys
from pathlib import Path

from mpi4py import MPI

from fem_bounce import scene
from fem_bounce.studies import validation

parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
parser.add_argument("--toy", action="store_true", help="8 cells per diameter, two bounces: for the test suite")
parser.add_argument("--out", type=Path, default=Path("runs/demo-case3"))
parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE")
args = parser.parse_args()

overrides = {"numerics.fd.cells_per_diameter": 8, "run.bounces": 2} if args.toy else {}
overrides.update(dict(scene.parse_override(text) for text in args.overrides))
result = validation.bouncing(MPI.COMM_WORLD, args.out, case=3, overrides=overrides)

# Required: the sphere rebounds at least twice and the first impact is the right kind of event
# (within 15 % of the measured speed).  Targets (reported, not required): 5 % and 10 % (docs/validation.md section 4).
checks = [
    validation.Check("first impact speed, 2 ms mean [m/s]", result["impact_speed"],
                     result["impact_speed_reference"], 0.15),
    validation.Check("first impact speed, 2 ms mean [m/s]", result["impact_speed"],
                     result["impact_speed_reference"], 0.05, required=False),
]
if result["Re_II"] is not None:
    checks.append(validation.Check("Re of the second impact", result["Re_II"], result["Re_II_reference"], 0.10,
                                   required=False))
if MPI.COMM_WORLD.rank == 0:
    (args.out / "result.json").write_text(json.dumps(result, indent=1))
    print(f"Re_I = {result['Re_I']:.1f} (Table 2: {result['Re_I_reference']}); figures: "
          f"{args.out / 'trajectory.png'}, {args.out / 'velocity_gap.png'}")
    print(f"check {'PASS' if result['rebounds'] >= 2 else 'FAIL'}  rebounds: {result['rebounds']} (at least 2)")
passed = validation.report(checks) and result["rebounds"] >= 2 if MPI.COMM_WORLD.rank == 0 else True
sys.exit(0 if MPI.COMM_WORLD.bcast(passed, root=0) else 1)
