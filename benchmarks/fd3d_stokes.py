"""The 3-D fictitious-domain flow (fem_bounce.models.fd3d) against exact Stokes resistances, a sphere's drag at
Re 100 and 200 and its wake's loss of axisymmetry, its step's solver, and the lift of a sphere sliding along a wall.

    python benchmarks/fd3d_stokes.py wall --cells 24 --gaps 0.1,0.5,2 --tag _c24   # 62 s, 2.5 GB peak
    python benchmarks/fd3d_stokes.py wall --cells 12 --tag _c12                     # 24 s, 1.5 GB
    python benchmarks/fd3d_stokes.py solver --cells 16 --steps 10 --tag _c16        # 124 s, 1.6 GB
    python benchmarks/fd3d_stokes.py drag --cells 12 --steps 14 --picard-dt 10 --tag _c12   # 85 s, 1.4 GB
    python benchmarks/fd3d_stokes.py drag --cells 12 --steps 14 --picard-dt 10 --re 100,200 --tag _c12_re200  # 87 s
    python benchmarks/fd3d_stokes.py drag --cells 20 --steps 14 --picard-dt 10 --re 200 --tag _c20_re200  # 238 s
    python benchmarks/fd3d_stokes.py drag --cells 12 --steps 14 --picard-dt 10 --re 200,230 --symmetric-base \
        --wake-time 40 --wake-dt 0.5 --tag _c12_wake_sym                                  # 526 s, 1.5 GB
    python benchmarks/fd3d_stokes.py growth --record benchmarks/history/fd3d_stokes_drag_c12_wake_sym.json \
        --window 5,20                                                                     # reads the record, 2 s
    python benchmarks/fd3d_stokes.py lift --cells 12 --gaps 0.1,0.2,0.4,0.6,1,2,4 --re 10,25,50,100,150 --steps 30 \
        --picard-dt 10 --half-width 15 --tag _c12 --csv fem_bounce/data/wall_lift_fd3d.csv    # 740 s, 1.6 GB
    mpiexec -n 2 python benchmarks/fd3d_stokes.py lift --cells 24 --gaps 0.1,0.2,0.4,0.6,1,2,4 --re 10,25,50,100,150 \
        --steps 30 --picard-dt 10 --half-width 15 --tag _c24 --csv fem_bounce/data/wall_torque_fd3d.csv  # 1,188 s
    mpiexec -n 2 python benchmarks/fd3d_stokes.py lift --cells 32 --gaps 0.2,0.4 --re 10,50,100 --steps 30 \
        --picard-dt 10 --half-width 15 --tag _c32_check                                   # the torque's mesh check

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
than 1e-4 of itself; Cd = F / (rho U^2 pi a^2 / 2) from the penalty's reaction, against the standard values of
fem_bounce/data/sphere_drag_reference.csv (Re 100: Johnson & Patel's (1999) 1.087; Re 200: 0.77, Fornberg 1988),
at each Reynolds number of --re; beside it the lift C_L = F_x / (rho U^2 pi a^2 / 2) (the plane y = 0 is a
symmetry plane, so a wake off its axis can only put its lift along x; the mesh is not quite symmetric in x, which
seeds it).  With --wake-time T the wake's stability (the steady axisymmetric wake of a sphere turns non-axisymmetric
at Re ~ 210-212: Natarajan & Acrivos 1993, Johnson & Patel 1999): the Picard state kicked off axisymmetry (u_x +=
--kick U exp(-r^2 / a^2) about a point one diameter behind the centre) and time-stepped (BDF2, dt = --wake-dt D / U,
for T D / U; the factors kept as FGMRES's preconditioner), the C_L history and the growth rate sigma of dC_L / dt
(the mesh's own asymmetry holds a constant C_L, which the derivative removes) over --window.  With
--symmetric-base every Picard iterate is projected on the axisymmetric class, (u + R u(R x)) / 2 with R the mirror
x -> -x (a mirrored copy of the mesh, non-matching interpolation): above the threshold the plain Picard iteration
itself leaves the axisymmetric state, and the kick must start from it.  `growth` re-reads such a record (--record)
and fits over another --window, printing only.

`lift`: a sphere translating at U parallel to the wall at each Re of --re, held at each gap of --gaps [a] in the box
of `wall` (--half-width in D), seen in its own frame as in `solver` (the wall and the far field at -U, the box's
sides all given that velocity), the steady state by `drag`'s damped Picard steps (to 2e-4 of Cd): Cd = -F_x, the
lift C_L = F_z away from the wall and C_T = T_y / a over rho U^2 pi a^2 / 2, with the Stokes drag near the wall
(O'Neill 1964) beside Cd.  --csv writes the rows as fem_bounce.wall_lift's table.  At gap/a 0.4 C_L is 0.238 /
0.220 / 0.216 (Re 50) and 0.154 / 0.133 / 0.135 (Re 100) at 8 / 12 / 16 cells/D (`lift --cells N --gaps 0.4 --re
50,100 --steps 30 --picard-dt 10 --half-width 15 --tag _cN_gap04`), and at 12 cells/D 0.140 with the sides 25 D
away instead of 15 (Re 100, `--half-width 25 --tag _c12_gap04_box25`): a few per cent in the mesh, 5 % in the box.
C_T, a small difference of the shear on the two sides, needs finer cells: at 12 cells/D it is far off (its sign
changes with the mesh), at 24 it is within about 0.001-0.003 of 32 cells/D at Re 50-100 and 0.007 at Re 10, and in
Stokes flow (Re 0.1, gap/a 0.4) 6.61 against the film's exact 7.24 (docs/validation.md section 14).

Results are printed and written to benchmarks/history/fd3d_stokes_{case}{tag}.json.  One process; the meshes are
cached (a second run skips gmsh).  The measurements themselves, with their commands, are in those files.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import fem_bounce  # noqa: F401  first: MPI ahead of PETSc and dolfinx
from dolfinx import fem
from mpi4py import MPI

from fem_bounce import reference
from fem_bounce.fem.compat import collapse
from fem_bounce.fem.geometry import Cartesian
from fem_bounce.models.fd3d.flow import PenalisedFlow3D, taylor_hood_space
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
              prefix: str = "fd3d_", step_solver: str = "direct", mesh=None):
    """The flow on a new mesh of `spec`, or (`mesh`: (domain, facet tags)) on that one."""
    start = time.perf_counter()
    domain, facets = mesh if mesh is not None else create_box_mesh(comm, spec)[::2]
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


def coefficients(response, speed: float) -> tuple[float, float]:
    """(Cd, C_L) = (-F_z, F_x) / (rho U^2 pi a^2 / 2) of the held sphere in the stream along -z (the stream pushes
    it down; the half box's lift can only lie along x): the penalty's reaction, the whole sphere's."""
    force = response.penalty_force(np.zeros(3))
    names = response.names
    scale = 0.5 * speed**2 * math.pi * RADIUS**2
    return -force[names.index("U_z")] / scale, force[names.index("U_x")] / scale


def kick(flow, state: fem.Function, amplitude: float, center) -> None:
    """Add the non-axisymmetric seed u_x += amplitude exp(-|x - X_w|^2 / a^2), X_w one diameter behind the sphere's
    centre (in its recirculation), to the velocity of `state` (even in x and y: the x-odd class of a wake whose
    lift lies along x)."""
    space, dofs = collapse(flow.W.sub(0).sub(0))
    x = space.tabulate_dof_coordinates()
    seed = np.asarray(center, dtype=float) - np.array([0.0, 0.0, 2.0 * RADIUS])
    state.x.array[dofs] += amplitude * np.exp(-np.sum((x - seed) ** 2, axis=1) / RADIUS**2)
    state.x.scatter_forward()


class Reflection:
    """The mirror image u -> R u(R x) of a (u, p) state of the drag's mesh, R: x -> -x (the box is symmetric about
    x = 0, its mesh is not quite): a second copy of the mesh from the cache, its vertices reflected, carrying the
    state's values (u_x negated), interpolated back at the mesh's dofs (dolfinx's non-matching interpolation).
    `symmetrise` projects a state on the wake's axisymmetric class, (u + R u(R x)) / 2."""

    def __init__(self, W: fem.FunctionSpace, spec: BoxSpec):
        domain, _, _ = create_box_mesh(W.mesh.comm, spec)
        if not np.array_equal(domain.geometry.x, W.mesh.geometry.x):
            raise RuntimeError("the mesh's second copy is ordered differently")
        domain.geometry.x[:, 0] *= -1.0
        mirrored = taylor_hood_space(domain)
        cells = np.arange(W.mesh.topology.index_map(3).size_local, dtype=np.int32)
        self.parts = []
        for k in range(2):
            space_to, dofs = collapse(W.sub(k))
            space_from, dofs_from = collapse(mirrored.sub(k))
            if not np.array_equal(dofs, dofs_from):
                raise RuntimeError("the mirrored mesh's dofs are laid out differently")
            data = fem.create_interpolation_data(space_to, space_from, cells, padding=1e-8)
            self.parts.append((fem.Function(space_from), fem.Function(space_to), dofs, data, cells))

    def symmetrise(self, state: fem.Function) -> tuple[float, float]:
        """state <- (state + its mirror image) / 2; returns the velocity's part removed, |u - R u(R x)| / 2, at its
        largest and as the root mean square over the velocity dofs (both over U when U = 1)."""
        values = state.x.array.copy()
        removed = (0.0, 0.0)
        for k, (source, target, dofs, data, cells) in enumerate(self.parts):
            source.x.array[:] = values[dofs]
            if k == 0:
                source.x.array.reshape(-1, 3)[:, 0] *= -1.0
            target.interpolate_nonmatching(source, cells, data)
            half = 0.5 * (target.x.array - values[dofs])
            state.x.array[dofs] += half
            if k == 0:
                removed = (float(np.abs(half).max()), float(np.sqrt(np.mean(half**2))))
        state.x.scatter_forward()
        return removed


def growth_rate(times, lift, window=None) -> dict:
    """The asymmetric part's growth rate sigma [U / D] from C_L(t) = C_inf + B exp(sigma t) (C_inf, the lift the
    mesh's own asymmetry holds, not known): the least-squares slope of log |dC_L / dt| over the `window` (t_0, t_1)
    [D / U] (None: the last half of the steps), the same over its first and second halves (equal: one mode
    dominates), and C_inf for that sigma (linear least squares over the window)."""
    t, c = np.asarray(times), np.asarray(lift)
    rate, mid = np.diff(c) / np.diff(t), 0.5 * (t[1:] + t[:-1])
    if window is None:
        inside = np.arange(rate.size) >= rate.size // 2
    else:
        inside = (mid >= window[0]) & (mid <= window[1])
    picked = np.flatnonzero(inside)
    result = {"window_start": float(mid[picked[0]]), "window_end": float(mid[picked[-1]]),
              "sign_changes_in_window": int(np.sum(np.diff(np.sign(rate[picked])) != 0))}

    def slope(part):
        return float(np.polyfit(mid[part], np.log(np.abs(rate[part])), 1)[0])

    half = picked.size // 2
    sigma = slope(picked)
    levels = (t >= mid[picked[0]] - 1e-12) & (t <= mid[picked[-1]] + 1e-12)
    basis = np.c_[np.ones(levels.sum()), np.exp(sigma * (t[levels] - t[levels][0]))]
    c_inf = float(np.linalg.lstsq(basis, c[levels], rcond=None)[0][0])
    result |= {"sigma": sigma, "sigma_first_half": slope(picked[:half]), "sigma_second_half": slope(picked[half:]),
               "c_inf": c_inf}
    return result


def growth(args) -> None:
    """The growth rates of recorded wakes (--record, a drag JSON record with --wake-time) over --window."""
    record = json.loads(Path(args.record).read_text())
    for row in record["rows"]:
        if "wake" not in row:
            continue
        w = row["wake"]
        g = growth_rate(w["times"], w["lift_history"], args.window)
        print(f"Re {row['reynolds']:g}: t {g['window_start']:.2f}-{g['window_end']:.2f} D/U: sigma {g['sigma']:+.4f} "
              f"U/D (halves {g['sigma_first_half']:+.4f}, {g['sigma_second_half']:+.4f}; sign changes of dC_L/dt "
              f"{g['sign_changes_in_window']}), C_inf {g['c_inf']:+.4f}; C_L at t {w['times'][0]:g}, "
              f"{w['times'][-1]:g}: {w['lift_history'][0]:+.4f}, {w['lift_history'][-1]:+.4f}")


def drag(args) -> list[dict]:
    """A fixed sphere in a uniform stream at Re = U D / nu: the steady state by damped Picard steps (BDF1 at a large
    dt, convection about the last iterate: the step's fixed point is the steady penalised Navier-Stokes flow);
    with --wake-time, then the wake's stability: that state kicked off axisymmetry (`kick`) and time-stepped."""
    comm = MPI.COMM_WORLD
    rows = []
    h = 2.0 * RADIUS / args.cells
    downstream, upstream, half_width = 2.0 * args.downstream, 2.0 * args.upstream, 2.0 * args.half_width
    # the stream runs down -z: in at the top, out through z = 0; the "gap" cylinder under the sphere is its wake
    spec = BoxSpec(half_width=half_width, height=downstream + upstream, center=(0.0, 0.0, downstream), radius=RADIUS,
                   surface_size=h, coarse_size=0.2 * half_width, grading=args.grading, gap_size=args.wake_size * h,
                   gap_radius=RADIUS, mirrored=True)
    standard = {row["Re"]: (row["Cd_reference"], row["source"]) for row in reference.table("sphere_drag_reference")}
    start = time.perf_counter()
    mesh = create_box_mesh(comm, spec)[::2]  # (domain, facet tags): every Reynolds number's, and the wake's
    mesh_s = time.perf_counter() - start
    for reynolds in args.reynolds_list:
        speed = 1.0
        viscosity = speed * 2.0 * RADIUS / reynolds
        sides = {TOP: "inflow", WALL: "outflow", SIDE_X: "slip", SIDE_Y: "slip"}
        flow, counts = make_flow(comm, spec, viscosity, args.strength, sides, inflow=(0.0, 0.0, -speed),
                                 prefix="fd3d_drag_", mesh=mesh)
        counts["mesh_s"] = mesh_s
        stream = uniform_state(flow, (0.0, 0.0, -speed))  # kept alive: its PETSc vector wraps its array
        flow.set_state(stream.x.petsc_vec)
        flow.set_time_step(args.picard_dt * 2.0 * RADIUS / speed, order=1)
        history, lift, removed = [], [], []
        start = time.perf_counter()
        reflection = Reflection(flow.W, spec) if args.symmetric_base else None
        for _ in range(args.steps):
            response = flow.step(responses=False)
            flow.commit(np.zeros(3))
            if reflection is not None:  # BDF1: the next step sees only u^n
                removed.append(reflection.symmetrise(flow.states[0]))
            drag_coefficient, lift_coefficient = coefficients(response, speed)
            history.append(drag_coefficient)
            lift.append(lift_coefficient)
            if len(history) > 2 and abs(history[-1] - history[-2]) < 1e-4 * abs(history[-1]):
                break
        elapsed = time.perf_counter() - start
        value, source = standard.get(reynolds, (None, None))
        row = {"reynolds": reynolds, "cells_per_diameter": args.cells, "downstream_D": args.downstream,
               "upstream_D": args.upstream, "half_width_D": args.half_width, **counts, "picard_steps": len(history),
               "elapsed_s": elapsed, "factorise_s": flow.factorise_s, "assembly_s": flow.assembly_s,
               "drag_history": history, "drag": history[-1], "lift_history": lift, "lift": lift[-1],
               "reference": value, "reference_source": source, "symmetric_base": args.symmetric_base,
               "asymmetry_removed": removed}
        rows.append(row)
        if comm.rank == 0:
            error = f"{100 * (row['drag'] / value - 1):+.2f} %" if value else "no reference"
            print(f"Re {reynolds:g}: {counts['unknowns']} unknowns ({counts['vertices']} vertices), "
                  f"{len(history)} Picard steps in {elapsed:.0f} s (factorisations {flow.factorise_s:.0f} s): "
                  f"Cd {row['drag']:.4f} against {value} ({source}; {error}), C_L {row['lift']:.2e}; "
                  f"last changes {np.diff(history[-3:])}", flush=True)
        if args.wake_time > 0:
            base = fem.Function(flow.W)
            base.x.array[:] = flow.states[0].x.array
            del reflection
            flow.destroy()
            row["wake"] = wake(args, spec, mesh, viscosity, sides, speed, base)
        else:
            flow.destroy()
    return rows


def lift(args) -> list[dict]:
    """A sphere translating parallel to the wall at Re = U D / nu, held at each gap of --gaps and seen in its own
    frame (the wall and the far field move at -U along x, as in `solver`): the steady state by damped Picard steps
    as in `drag`, then the drag Cd = -F_x, the lift C_L = F_z (away from the wall) over rho U^2 pi a^2 / 2 and the
    torque T_y / (rho U^2 pi a^3 / 2), against the Stokes drag near the wall (O'Neill 1964, 6 pi mu a U f_xx)."""
    comm = MPI.COMM_WORLD
    rows = []
    for gap in args.gaps:
        spec = box_spec(gap, args.cells, args.gap_cells, half_width=2.0 * args.half_width)
        sides = {side: "inflow" for side in SIDES}
        mesh = create_box_mesh(comm, spec)[::2]
        for reynolds in args.reynolds_list:
            speed = 1.0
            viscosity = speed * 2.0 * RADIUS / reynolds
            stream = (-speed, 0.0, 0.0)
            flow, counts = make_flow(comm, spec, viscosity, args.strength, sides, inflow=stream,
                                     prefix="fd3d_lift_", mesh=mesh)
            state = uniform_state(flow, stream)  # kept alive: its PETSc vector wraps its array
            flow.set_state(state.x.petsc_vec)
            flow.set_time_step(args.picard_dt * 2.0 * RADIUS / speed, order=1)
            scale = 0.5 * speed**2 * math.pi * RADIUS**2
            history = []
            start = time.perf_counter()
            for _ in range(args.steps):
                response = flow.step(responses=False)
                flow.commit(np.zeros(3))
                force = response.penalty_force(np.zeros(3))
                names = response.names
                history.append((-force[names.index("U_x")] / scale, force[names.index("U_z")] / scale,
                                force[names.index("Omega_y")] / (scale * RADIUS)))
                if len(history) > 2 and all(abs(history[-1][k] - history[-2][k]) < 2e-4 * abs(history[-1][0])
                                            for k in range(3)):
                    break
            drag_coefficient, lift_coefficient, torque_coefficient = history[-1]
            stokes = 6.0 * math.pi * viscosity * RADIUS * speed * tangential_coefficients(gap)[0] / scale
            row = {"gap_over_a": gap, "reynolds": reynolds, "cells_per_diameter": args.cells,
                   "half_width_D": args.half_width, **counts, "picard_steps": len(history),
                   "elapsed_s": time.perf_counter() - start, "history": history, "drag": drag_coefficient,
                   "lift": lift_coefficient, "torque": torque_coefficient, "stokes_drag": stokes}
            rows.append(row)
            if comm.rank == 0:
                print(f"gap/a {gap:g} Re {reynolds:g}: {counts['unknowns']} unknowns, {len(history)} Picard steps "
                      f"in {row['elapsed_s']:.0f} s: Cd {drag_coefficient:.4f} (Stokes near the wall {stokes:.4f}), "
                      f"C_L {lift_coefficient:+.4f}, C_T {torque_coefficient:+.4f}; last change "
                      f"{np.subtract(history[-1], history[-2]) if len(history) > 1 else None}", flush=True)
            flow.destroy()
    if args.csv and comm.rank == 0:
        write_lift_table(Path(args.csv), rows, f"python benchmarks/fd3d_stokes.py {' '.join(sys.argv[1:])}")
    return rows


def write_lift_table(path: Path, rows: list[dict], command: str) -> None:
    """The lift rows as fem_bounce.wall_lift's table (gap_over_a, Re, C_L and beside them Cd and C_T)."""
    lines = ["# The steady lift C_L = F_L / (rho U^2 pi a^2 / 2) of a sphere translating at U parallel to a plane wall",
             "# through liquid at rest, away from the wall, at the gap delta = gap_over_a a and Re = U D / nu: the 3-D",
             "# fictitious-domain model (fem_bounce.models.fd3d's flow, the sphere held in its own frame, the wall and",
             "# the far field at -U, damped Picard steps to the steady state), written by",
             f"#   {command}",
             "# (benchmarks/fd3d_stokes.py's module docstring; docs/physics.md section 7).  Cd = -F_x and",
             "# C_T = T_y / a over the same scale (T_y about y, positive in the rolling sense of the sphere's motion),",
             "# beside it.",
             "gap_over_a,Re,C_L,Cd,C_T"]
    lines += [f"{row['gap_over_a']:g},{row['reynolds']:g},{row['lift']:.4f},{row['drag']:.4f},{row['torque']:.4f}"
              for row in sorted(rows, key=lambda row: (row["reynolds"], row["gap_over_a"]))]
    path.write_text("\n".join(lines) + "\n")
    print(f"written {path}")


def wake(args, spec: BoxSpec, mesh, viscosity: float, sides: dict, speed: float, base: fem.Function) -> dict:
    """The steady state `base` kicked off axisymmetry (`kick`, amplitude --kick U) and time-stepped (BDF2 from two
    equal levels, dt = --wake-dt D / U, for --wake-time D / U; the first step's factors kept as FGMRES's
    preconditioner, refactorised by fem.solver.ReusedFactorOperator's rule): the C_L history and its growth rate."""
    comm = MPI.COMM_WORLD
    flow, _ = make_flow(comm, spec, viscosity, args.strength, sides, inflow=(0.0, 0.0, -speed),
                        prefix="fd3d_wake_", step_solver="reuse", mesh=mesh)
    state = fem.Function(flow.W)
    state.x.array[:] = base.x.array
    kick(flow, state, args.kick * speed, spec.center)
    flow.set_state(state.x.petsc_vec)
    dt = args.wake_dt * 2.0 * RADIUS / speed
    flow.set_time_step(dt)
    steps = int(round(args.wake_time / args.wake_dt))
    times, drag_history, lift, iterations = [], [], [], []
    start = time.perf_counter()
    for step in range(steps):
        before = flow.step_operator.iterations if flow.step_operator else 0
        response = flow.step(responses=False)
        flow.commit(np.zeros(3))
        drag_coefficient, lift_coefficient = coefficients(response, speed)
        times.append((step + 1) * args.wake_dt)
        drag_history.append(drag_coefficient)
        lift.append(lift_coefficient)
        iterations.append(flow.step_operator.iterations - before)
        if comm.rank == 0 and ((step + 1) % 10 == 0 or step == 0):
            print(f"    t {times[-1]:6.1f} D/U: Cd {drag_coefficient:.5f} C_L {lift_coefficient:+.4e} "
                  f"({time.perf_counter() - start:.0f} s, {flow.factorisations} factorisations)", flush=True)
    elapsed = time.perf_counter() - start
    result = {"kick": args.kick, "dt_D_over_U": args.wake_dt, "time_D_over_U": args.wake_time, "steps": steps,
              "elapsed_s": elapsed, "assembly_s": flow.assembly_s, "factorise_s": flow.factorise_s,
              "solve_s": flow.solve_s, "factorisations": flow.factorisations,
              "factor_memory_bytes": flow.step_operator.factor_memory(), "fgmres_iterations": iterations,
              "times": times, "drag_history": drag_history, "lift_history": lift,
              "growth": growth_rate(times, lift, args.window)}
    if comm.rank == 0:
        g = result["growth"]
        print(f"    {steps} steps in {elapsed:.0f} s ({flow.factorisations} factorisations, {sum(iterations)} FGMRES "
              f"iterations): C_L {lift[0]:+.3e} -> {lift[-1]:+.3e}; growth rate of dC_L/dt over t "
              f"{g['window_start']:.1f}-{g['window_end']:.1f}: {g['sigma']:+.4f} U/D (halves "
              f"{g['sigma_first_half']:+.4f}, {g['sigma_second_half']:+.4f}; sign changes "
              f"{g['sign_changes_in_window']})", flush=True)
    flow.destroy()
    return result


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("case", choices=("wall", "solver", "drag", "lift", "growth"))
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
    parser.add_argument("--re", "--reynolds-list", dest="reynolds_list", default=[100.0],
                        type=lambda text: [float(g) for g in text.split(",")], help="U D / nu, a list (drag)")
    parser.add_argument("--downstream", type=float, default=6.0, help="diameters behind the sphere (drag)")
    parser.add_argument("--upstream", type=float, default=5.0, help="diameters before the sphere (drag)")
    parser.add_argument("--half-width", type=float, default=5.0, help="diameters to the slip sides (drag)")
    parser.add_argument("--wake-size", type=float, default=2.0, help="cells in the wake, in surface cells (drag)")
    parser.add_argument("--grading", type=float, default=0.3, help="size growth per distance (drag)")
    parser.add_argument("--picard-dt", type=float, default=2.0, help="the Picard steps' dt in D / U (drag)")
    parser.add_argument("--wake-time", type=float, default=0.0,
                        help="after the steady state, time-step the kicked wake this long in D / U (drag; 0: not)")
    parser.add_argument("--wake-dt", type=float, default=0.5, help="the wake's time step in D / U (drag)")
    parser.add_argument("--window", type=lambda text: tuple(float(g) for g in text.split(",")), default=None,
                        help="t_0,t_1 in D / U: the growth rate's window (drag with --wake-time, growth; default: "
                             "the last half)")
    parser.add_argument("--record", help="a drag record with --wake-time (growth)")
    parser.add_argument("--csv", help="write the rows as fem_bounce.wall_lift's table here (lift)")
    parser.add_argument("--symmetric-base", action="store_true",
                        help="project every Picard iterate on the axisymmetric class (x -> -x mirror; drag)")
    parser.add_argument("--kick", type=float, default=0.02, help="the wake's non-axisymmetric seed over U (drag)")
    args = parser.parse_args(argv)
    if args.case == "growth":  # a record's analysis: printed, nothing written
        growth(args)
        return
    start = time.perf_counter()
    rows = {"wall": wall, "solver": solver, "drag": drag, "lift": lift}[args.case](args)
    if MPI.COMM_WORLD.rank == 0:
        HISTORY.mkdir(exist_ok=True)
        record = {"command": f"python benchmarks/fd3d_stokes.py {' '.join(argv or sys.argv[1:])}",
                  "elapsed_s": time.perf_counter() - start, "rows": rows}
        path = HISTORY / f"fd3d_stokes_{args.case}{args.tag}.json"
        path.write_text(json.dumps(record, indent=1, default=float) + "\n")
        print(f"{record['elapsed_s']:.0f} s; written {path}")


if __name__ == "__main__":
    main()
