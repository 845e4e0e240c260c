"""Steady Stokes drag of two spheres on their line of centres, resolved models against the exact theory
(the pair's Stokes validation):

  together  two equal spheres moving at the same velocity U: the drag on each, F = -6 pi mu a U lambda,
            against Stimson & Jeffery (1926) (pair_theory.stimson_jeffery);
  approach  one sphere moving at U toward a held equal sphere: the moving sphere's F = -6 pi mu a U X11
            against Cooley & O'Neill (1969) (pair_theory.approach_fixed); ale also tabulates the held
            sphere's push, lambda = X12 < 0 (`approach-held`, pair_theory.resistance);
  single    one sphere alone in the same kind of domain at the same resolution (exact: 1).

Every row gives lambda_raw = F / (6 pi mu a U) (together: each sphere's) and error_raw against the exact
value, and lambda = lambda_raw / lambda_single (the mean of the two spheres, together) with its error: the
pair's interaction with the lone sphere's own discretisation and confinement error divided out.  The
domain of each model is printed with its rows and recorded.  Each model has a function returning rows;
main tabulates them and merges one record per model and resolution into benchmarks/history/pair_stokes.json
(date, machine, ranks, commit, command, cells per diameter, far field and domain, rows).

    python benchmarks/pair_stokes.py [fd] [ale] [--cells N ...] [--far-field D]
    python benchmarks/pair_stokes.py fd --cells 12 16 24      # 12 min on the shared 2-core machine
    python benchmarks/pair_stokes.py ale --cells 8 16 32      # 2 min
    python benchmarks/pair_stokes.py fd --cells 12 --far-field 100
    mpiexec -n 2 python benchmarks/pair_stokes.py fd ale --cells 16

No model named: both; no --cells: fd 16, ale 8 16 32; no --far-field: fd 50 D, ale 2000 D.

fd: the held pair's steady state of the time step (numerics.fd.steady_stokes, models/fd/steady.py),
the liquid of the brenner-approach preset (Re = 0.01 based on U), no wall (z = 0 a slip floor
far_field D below the pair) and far_field = 50 D (slip sides 50 D away: an unbounded liquid to about
1 %, measured by the `single` row).  Centre distances 1.25, 1.5, 2, 2.5, 3 and 4 D (together); sphere 1
moving up at U toward sphere 2, gaps 1 D down to 0.1 D (approach).  lambda divides out the diffuse
interface's effective radius (numerics.fd.radius_offset) and the far slip walls.

ale: the boundary-fitted flow (models/ale/flow.py, SphereFlow.steady, the variational reaction force),
both spheres of diameter D held where they are, their surfaces moving along the axis (the quasi-steady
Stokes problem, as in the Brenner check of ale_validation.py), mu = 1 Pa s, Re = 1e-5; the liquid is a
slip-walled cylinder of radius 2000 D and height 4000 D with the pair in the middle (the truncation adds
about 0.7 D / R to one sphere's drag: +0.2 % at R = 400 D, +0.014 % here; the `single` row shows it with
the discretisation error), 2 triangles across a thin gap, grading 0.2.  Centre distances 1.1, 2.5, 3 and
4 D (together); the upper sphere moving down at U onto the lower one, held, gaps 1 D down to 0.01 D
(approach).

Measured (benchmarks/history/pair_stokes.json, serial, the models' defaults otherwise):
 fd
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
 ale
  single    lambda_raw 0.9966 / 0.9993 / 1.0001 at 8 / 16 / 32 cells/D.
  together  lambda_raw within -0.26 / -0.04 / +0.05 % of Stimson & Jeffery at 8 / 16 / 32 cells/D at
            every separation (lambda, the lone sphere's error divided out: within +0.10 / +0.05 / +0.03 %).
  approach  the moving sphere's lambda_raw within -2.01 / -1.07 / -0.65 % of Cooley & O'Neill at 8 / 16 /
            32 cells/D at every gap from 1 D to 0.01 D (the largest errors at 0.05-0.02 D), the held
            sphere's within -2.34 / -1.26 / -0.71 % (lambda: -1.67 / -0.99 / -0.66 % moving, -2.00 / -1.19 /
            -0.72 % held).
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
import warnings
from pathlib import Path

from mpi4py import MPI

from fem_bounce import pair_theory
from provenance import stamp

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "history" / "pair_stokes.json"
SPEED = 1e-3  # [m/s]


def make_row(model: str, cells: float, far_field: float, domain: str, case: str, gap: float | None,
             raw: float | list[float], single: float, reference: float, n_cells: int, seconds: float) -> dict:
    """One table row: lambda_raw (the lone sphere's number, or one per sphere), its mean over lambda_single
    (lambda) and both errors against the exact `reference`."""
    mean = sum(raw) / len(raw) if isinstance(raw, list) else raw
    measured = mean / single
    return {"model": model, "cells_per_diameter": cells, "far_field_D": far_field, "domain": domain, "case": case,
            "gap_D": gap, "lambda_raw": raw, "error_raw": mean / reference - 1.0, "lambda": measured,
            "reference": reference, "error": measured / reference - 1.0, "cells": n_cells, "wall_time_s": seconds}


# --- fd: the fictitious-domain model's held pair -------------------------------------------------------

FD_CENTRE_DISTANCES = (1.25, 1.5, 2.0, 2.5, 3.0, 4.0)  # together, in diameters
FD_APPROACH_GAPS = (1.0, 0.5, 0.25, 0.1)  # approach, surface gap in diameters


def pair_scene(model: str, gap_diameters: float | None, velocities: tuple[float, float], far_field: float,
               changes: dict):
    """The brenner-approach liquid and sphere held at velocities (sphere 1, sphere 2) [m/s] with an equal
    second sphere `gap_diameters` above it (None: sphere 1 alone), no wall, far_field D to the slip sides."""
    from fem_bounce import scene as scenes

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


def fd_rows(comm, cells: float, far_field: float | None = None) -> list[dict]:
    """The fd model at `cells` per diameter: one row per configuration (the isolated sphere first)."""
    from fem_bounce import scene as scenes

    far_field = 50.0 if far_field is None else far_field
    domain = f"slip sides {far_field:g} D"
    changes = {"numerics.fd.cells_per_diameter": cells, "numerics.fd.steady_stokes": True}
    single = pair_scene("fd", None, (-SPEED, 0.0), far_field, changes)
    a, mu = single.sphere.radius, single.liquid.viscosity
    stokes = 6.0 * math.pi * mu * a * SPEED
    start = time.perf_counter()
    force, n_cells = fd_steady_forces(comm, single)
    lambda_single = force / stokes  # the sphere moves down: the drag pushes up
    rows = [make_row("fd", cells, far_field, domain, "single", None, lambda_single, lambda_single, 1.0, n_cells,
                     time.perf_counter() - start)]
    configurations = [("together", distance - 1.0, (-SPEED, -SPEED)) for distance in FD_CENTRE_DISTANCES]
    configurations += [("approach", gap, (SPEED, 0.0)) for gap in FD_APPROACH_GAPS]
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
        rows.append(make_row("fd", cells, far_field, domain, case, gap, raw, lambda_single, reference, n_cells,
                             time.perf_counter() - start))
    return rows


# --- ale: the boundary-fitted flow around a held pair ---------------------------------------------------

ALE_DIAMETER, ALE_VISCOSITY = 0.01, 1.0  # [m, Pa s]: Re = 1e-5, Stokes flow
ALE_CENTRE_DISTANCES = (1.1, 2.5, 3.0, 4.0)  # together, in diameters
ALE_APPROACH_GAPS = (1.0, 0.5, 0.2, 0.1, 0.05, 0.02, 0.01)  # approach, surface gap in diameters
ALE_GAP_CELLS = 2.0  # triangles across a thin gap (numerics.ale.min_gap_cells)
ALE_GRADING = 0.2


def ale_box(cells: float, gaps: list[float], far_field: float):
    """The slip cylinder (radius far_field D, height 2 far_field D) with spheres of diameter D on the axis,
    the first centred at mid-height, `gaps` [m] between consecutive surfaces (none: one sphere alone)."""
    from fem_bounce.fem.mesh import Box, HalfPlane, SphereHole

    d = ALE_DIAMETER
    fine, radius = d / cells, d / 2
    holes = [SphereHole(center=far_field * d, radius=radius, surface_size=fine, gap_cells=ALE_GAP_CELLS)]
    for gap in gaps:
        holes.append(SphereHole(center=holes[-1].top + gap + radius, radius=radius, surface_size=fine,
                                gap_cells=ALE_GAP_CELLS))
    refined = Box(r_max=d, z_min=holes[0].gap - d / 2, z_max=holes[-1].top + d / 2)
    return HalfPlane(radius=far_field * d, height=2 * far_field * d, fine_size=fine, coarse_size=far_field * d / 4,
                     grading=ALE_GRADING, refined=(refined,), holes=tuple(holes))


def ale_steady_drag(comm, cells: float, gaps: list[float], velocities: list[float], far_field: float) -> tuple:
    """(lambda per sphere, cells, seconds) of the steady Stokes flow with the surfaces at `velocities`
    [m/s]; lambda_i = F_i / (6 pi mu a |U|) with U the largest speed, sign: the drag opposes U."""
    import numpy as np
    import ufl

    from fem_bounce.fem.mesh import OUTER, SPHERE, SPHERE_2, TOP, WALL, create_mesh
    from fem_bounce.models.ale.flow import SphereFlow

    start = time.perf_counter()
    mesh, _, facet_tags = create_mesh(comm, ale_box(cells, gaps, far_field), cache=False)
    slip = {WALL: "slip", OUTER: "slip", TOP: "slip"}
    flow = SphereFlow(mesh, facet_tags, slip, 1000.0, ALE_VISCOSITY, 1.0, ufl.as_vector((0.0, 0.0)),
                      sphere_tags=(SPHERE, SPHERE_2)[: len(gaps) + 1])
    try:
        forces = np.atleast_1d(flow.steady(velocities, convection=False))
    finally:
        flow.destroy()
    speed = max(abs(v) for v in velocities)
    direction = math.copysign(1.0, [v for v in velocities if abs(v) == speed][0])
    stokes = 6.0 * math.pi * ALE_VISCOSITY * ALE_DIAMETER / 2 * speed
    lam = [float(x) for x in -direction * forces / stokes]
    return lam, mesh.topology.index_map(2).size_global, time.perf_counter() - start


def ale_rows(comm, cells: float, far_field: float | None = None) -> list[dict]:
    """The ale model at `cells` per diameter: the isolated sphere, then the pair moving together, then
    approaching (a row for the moving sphere and one for the held sphere)."""
    far_field = 2000.0 if far_field is None else far_field
    domain = f"slip cylinder R {far_field:g} D"
    a = ALE_DIAMETER / 2
    lam, n_cells, seconds = ale_steady_drag(comm, cells, [], [-SPEED], far_field)
    single = lam[0]
    rows = [make_row("ale", cells, far_field, domain, "single", None, single, single, 1.0, n_cells, seconds)]
    for distance in ALE_CENTRE_DISTANCES:
        gap = distance - 1.0
        lam, n_cells, seconds = ale_steady_drag(comm, cells, [gap * ALE_DIAMETER], [-SPEED, -SPEED], far_field)
        rows.append(make_row("ale", cells, far_field, domain, "together", gap, lam, single,
                             pair_theory.stimson_jeffery(a, gap * ALE_DIAMETER), n_cells, seconds))
    for gap in ALE_APPROACH_GAPS:
        h = gap * ALE_DIAMETER
        lam, n_cells, seconds = ale_steady_drag(comm, cells, [h], [0.0, -SPEED], far_field)
        # the upper sphere (2) moves toward the lower one (1), held: lambda_2 is Cooley & O'Neill's
        # approach factor (X22 = X11 for equal spheres); the held sphere is pushed along with
        # F_1 = -6 pi mu a X12 U2, so lambda_1 = X12 < 0 in this sign convention (one solve, two rows)
        rows.append(make_row("ale", cells, far_field, domain, "approach", gap, [lam[1]], single,
                             pair_theory.approach_fixed(a, a, h), n_cells, seconds))
        rows.append(make_row("ale", cells, far_field, domain, "approach-held", gap, [lam[0]], single,
                             float(pair_theory.resistance(a, a, h)[0, 1]), n_cells, seconds))
    if comm.rank == 0:
        print(f"ale, {cells:g} cells/D done", flush=True)
    return rows


MODELS = {"fd": fd_rows, "ale": ale_rows}
DEFAULT_CELLS = {"fd": [16.0], "ale": [8.0, 16.0, 32.0]}


# --- shared: table, history -----------------------------------------------------------------------------

def table(rows: list[dict]) -> str:
    header = ["model", "domain", "cells/D", "case", "gap/D", "lambda_raw", "error_raw", "lambda", "theory", "error",
              "cells", "s"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for row in rows:
        raw = row["lambda_raw"]
        raw_text = " / ".join(f"{x:.4f}" for x in raw) if isinstance(raw, list) else f"{raw:.4f}"
        gap = f"{row['gap_D']:g}" if row["gap_D"] is not None else "inf"
        lines.append(f"| {row['model']} | {row['domain']} | {row['cells_per_diameter']:g} | {row['case']} | {gap} | "
                     f"{raw_text} | {row['error_raw']:+.2%} | {row['lambda']:.4f} | {row['reference']:.4f} | "
                     f"{row['error']:+.2%} | {row['cells']} | {row['wall_time_s']:.1f} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("models", nargs="*", metavar="model", help="fd, ale (default: both)")
    parser.add_argument("--cells", type=float, nargs="+", default=None,
                        help="cells per diameter (default: fd 16; ale 8 16 32)")
    parser.add_argument("--far-field", type=float, default=None,
                        help="the slip boundary this many D away (default: fd 50, ale 2000)")
    args = parser.parse_args()
    comm = MPI.COMM_WORLD
    unknown = sorted(set(args.models) - set(MODELS))
    if unknown:
        parser.error(f"unknown model(s) {', '.join(unknown)}: choose from {', '.join(MODELS)}")
    models = list(dict.fromkeys(args.models or MODELS))  # in the order given, once each
    runs = [(model, cells) for model in models for cells in (args.cells or DEFAULT_CELLS[model])]
    records = {}
    for model, cells in runs:
        rows = MODELS[model](comm, cells, args.far_field)
        far_field, domain = rows[0]["far_field_D"], rows[0]["domain"]
        records[f"{model}-{cells:g}cpd-far{far_field:g}"] = {
            **stamp(), "ranks": comm.size,
            "command": "python " + " ".join(["benchmarks/pair_stokes.py", *sys.argv[1:]]), "model": model,
            "cells_per_diameter": cells, "far_field_D": far_field, "domain": domain, "rows": rows}
    if comm.rank != 0:
        return
    print(table([row for record in records.values() for row in record["rows"]]))
    history = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    history.update(records)
    RESULTS.write_text(json.dumps(history, indent=1, default=float) + "\n")


if __name__ == "__main__":
    main()
