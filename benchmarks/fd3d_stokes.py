"""The 3-D fictitious-domain flow (fem_bounce.models.fd3d) against exact Stokes resistances and a sphere's drag at
Re 100, and its step's solver.

    python benchmarks/fd3d_stokes.py wall --cells 24 --gaps 0.1,0.5,2 --tag _c24   # 62 s, 2.5 GB peak
    python benchmarks/fd3d_stokes.py wall --cells 12 --tag _c12                     # 24 s, 1.5 GB
    python benchmarks/fd3d_stokes.py solver --cells 16 --steps 10 --tag _c16        # 124 s, 1.6 GB
    python benchmarks/fd3d_stokes.py drag --cells 12 --steps 14 --picard-dt 10 --tag _c12   # 85 s, 1.4 GB

(one process on a 2-core machine shared with other jobs, so the times are rough: /usr/bin/time -f "%e s %M kB".)

`wall`: a sphere of radius a held at the gap delta above a no-slip wall in a half box (the plane y = 0 of
symmetry through its centre; x, y within 30 a, height 30 a, no-slip far sides), steady penalised Stokes, the
resistance matrix over the in-plane rigid modes (U_x, U_z, Omega_y) from one factorisation and four back-solves.
Compared, with eps = delta / a, against
  - f_xx = -F_x / (6 pi mu a U_x), c_yy = -T_y / (8 pi mu a^3 Omega_y) and the coupling c_yx = T_y / (8 pi mu a^2 U_x)
    = F_x / (8 pi mu a^2 Omega_y) (Omega_y > 0 in the rolling sense): the exact solution (O'Neill 1964; Goldman, Cox
    & Brenner 1967) as Chaoui & Feuillebois (2003) fitted it (fem_bounce.wall_tangential, their tables 9-13);
  - f_zz = -F_z / (6 pi mu a U_z), motion normal to the wall: Brenner's (1961) exact series
    (fem_bounce/data/brenner1961_wall_drag.csv).
The indicator's outer edge is on the sphere's surface, its band two surface cells wide, the penalty rate
c_B = strength nu / h_min^2 with h_min the smallest cell (strength 1e4: the interior slips by ~1e-4 to 1e-3).
The coupling c_yx is small (0.089, 0.017, 0.001 at eps 0.1, 0.5, 2): its error is best read against c_yy.

`solver`: one modest mesh (gap 0.5 a, --cells per diameter), a sphere translating along the wall at
Re = U D / nu = 20 seen in its own frame (the liquid and the wall move at -U, the sphere is held still, so the
penalty stays where it is in the matrix and only the convection changes from step to step), impulsively started
(both past levels the uniform stream, so every step is BDF2 and the mass term never changes), dt = 0.5 h / U.
Two solvers side by side on the same mesh: a MUMPS factorisation every step ("direct") and the first step's
factors kept as the preconditioner of FGMRES ("reuse", fem.solver.ReusedFactorOperator, |r| <= 1e-10 |b_free|);
per step the assembly, factorisation and back-solve times, the FGMRES iterations of its four right-hand sides
(x_0 and one per mode) and the relative difference between the two solvers' penalty forces.

`drag`: a sphere held in a uniform stream along -z (in through the top 5 D upstream, out through z = 0 6 D
downstream, slip sides 5 D from the axis; the wake under the sphere at two surface cells), the steady state by
damped Picard steps (BDF1 at dt = --picard-dt D / U, convection about the last iterate) until Cd changes by less
than 1e-4 of itself; Cd = F / (rho U^2 pi a^2 / 2) from the penalty's reaction, against Johnson & Patel's (1999)
1.087 (fem_bounce/data/sphere_drag_reference.csv).

Results are printed and written to benchmarks/history/fd3d_stokes_{case}{tag}.json.  One process; the meshes are
cached (a second run skips gmsh).  The measurements themselves, with their commands, are in those files.
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

import fem_bounce  # noqa: F401  first: MPI ahead of PETSc and dolfinx
from dolfinx import fem
from mpi4py import MPI

from fem_bounce import reference
from fem_bounce.fem.compat import collapse
from fem_bounce.fem.geometry import Cartesian
from fem_bounce.models.fd3d.flow import PenalisedFlow3D
from fem_bounce.models.fd3d.indicator import SphereIndicator
from fem_bounce.models.fd3d.mesh import SIDE_X, SIDE_Y, TOP, WALL, BoxSpec, create_box_mesh
from fem_bounce.wall_tangential import tangential_coefficients

HISTORY = Path(__file__).resolve().parent / "history"
RADIUS = 1.0  # [m]: the benchmark is dimensionless, a = mu = 1
SIDES = (WALL, TOP, SIDE_X, SIDE_Y)


def box_spec(gap: float, cells_per_diameter: float, gap_cells: float = 2.0, half_width: float = 30.0,
             grading: float = 0.4, local_gap_cells: float = 0.0) -> BoxSpec:
    """The half box around a sphere at `gap` [a] above the wall: surface cells of D / cells_per_diameter, in the gap
    at most gap / gap_cells (that many cells across) within 0.3 a of the axis below the centre, and (local_gap_cells
    > 0) at most the local gap over local_gap_cells everywhere under the sphere."""
    h = 2.0 * RADIUS / cells_per_diameter
    gap_size = min(h, gap * RADIUS / gap_cells)
    return BoxSpec(half_width=half_width * RADIUS, height=half_width * RADIUS, center=(0.0, 0.0, RADIUS + gap * RADIUS),
                   radius=RADIUS, surface_size=h, coarse_size=0.2 * half_width * RADIUS, grading=grading,
                   gap_size=gap_size, gap_radius=0.3 * RADIUS, gap_cells=local_gap_cells, mirrored=True)


def brenner_normal_drag(gap: float) -> float:
    """Brenner's (1961) exact f_zz at gap [a] (the packaged table's rows: delta = gap / D)."""
    rows = {round(row["delta"], 6): row["lambda_brenner"] for row in reference.table("brenner1961_wall_drag")}
    return rows[round(0.5 * gap, 6)]


def make_flow(comm, spec: BoxSpec, viscosity: float, strength: float, sides: dict, inflow=(0.0, 0.0, 0.0),
              prefix: str = "fd3d_", step_solver: str = "direct"):
    start = time.perf_counter()
    domain, _, facets = create_box_mesh(comm, spec)
    meshed = time.perf_counter()
    h = spec.surface_size
    sphere = SphereIndicator(domain, RADIUS, 2.0 * h, spec.center)
    smallest = min(h, spec.gap_size or h)
    flow = PenalisedFlow3D(Cartesian(domain, mirrored=spec.mirrored), facets, sides, 1.0, viscosity, sphere,
                           strength * viscosity / smallest**2, inflow=inflow, prefix=prefix, step_solver=step_solver)
    counts = {"vertices": domain.topology.index_map(0).size_global, "cells": domain.topology.index_map(3).size_global,
              "unknowns": flow.unknowns, "mesh_s": meshed - start, "setup_s": time.perf_counter() - meshed}
    return flow, counts


def wall(args) -> list[dict]:
    comm = MPI.COMM_WORLD
    rows = []
    for gap in args.gaps:
        spec = box_spec(gap, args.cells, args.gap_cells, local_gap_cells=args.local_gap_cells)
        flow, counts = make_flow(comm, spec, 1.0, args.strength, {side: "no-slip" for side in SIDES})
        start = time.perf_counter()
        response = flow.steady()
        elapsed = time.perf_counter() - start
        R = response.resistance
        ux, uz, oy = (response.index(name) for name in ("U_x", "U_z", "Omega_y"))
        measured = {"f_xx": -R[ux, ux] / (6 * math.pi), "c_yy": -R[oy, oy] / (8 * math.pi),
                    "c_yx_torque": R[oy, ux] / (8 * math.pi), "c_yx_force": R[ux, oy] / (8 * math.pi),
                    "f_zz": -R[uz, uz] / (6 * math.pi)}
        f_xx, c_yx, c_yy = tangential_coefficients(gap)
        exact = {"f_xx": f_xx, "c_yy": c_yy, "c_yx_torque": c_yx, "c_yx_force": c_yx, "f_zz": brenner_normal_drag(gap)}
        slip = 0.0
        for k in range(len(response.names)):
            amplitudes = np.eye(len(response.names))[k]
            state = fem.Function(flow.W)
            flow.field(amplitudes, state.x.petsc_vec)
            state.x.scatter_forward()
            slip = max(slip, flow.interior_slip(state, amplitudes, RADIUS - flow.sphere.width))
        row = {"gap_over_a": gap, "cells_per_diameter": args.cells, "gap_cells": args.gap_cells,
               "local_gap_cells": args.local_gap_cells,
               "strength": args.strength, **counts,
               "solve_s": elapsed, **flow.steady_costs, "interior_slip": slip,
               "measured": measured, "exact": exact,
               "relative_error": {key: measured[key] / exact[key] - 1.0 for key in measured}}
        rows.append(row)
        if comm.rank == 0:
            print(f"gap/a {gap}: {counts['unknowns']} unknowns ({counts['vertices']} vertices, "
                  f"{counts['cells']} cells), "
                  f"mesh {counts['mesh_s']:.1f} s, factorisation {row['factorise_s']:.1f} s, 4 back-solves "
                  f"{row['solve_s']:.2f} s, MUMPS {(row['factor_memory_bytes'] or 0) / 1e9:.2f} GB, slip {slip:.1e}")
            for key in measured:
                print(f"    {key:12s} {measured[key]:9.4f}  exact {exact[key]:9.4f}  "
                      f"{100 * row['relative_error'][key]:+7.2f} %")
        flow.destroy()
    return rows


def uniform_state(flow, velocity) -> fem.Function:
    state = fem.Function(flow.W)
    for k in range(3):
        _, dofs = collapse(flow.W.sub(0).sub(k))
        state.x.array[dofs] = velocity[k]
    return state


def solver(args) -> list[dict]:
    """The step's solver: factorise every step against the first step's factors kept (module docstring)."""
    comm = MPI.COMM_WORLD
    spec = box_spec(args.solver_gap, args.cells)
    speed, reynolds = 1.0, args.reynolds
    viscosity = speed * 2.0 * RADIUS / reynolds
    stream = (-speed, 0.0, 0.0)
    sides = {side: "inflow" for side in SIDES}  # the wall slides at -U, the far field streams at -U
    flows = {}
    for name in ("direct", "reuse"):
        flows[name], counts = make_flow(comm, spec, viscosity, args.strength, sides, inflow=stream,
                                        prefix=f"fd3d_{name}_", step_solver=name)
    dt = 0.5 * spec.surface_size / speed
    rows = []
    start_state = uniform_state(flows["direct"], stream)
    for flow in flows.values():
        flow.set_state(start_state.x.petsc_vec)
    held = np.zeros(3)
    for step in range(args.steps):
        row = {"step": step + 1}
        responses = {}
        for name, flow in flows.items():
            flow.set_time_step(dt)  # BDF2 from the start (both past levels the uniform stream): one matrix form
            before = (flow.assembly_s, flow.factorise_s, flow.solve_s)
            iterations = getattr(flow.step_operator, "iterations", 0) if flow.step_operator else 0
            responses[name] = flow.step()
            after = (flow.assembly_s, flow.factorise_s, flow.solve_s)
            row[name] = {"assembly_s": after[0] - before[0], "factorise_s": after[1] - before[1],
                         "solve_s": after[2] - before[2]}
            if name == "reuse":
                row[name]["iterations"] = flow.step_operator.iterations - iterations
                row[name]["factorisations"] = flow.step_operator.factorisations
            flow.commit(held)
        force = {name: response.penalty_force(held) for name, response in responses.items()}
        row["force"] = force["direct"].tolist()
        row["force_difference"] = float(np.abs(force["reuse"] - force["direct"]).max() / np.abs(force["direct"]).max())
        rows.append(row)
        if comm.rank == 0:
            d, r = row["direct"], row["reuse"]
            print(f"step {step + 1}: direct assembly {d['assembly_s']:.2f} s factorisation {d['factorise_s']:.2f} s "
                  f"4 back-solves {d['solve_s']:.2f} s | reuse {r['iterations']} FGMRES iterations over 4 solves "
                  f"{r['solve_s']:.2f} s ({r['factorisations']} factorisations) | force F_x {row['force'][0]:.4f}, "
                  f"solvers differ by {row['force_difference']:.1e}")
    summary = {"unknowns": counts["unknowns"], "vertices": counts["vertices"], "cells": counts["cells"],
               "reynolds": reynolds, "dt": dt, "gap_over_a": args.solver_gap, "cells_per_diameter": args.cells,
               "factor_memory_bytes": flows["direct"].step_operator.factor_memory(), "steps": rows}
    if comm.rank == 0:
        print(f"{counts['unknowns']} unknowns ({counts['vertices']} vertices, {counts['cells']} cells), MUMPS "
              f"{(summary['factor_memory_bytes'] or 0) / 1e9:.2f} GB per factorisation, dt {dt:.4g}")
    for flow in flows.values():
        flow.destroy()
    return [summary]


def drag(args) -> list[dict]:
    """A fixed sphere in a uniform stream at Re = U D / nu: the steady state by damped Picard steps (BDF1 at a large
    dt, convection about the last iterate: the step's fixed point is the steady penalised Navier-Stokes flow)."""
    comm = MPI.COMM_WORLD
    rows = []
    h = 2.0 * RADIUS / args.cells
    downstream, upstream, half_width = 2.0 * args.downstream, 2.0 * args.upstream, 2.0 * args.half_width
    # the stream runs down -z: in at the top, out through z = 0; the "gap" cylinder under the sphere is its wake
    spec = BoxSpec(half_width=half_width, height=downstream + upstream, center=(0.0, 0.0, downstream), radius=RADIUS,
                   surface_size=h, coarse_size=0.2 * half_width, grading=args.grading, gap_size=args.wake_size * h,
                   gap_radius=RADIUS, mirrored=True)
    for reynolds in args.reynolds_list:
        speed = 1.0
        viscosity = speed * 2.0 * RADIUS / reynolds
        sides = {TOP: "inflow", WALL: "outflow", SIDE_X: "slip", SIDE_Y: "slip"}
        flow, counts = make_flow(comm, spec, viscosity, args.strength, sides, inflow=(0.0, 0.0, -speed),
                                 prefix="fd3d_drag_")
        stream = uniform_state(flow, (0.0, 0.0, -speed))  # kept alive: its PETSc vector wraps its array
        flow.set_state(stream.x.petsc_vec)
        flow.set_time_step(args.picard_dt * 2.0 * RADIUS / speed, order=1)
        uz = flow.geometry.mode_names.index("U_z")
        history = []
        start = time.perf_counter()
        for _ in range(args.steps):
            response = flow.step(responses=False)
            flow.commit(np.zeros(3))
            # Cd = F / (rho U^2 pi a^2 / 2), the penalty's reaction of the held sphere (the stream pushes it down)
            history.append(-response.penalty_force(np.zeros(3))[uz] / (0.5 * speed**2 * math.pi * RADIUS**2))
            if len(history) > 2 and abs(history[-1] - history[-2]) < 1e-4 * abs(history[-1]):
                break
        elapsed = time.perf_counter() - start
        standard = {row["Re"]: row["Cd_reference"] for row in reference.table("sphere_drag_reference")}
        row = {"reynolds": reynolds, "cells_per_diameter": args.cells, **counts, "picard_steps": len(history),
               "elapsed_s": elapsed, "factorise_s": flow.factorise_s, "assembly_s": flow.assembly_s,
               "drag_history": history, "drag": history[-1], "reference": standard.get(reynolds)}
        rows.append(row)
        if comm.rank == 0:
            error = f"{100 * (row['drag'] / row['reference'] - 1):+.2f} %" if row["reference"] else "no reference"
            print(f"Re {reynolds:g}: {counts['unknowns']} unknowns ({counts['vertices']} vertices), "
                  f"{len(history)} Picard steps in {elapsed:.0f} s (factorisations {flow.factorise_s:.0f} s): "
                  f"Cd {row['drag']:.4f} against {row['reference']} ({error}); last changes {np.diff(history[-3:])}")
        flow.destroy()
    return rows


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=("wall", "solver", "drag"))
    parser.add_argument("--cells", type=float, default=12.0, help="cells per diameter at the sphere's surface")
    parser.add_argument("--gaps", type=lambda text: [float(g) for g in text.split(",")], default=[0.1, 0.5, 2.0],
                        help="gaps over the radius (wall)")
    parser.add_argument("--gap-cells", type=float, default=2.0, help="cells across the gap (at most)")
    parser.add_argument("--local-gap-cells", type=float, default=0.0, help="cells across the local gap (0: none)")
    parser.add_argument("--strength", type=float, default=1e4, help="penalty rate in nu / h_min^2")
    parser.add_argument("--solver-gap", type=float, default=0.5, help="gap over the radius (solver)")
    parser.add_argument("--reynolds", type=float, default=20.0, help="U D / nu (solver)")
    parser.add_argument("--tag", default="", help="appended to the JSON file's name")
    parser.add_argument("--steps", type=int, default=8, help="time steps (solver), at most Picard steps (drag)")
    parser.add_argument("--reynolds-list", type=lambda text: [float(g) for g in text.split(",")], default=[100.0],
                        help="U D / nu (drag)")
    parser.add_argument("--downstream", type=float, default=6.0, help="diameters behind the sphere (drag)")
    parser.add_argument("--upstream", type=float, default=5.0, help="diameters before the sphere (drag)")
    parser.add_argument("--half-width", type=float, default=5.0, help="diameters to the slip sides (drag)")
    parser.add_argument("--wake-size", type=float, default=2.0, help="cells in the wake, in surface cells (drag)")
    parser.add_argument("--grading", type=float, default=0.3, help="size growth per distance (drag)")
    parser.add_argument("--picard-dt", type=float, default=2.0, help="the Picard steps' dt in D / U (drag)")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    rows = {"wall": wall, "solver": solver, "drag": drag}[args.case](args)
    if MPI.COMM_WORLD.rank == 0:
        HISTORY.mkdir(exist_ok=True)
        record = {"command": f"python benchmarks/fd3d_stokes.py {' '.join(argv or __import__('sys').argv[1:])}",
                  "elapsed_s": time.perf_counter() - start, "rows": rows}
        path = HISTORY / f"fd3d_stokes_{args.case}{args.tag}.json"
        path.write_text(json.dumps(record, indent=1, default=float) + "\n")
        print(f"{record['elapsed_s']:.0f} s; written {path}")


if __name__ == "__main__":
    main()
