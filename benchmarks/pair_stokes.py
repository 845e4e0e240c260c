"""Steady Stokes drag of two spheres on their line of centres, resolved models against the exact theory
(issue 14, validation item 4, its first two bullets):

  together  two equal spheres moving at the same velocity U: the drag on each, F = -6 pi mu a U lambda,
            against Stimson & Jeffery (1926) (pair_theory.stimson_jeffery), at centre distances
            1.25, 1.5, 2, 2.5, 3 and 4 diameters;
  approach  sphere 1 moving at U toward a fixed equal sphere 2: F_1 = -6 pi mu a U X11 against
            Cooley & O'Neill (1969) (pair_theory.approach_fixed), at gaps from 1 D down to 0.1 D.

Each model has a function returning rows; main tabulates them and merges them into
benchmarks/history/pair_stokes.json with date, machine, commit and resolution.

    python benchmarks/pair_stokes.py fd --cells 12 16 24      # 12 min on the shared 2-core machine
    mpirun -n 2 python benchmarks/pair_stokes.py fd --cells 16

fd: the held pair's steady state of the time step (numerics.fd.steady_stokes, models/fd/steady.py),
the liquid of the brenner-approach preset (Re = 0.01 based on U), no wall (z = 0 a slip floor
far_field D below the pair) and far_field = 50 D (slip sides 50 D away: an unbounded liquid to about
1 %, measured by the `single` row, one sphere alone in the same kind of domain).  lambda_raw is
-F / (6 pi mu a U); lambda is lambda_raw / lambda_single, the pair's interaction with the single
sphere's own discretisation and confinement error (the diffuse interface's effective radius,
numerics.fd.radius_offset, and the far slip walls) divided out.  Both are tabulated.

Measured (benchmarks/history/pair_stokes.json, serial, the model's defaults otherwise):
  single    lambda_raw 1.004 / 1.008 / 1.011 at 12 / 16 / 24 cells/D (far field 50 D), 0.996 at
            12 cells/D with far field 100 D: the slip sides at 50 D add ~0.8 %, the diffuse sphere's
            effective radius is within ~1 % of a (its drag scales with it).
  together  lambda within +0.7 .. +1.4 % of Stimson & Jeffery at every separation and resolution
            (24 cells/D: +0.71 % at gap 0.25 D up to +1.26 % at 3 D); the error grows with separation
            because the slip sides weaken the far interaction: +0.50 .. +0.76 % with far field 100 D.
  approach  24 cells/D: -1.1 / -1.6 / -2.6 / -6.6 % at gaps 1 / 0.5 / 0.25 / 0.1 D (16 cells/D:
            -1.2 / -1.9 / -3.4 / -9.7 %): within 2 % down to 0.5 D; closer, the squeeze flow in the gap
            (2.4 cells across 0.1 D at 24 cells/D, one of them inside the indicators' supports) is
            under-resolved, as for Brenner's wall drag (docs/validation.md, fd: -2.0 % at 0.25 D).
"""
from __future__ import annotations

import argparse
import json
import math
import platform
import subprocess
import time
import warnings
from pathlib import Path

from mpi4py import MPI

from fem_bounce import pair_theory
from fem_bounce import scene as scenes

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "history" / "pair_stokes.json"
CENTRE_DISTANCES = (1.25, 1.5, 2.0, 2.5, 3.0, 4.0)  # together, in diameters
APPROACH_GAPS = (1.0, 0.5, 0.25, 0.1)  # approach, surface gap in diameters
SPEED = 1e-3  # [m/s]


def pair_scene(model: str, gap_diameters: float | None, velocities: tuple[float, float], far_field: float,
               changes: dict) -> scenes.Scene:
    """The brenner-approach liquid and sphere held at velocities (sphere 1, sphere 2) [m/s] with an equal
    second sphere `gap_diameters` above it (None: sphere 1 alone), no wall, far_field D to the slip sides."""
    base = scenes.load("brenner-approach")
    diameter = base.sphere.diameter
    settings = {"wall.present": False, "initial_gap": far_field * diameter, "motion.velocity": velocities[0],
                f"numerics.{model}.far_field": far_field, **changes}
    if gap_diameters is not None:
        sphere = base.sphere
        settings.update({"second_sphere.diameter": diameter, "second_sphere.density": sphere.density,
                         "second_sphere.youngs_modulus": sphere.youngs_modulus,
                         "second_sphere.poisson_ratio": sphere.poisson_ratio,
                         "second_sphere.gap": gap_diameters * diameter, "second_sphere.velocity": velocities[1],
                         "second_sphere.mode": "fixed", "contact.history": "off"})
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return scenes.load("brenner-approach", settings)


class _HeldPair:
    """What a flow model's build asks of the sphere integrator, for spheres held in place: no contact
    hold (a held pair never approaches)."""

    hold_gaps = (0.0, 0.0)

    class contact:
        hold_gap = 0.0


