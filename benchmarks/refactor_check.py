"""Did a refactor move any number?  Runs every model on small scenes and prints, per run, the impacts,
rebounds, final state, step count and a hash of trajectory.csv (rows to 10 digits), as JSON.

    python benchmarks/refactor_check.py > before.json     # on the old code
    python benchmarks/refactor_check.py --compare before.json   # on the new code: lists what moved
    python benchmarks/refactor_check.py --size 0d4af21          # the package's size then and now (no runs)
    python benchmarks/refactor_check.py --found a.json --compare b.json   # two records, no runs

Records in benchmarks/history/: refactor_check_before_issue25.json (at 0d4af21),
refactor_check_after_issue25.json (after its items 1-4, at c16a6dd: the same within 1.1e-11 but for
ode-pair-wall's one added wall record, a column at rest closing its last approach as one sphere does) and
refactor_check_issue25_done.json (fd and ale without a one-sphere path, the package smaller: the same as
the record before within 1e-10, with ode-three, fd-three and ale-three added).  Issue 34 (the PyPI stack):
refactor_check_dolfinx052.json (Debian's dolfinx 0.5.2 on this machine, at be6a627) and
refactor_check_dolfinx011.json (the same code on dolfinx 0.11; docs/performance.md accounts for each
difference).  refactor_check_issue35_done.json: after issues 35-38 (the ode model's exact Jacobian and step
control, the liquid's tension limit: rebounds higher, first impacts the same); the next refactor's baseline.

--compare prints each run's largest relative difference and lists the numbers that moved by more than
--rtol (1e-10 by default); numbers both below ZERO (1e-12, SI) in size are round-off zeros and compare
equal.  Two machines of the same kind differ by round-off (2e-15 relative in the ode
run, up to 1e-12 in the ale trajectory through MUMPS), so bit-for-bit equality is not portable; a real
change moves numbers by far more than 1e-10.  The trajectory's sha256 is printed when it differs, for
information only: it changes with the last of the 10 digits written.

About 4 minutes serial on the 2-core development machine.  Runs land in results/refactor_check/.
"""
from __future__ import annotations

import argparse
import ast
import hashlib
import json
import math
import subprocess
import sys
from pathlib import Path

from mpi4py import MPI

from fem_bounce import scene as scenes
from fem_bounce.errors import RunDiverged
from fem_bounce.run import run_logged as simulate  # the libraries' output goes to the run's run.log

CASES = {
    "ode-case3": ("li2011-case3", "ode", {"run.bounces": 2}),
    "fd-case3": ("li2011-case3", "fd", {"numerics.fd.cells_per_diameter": 8, "run.bounces": 1,
                                        "numerics.fd.checkpoint_every": 0}),
    "fd-brenner": ("brenner-approach", "fd", {"numerics.fd.cells_per_diameter": 8}),
    "ib-case3": ("li2011-case3", "ib", {"numerics.ib.cells_per_diameter": 8, "run.bounces": 1}),
    "ib-drag": ("sphere-drag-re100", "ib", {"numerics.ib.cells_per_diameter": 8, "run.end_time": 0.3}),
    "ale-case3": ("li2011-case3", "ale", {"numerics.ale.cells_per_diameter": 6, "run.bounces": 1}),
    "ale-brenner": ("brenner-approach", "ale", {"numerics.ale.cells_per_diameter": 6}),
    "ode-ehd": ("li2011-case3", "ode", {"contact.model": "ehd", "run.bounces": 1}),
    "ode-pair": ("yang-hunt2006-pair", "ode", {}),
    # an oblique collision: case 3's sphere launched at the wall 30 degrees off its normal, wet steel's friction
    "ode-oblique": ("li2011-case3", "ode", {"gravity": 0.0, "initial_gap": 0.00475, "initial_velocity": -0.33775,
                                            "tangential_velocity": 0.195, "contact.friction": 0.02, "run.bounces": 1}),
    "ode-pair-wall": ("pair-settling-wall", "ode", {}),
    "fd-pair": ("yang-hunt2006-pair", "fd", {"numerics.fd.cells_per_diameter": 12, "numerics.fd.constraint": "penalty",
                                              "numerics.fd.mesh": "fixed",
                                              "numerics.fd.checkpoint_every": 0}),
    "ale-pair": ("yang-hunt2006-pair", "ale", {"numerics.ale.cells_per_diameter": 6}),
    # three spheres: through the first wall and pair collisions
    "ode-three": ("three-spheres-wall", "ode", {"run.end_time": 0.09}),
    "fd-three": ("three-spheres-wall", "fd", {"numerics.fd.cells_per_diameter": 12, "run.end_time": 0.09,
                                              "numerics.fd.checkpoint_every": 0}),
    "ale-three": ("three-spheres-wall", "ale", {"numerics.ale.cells_per_diameter": 6, "run.end_time": 0.09}),
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
            "collisions": summary.get("collisions", []),
            "rows": len((out / "trajectory.csv").read_text().splitlines()) - 1}


# Below this absolute size [SI] a number is a round-off zero (the velocity at an apex: 7e-15 m/s) and has no
# relative digits to keep: two of them differ by less than ZERO whatever their ratio.
ZERO = 1e-12


