"""Steady Stokes drag of two spheres on the axis with the boundary-fitted ale flow (issue 14, item 4).

    python benchmarks/pair_stokes_ale.py                 # 8, 16, 32 cells/D, both checks     ~2 min serial
    python benchmarks/pair_stokes_ale.py --cells 8 16    # fewer resolutions

Both spheres have diameter D and are held where they are, their surfaces moving along the axis (the
quasi-steady Stokes problem, as in the Brenner check of ale_validation.py); the liquid is unbounded, here
a slip-walled cylinder of radius 2000 D and height 4000 D with the pair in the middle (the truncation
adds about 0.7 D / R to one sphere's drag: +0.2 % at R = 400 D, +0.014 % here; the `alone` rows show it
with the discretisation error).  lambda = F / (6 pi mu a U):

- together: both at U, centre distance l = 1.1, 2.5, 3, 4 D, against Stimson & Jeffery (1926);
- approach: the upper sphere at -U toward the lower one, held at rest, gap h = 1 D down to 0.01 D, the
  force on each against Cooley & O'Neill (1969) (fem_bounce.pair_theory).

The force is the ale model's variational reaction force (models/ale/flow.py).  The table goes to
results/ale/pair_stokes/pair_stokes.md and benchmarks/history/ale/pair_stokes.md, the numbers to
benchmarks/history/pair_stokes_ale.json.  Runs serial or under mpirun.
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
import ufl
from mpi4py import MPI

from fem_bounce import pair_theory
from fem_bounce.fem.mesh import OUTER, SPHERE, SPHERE_2, TOP, WALL, Box, HalfPlane, SphereHole, create_mesh
from fem_bounce.models.ale.flow import SphereFlow

COMM = MPI.COMM_WORLD
DIAMETER, VISCOSITY, SPEED = 0.01, 1.0, 1e-3  # [m, Pa s, m/s]: Re = 1e-5, Stokes flow
FAR_FIELD = 2000.0  # the box's half-height and radius, in D (400 D left +0.2 % on one sphere alone)
GAP_CELLS = 2.0  # triangles across a thin gap (numerics.ale.min_gap_cells)
GRADING = 0.2
ROOT = Path("results") / "ale" / "pair_stokes"
HISTORY = Path(__file__).parent / "history"


def say(text: str) -> None:
    if COMM.rank == 0:
        print(text, flush=True)


def pair_box(cells: float, gaps: list[float]) -> HalfPlane:
    """The slip box with spheres of diameter D on the axis, the first centred at mid-height, `gaps`
    between consecutive surfaces (none: one sphere alone)."""
    fine, radius = DIAMETER / cells, DIAMETER / 2
    holes = [SphereHole(center=FAR_FIELD * DIAMETER, radius=radius, surface_size=fine, gap_cells=GAP_CELLS)]
    for gap in gaps:
        holes.append(SphereHole(center=holes[-1].top + gap + radius, radius=radius, surface_size=fine,
                                gap_cells=GAP_CELLS))
    refined = Box(r_max=DIAMETER, z_min=holes[0].gap - DIAMETER / 2, z_max=holes[-1].top + DIAMETER / 2)
    return HalfPlane(radius=FAR_FIELD * DIAMETER, height=2 * FAR_FIELD * DIAMETER, fine_size=fine,
                     coarse_size=FAR_FIELD * DIAMETER / 4, grading=GRADING, refined=(refined,), holes=tuple(holes))


def steady_drag(cells: float, gaps: list[float], velocities: list[float]) -> tuple[np.ndarray, int, float]:
    """(lambda per sphere, cells, seconds) of the steady Stokes flow with the surfaces at `velocities`
    [m/s]; lambda_i = F_i / (6 pi mu a |U|) with U the largest speed, sign: the drag opposes U."""
    start = time.perf_counter()
    mesh, _, facet_tags = create_mesh(COMM, pair_box(cells, gaps), cache=False)
    slip = {WALL: "slip", OUTER: "slip", TOP: "slip"}
    flow = SphereFlow(mesh, facet_tags, slip, 1000.0, VISCOSITY, 1.0, ufl.as_vector((0.0, 0.0)),
                      sphere_tags=(SPHERE, SPHERE_2)[: len(gaps) + 1])
    try:
        forces = np.atleast_1d(flow.steady(velocities, convection=False))
    finally:
        flow.destroy()
    speed = max(abs(v) for v in velocities)
    direction = math.copysign(1.0, [v for v in velocities if abs(v) == speed][0])
    stokes = 6.0 * math.pi * VISCOSITY * DIAMETER / 2 * speed
    return -direction * forces / stokes, mesh.topology.index_map(2).size_global, time.perf_counter() - start


def error(value: float, exact: float) -> float:
    return 100.0 * (value / exact - 1.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cells", type=float, nargs="+", default=[8.0, 16.0, 32.0])
    args = parser.parse_args()
    a = DIAMETER / 2
    records = []
    for cells in args.cells:
        lam, count, seconds = steady_drag(cells, [], [-SPEED])
        records.append({"case": "alone", "cells_per_diameter": cells, "gap_over_D": None, "exact": [1.0],
                        "lambda": lam.tolist(), "cells": count, "seconds": seconds})
        for distance in (1.1, 2.5, 3.0, 4.0):  # centre distance / D
            gap = (distance - 1.0) * DIAMETER
            lam, count, seconds = steady_drag(cells, [gap], [-SPEED, -SPEED])
            exact = pair_theory.stimson_jeffery(a, gap)
            records.append({"case": "together", "cells_per_diameter": cells, "gap_over_D": distance - 1.0,
                            "exact": [exact, exact], "lambda": lam.tolist(), "cells": count, "seconds": seconds})
        for delta in (1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01):
            gap = delta * DIAMETER
            lam, count, seconds = steady_drag(cells, [gap], [0.0, -SPEED])
            # the upper sphere (2) moves toward the lower one (1), held: lambda_2 is Cooley & O'Neill's
            # approach factor (X22 = X11 for equal spheres); the held sphere is pushed along with
            # F_1 = -6 pi mu a X12 U2, so lambda_1 = X12 < 0 in this sign convention
            moving = pair_theory.approach_fixed(a, a, gap)
            held = float(pair_theory.resistance(a, a, gap)[0, 1])
            records.append({"case": "approach", "cells_per_diameter": cells, "gap_over_D": delta,
                            "exact": [held, moving], "lambda": lam.tolist(), "cells": count, "seconds": seconds})
        say(f"{cells:g} cells/D done")
    write(records)


def write(records: list[dict]) -> None:
    header = ["case", "cells/D", "gap / D", "exact lambda_1", "lambda_1", "error_1", "exact lambda_2", "lambda_2",
              "error_2", "cells", "seconds"]
    rows = []
    for r in records:
        exact, lam = r["exact"], r["lambda"]
        pairs = [(f"{e:.5f}", f"{v:.5f}", f"{error(v, e):+.2f} %") for e, v in zip(exact, lam)]
        if len(pairs) == 1:
            pairs.append(("", "", ""))
        gap = "" if r["gap_over_D"] is None else f"{r['gap_over_D']:g}"
        rows.append([r["case"], f"{r['cells_per_diameter']:g}", gap, *pairs[0], *pairs[1], r["cells"],
                     f"{r['seconds']:.1f}"])
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(x) for x in row) + " |" for row in rows]
    text = "\n".join(lines) + "\n"
    say(text)
    if COMM.rank == 0:
        for path in (ROOT / "pair_stokes.md", HISTORY / "ale" / "pair_stokes.md"):
            path.parent.mkdir(parents=True, exist_ok=True)
            path.write_text(text)
        meta = {"command": "python benchmarks/pair_stokes_ale.py", "ranks": COMM.size,
                "far_field_D": FAR_FIELD, "gap_cells": GAP_CELLS, "grading": GRADING, "records": records}
        (HISTORY / "pair_stokes_ale.json").write_text(json.dumps(meta, indent=1) + "\n")


if __name__ == "__main__":
    main()