def fd_steady_forces(comm, scene) -> tuple:
    """The fd model's steady Stokes force(s) on the held sphere(s) [N] and the mesh's cell count."""
    from fem_bounce.models.fd.model import FictitiousDomainModel

    model = FictitiousDomainModel(scene, comm)
    try:
        model.build(_HeldPair())
        return model.steady_forces(), model.sizes()["cells"]
    finally:
        model.destroy()


def fd_rows(comm, cells: float, far_field: float = 50.0) -> list[dict]:
    """The fd model at `cells` per diameter: one row per configuration (the isolated sphere first)."""
    changes = {"numerics.fd.cells_per_diameter": cells, "numerics.fd.steady_stokes": True}
    single = pair_scene("fd", None, (-SPEED, 0.0), far_field, changes)
    a, mu = single.sphere.radius, single.liquid.viscosity
    stokes = 6.0 * math.pi * mu * a * SPEED
    start = time.perf_counter()
    force, n_cells = fd_steady_forces(comm, single)
    lambda_single = force / stokes  # the sphere moves down: the drag pushes up
    rows = [{"model": "fd", "cells_per_diameter": cells, "case": "single", "gap_D": None, "lambda_raw": lambda_single,
             "lambda": 1.0, "reference": 1.0, "error": lambda_single - 1.0, "cells": n_cells,
             "wall_time_s": time.perf_counter() - start}]
    configurations = [("together", distance - 1.0, (-SPEED, -SPEED)) for distance in CENTRE_DISTANCES]
    configurations += [("approach", gap, (SPEED, 0.0)) for gap in APPROACH_GAPS]
    for case, gap, velocities in configurations:
        start = time.perf_counter()
        scene = pair_scene("fd", gap, velocities, far_field, changes)
        try:
            forces, n_cells = fd_steady_forces(comm, scene)
        except scenes.SceneError as err:  # closer than the indicators allow at this resolution
            if comm.rank == 0:
                print(f"fd, {cells:g} cells/D, {case} at {gap:g} D: skipped ({err})")
            continue
        h = gap * 2.0 * a
        if case == "together":
            raw = [-f / (6.0 * math.pi * mu * a * velocities[0]) for f in forces]
            reference = pair_theory.stimson_jeffery(a, h)
        else:
            raw = [-forces[0] / (6.0 * math.pi * mu * a * velocities[0])]
            reference = pair_theory.approach_fixed(a, a, h)
        measured = sum(raw) / len(raw) / lambda_single  # together: the mean of the two spheres
        rows.append({"model": "fd", "cells_per_diameter": cells, "case": case, "gap_D": gap,
                     "lambda_raw": raw, "lambda": measured, "reference": reference,
                     "error": measured / reference - 1.0, "cells": n_cells,
                     "wall_time_s": time.perf_counter() - start})
    return rows


MODELS = {"fd": fd_rows}


def provenance() -> dict:
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True,
                                cwd=HERE).stdout.strip()
    except OSError:
        commit = "?"
    return {"date": time.strftime("%Y-%m-%dT%H:%M:%S"), "machine": platform.node(), "ranks": MPI.COMM_WORLD.size,
            "commit": commit}


def table(rows: list[dict]) -> str:
    lines = ["| model | cells/D | case | gap/D | lambda_raw | lambda | theory | error |",
             "|---|---|---|---|---|---|---|---|"]
    for row in rows:
        raw = row["lambda_raw"]
        raw_text = " / ".join(f"{x:.4f}" for x in raw) if isinstance(raw, list) else f"{raw:.4f}"
        gap = row["gap_D"] if row["gap_D"] is not None else math.inf
        lines.append(f"| {row['model']} | {row['cells_per_diameter']:g} | {row['case']} | {gap:g} | {raw_text} | "
                     f"{row['lambda']:.4f} | {row['reference']:.4f} | {row['error']:+.2%} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("models", nargs="*", default=list(MODELS), choices=list(MODELS))
    parser.add_argument("--cells", type=float, nargs="+", default=[16.0], help="cells per diameter")
    parser.add_argument("--far-field", type=float, default=50.0, help="slip sides this many D away")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    rows = [row for model in args.models for cells in args.cells
            for row in MODELS[model](comm, cells, args.far_field)]
    if comm.rank != 0:
        return
    print(table(rows))
    history = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    for model in args.models:
        for cells in args.cells:
            key = f"{model}-{cells:g}cpd-far{args.far_field:g}"
            history[key] = {**provenance(), "far_field": args.far_field,
                            "rows": [r for r in rows if r["model"] == model and r["cells_per_diameter"] == cells]}
    RESULTS.write_text(json.dumps(history, indent=1, default=float) + "\n")


if __name__ == "__main__":
    main()