def relative(a: float, b: float) -> float:
    if math.isnan(a) or math.isnan(b):
        return 0.0 if math.isnan(a) and math.isnan(b) else math.inf
    if abs(a - b) < ZERO and max(abs(a), abs(b)) < ZERO:
        return 0.0
    scale = max(abs(a), abs(b))
    return abs(a - b) / scale if scale else 0.0


def differences(before, after, path=""):
    """(path, before, after, relative difference) for every number; inf for anything else that differs."""
    if isinstance(before, dict) and isinstance(after, dict):
        for k in sorted(before.keys() | after.keys()):
            yield from differences(before.get(k), after.get(k), f"{path}.{k}")
    elif isinstance(before, list) and isinstance(after, list):
        for k, (a, b) in enumerate(zip(before, after)):
            yield from differences(a, b, f"{path}[{k}]")
        for k in range(min(len(before), len(after)), max(len(before), len(after))):  # added or removed
            old = before[k] if k < len(before) else "(none)"
            yield f"{path}[{k}]", old, after[k] if k < len(after) else "(none)", math.inf
    elif all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (before, after)):
        yield path, before, after, relative(before, after)
    elif before != after:
        yield path, before, after, math.inf


def compare(before: dict, found: dict, rtol: float) -> list[str]:
    """One line per run (its largest relative difference), then every number that moved by more than rtol."""
    report, changes = [], []
    for name, after in found.items():
        if name not in before:
            report.append(f"{name}: not in the record (a case added since): nothing to compare")
            continue
        old = before[name]
        diffs = [d for d in differences(old, after, name)
                 if not d[0].endswith(("wall_time_s", "trajectory_sha256"))]
        path, _, _, largest = max(diffs, key=lambda d: d[3], default=(name, None, None, 0.0))
        sha = "" if old.get("trajectory_sha256") == after.get("trajectory_sha256") else \
            "; trajectory sha256 differs (information only)"
        report.append(f"{name}: largest relative difference {largest:.3g}" + (f" ({path})" if largest else "") + sha)
        changes += [f"  {p}: {a!r} -> {b!r}" + (f" (relative {r:.3g})" if r < math.inf else "")
                    for p, a, b, r in diffs if r > rtol]
    if changes:
        report += [f"changed by more than rtol {rtol:g}:", *changes]
    else:
        report.append(f"unchanged within rtol {rtol:g}: {', '.join(n for n in found if n in before)}")
    return report


# What a branch on a special case looks like: an if, elif, while, conditional expression or comprehension
# filter whose condition names one of these (the package's size counts them).
SPECIAL_CASES = {"pair": {"pair"}, "second_sphere": {"second_sphere"}, "mode": {"mode", "modes"}}


def _conditions(tree: ast.AST):
    for node in ast.walk(tree):
        if isinstance(node, (ast.If, ast.IfExp, ast.While)):
            yield node.test
        elif isinstance(node, ast.comprehension):
            yield from node.ifs


def size(revision: str | None) -> dict:
    """Lines and modules of fem_bounce/ and its branches on special cases, in the working tree (None) or at a
    git revision."""
    listing = ["git", "ls-tree", "-r", "--name-only", revision, "fem_bounce"] if revision else \
        ["git", "ls-files", "fem_bounce"]
    files = subprocess.run(listing, capture_output=True, text=True, check=True)
    found = {"lines": 0, "modules": 0, **{f"branches_on_{name}": 0 for name in SPECIAL_CASES}}
    for path in (p for p in files.stdout.split() if p.endswith(".py")):
        text = (subprocess.run(["git", "show", f"{revision}:{path}"], capture_output=True, text=True, check=True).stdout
                if revision else Path(path).read_text())
        found["lines"] += len(text.splitlines())
        found["modules"] += 1
        for test in _conditions(ast.parse(text)):
            names = {n.id for n in ast.walk(test) if isinstance(n, ast.Name)} | \
                    {n.attr for n in ast.walk(test) if isinstance(n, ast.Attribute)}
            for name, spelled in SPECIAL_CASES.items():
                found[f"branches_on_{name}"] += bool(names & spelled)
    return found


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--compare", type=Path, help="a JSON this script printed before")
    parser.add_argument("--rtol", type=float, default=1e-10,
                        help="relative difference a number may move by with --compare (default 1e-10)")
    parser.add_argument("--only", help="comma-separated case names")
    parser.add_argument("--found", type=Path, help="no runs: compare this record (printed before, e.g. on another "
                        "stack) with --compare's")
    parser.add_argument("--size", metavar="REV", help="no runs: the package's lines, modules and branches on "
                        "pair / second_sphere / mode at git revision REV and in the working tree")
    args = parser.parse_args()
    if args.size:
        before, now = size(args.size), size(None)
        for key in before:
            print(f"{key}: {before[key]} at {args.size}, {now[key]} now")
        return 0
    names = args.only.split(",") if args.only else list(CASES)
    if args.found:
        found = {name: run for name, run in json.loads(args.found.read_text()).items() if name in names}
    else:
        # through JSON as a record is, so that a tuple compares with the list a record holds
        found = json.loads(json.dumps({name: fingerprint(name) for name in names}))
    if args.compare is None:
        print(json.dumps(found, indent=1))
        return 0
    report = compare(json.loads(args.compare.read_text()), found, args.rtol)
    print("\n".join(report))
    return 0 if report[-1].startswith("unchanged") else 1


if __name__ == "__main__":
    sys.exit(main())
