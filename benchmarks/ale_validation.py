"""Validation of the boundary-fitted ALE model (`--model ale`), one study per subcommand.

    python benchmarks/ale_validation.py brenner        # wall drag lambda(delta) at 8, 16, 32 cells/D   ~1 min
    python benchmarks/ale_validation.py drag           # Cd(100), Cd(200), meshes and domain size        ~3 min
    python benchmarks/ale_validation.py tencate        # ten Cate E4 settling, velocity curve            ~15 min
    python benchmarks/ale_validation.py case3          # Li case 3, three bounces                        ~10 min
    python benchmarks/ale_validation.py near-contact   # smallest gap the mesh follows to, per resolution ~20 min
    python benchmarks/ale_validation.py fig7 [--fd]    # the paper's Fig. 7: f_sim(gap) along case 3     ~10 min
    python benchmarks/ale_validation.py density        # lowest stable density ratio                     ~10 min
    python benchmarks/ale_validation.py cost           # seconds per step and their split, 8-32 cells/D  ~5 min
    (Table 2, cases 1-7:  python benchmarks/table2.py --model ale)

Times are for one core of a quiet 2-core machine; runs are serial (mpiexec -n 2 works too).
Everything goes to results/ale/<study>/ (runs/ keeps each run directory; a finished run is
reused unless --force), with a Markdown table <study>.md and, where it helps, a figure.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import time
from pathlib import Path

import numpy as np
from mpi4py import MPI

from fem_bounce import output, reference, theory
from fem_bounce import scene as scenes
from fem_bounce.errors import RunDiverged
from fem_bounce.run import run_logged as simulate  # the libraries' output goes to the run's run.log

ROOT = Path("results") / "ale"
COMM = MPI.COMM_WORLD


def run(name: str, study: str, scene_name: str, changes: dict, model: str = "ale", force: bool = False) -> Path:
    """The run directory of `model` on the preset with `changes`, running it unless it is there."""
    run_dir = ROOT / study / "runs" / name
    if force or not (run_dir / "summary.json").exists():
        scene = scenes.load(scene_name, changes)
        start = time.perf_counter()
        try:
            simulate(scene, model, COMM, run_dir, force=True, progress=False, command=f"ale_validation.py {study}")
        except RunDiverged as err:
            say(f"  {name}: {err}")
        say(f"  {name}: {time.perf_counter() - start:.1f} s")
    return run_dir


def summary(run_dir: Path) -> dict:
    return json.loads((run_dir / "summary.json").read_text())


def forces(run_dir: Path) -> dict[str, np.ndarray]:
    """The ale model's per-step force record (ale_forces.csv)."""
    with open(run_dir / "ale_forces.csv", newline="") as stream:
        rows = list(csv.reader(stream))
    data = np.array(rows[1:], dtype=float).reshape(-1, len(rows[0]))
    return {name: data[:, k] for k, name in enumerate(rows[0])}


def say(text: str) -> None:
    if COMM.rank == 0:
        print(text, flush=True)


def table(path: Path, header: list[str], rows: list[list]) -> None:
    """A Markdown table to `path` and the screen."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(x) for x in row) + " |" for row in rows]
    if COMM.rank == 0:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text("\n".join(lines) + "\n")
    say("\n".join(lines))


def pct(value: float, target: float) -> str:
    return f"{100.0 * (value / target - 1.0):+.2f} %"


# -- static checks --------------------------------------------------------------------------------------
def brenner(args) -> None:
    """Steady Stokes drag of a sphere approaching a wall, over 6 pi mu a V, against Brenner (1961)."""
    rows = []
    for cells in args.cells or (8.0, 16.0, 32.0):
        for delta in (1.0, 0.5, 0.25, 0.1, 0.05, 0.02, 0.01):
            base = scenes.load("brenner-approach")
            # the integrator wants a start outside contact: below delta_ss move delta_ss (it plays no role here);
            # the held sphere stays at its gap whatever numerics.ale.hold_delta (read nowhere here, so not set)
            changes = {"initial_gap": delta * base.sphere.diameter, "numerics.ale.cells_per_diameter": cells,
                       "contact.delta_ss": min(base.contact.delta_ss, delta / 2)}
            run_dir = run(f"n{cells:g}-delta{delta:g}", "brenner", "brenner-approach", changes, force=args.force)
            data, record = summary(run_dir), forces(run_dir)
            unit = -6.0 * math.pi * base.liquid.viscosity * base.sphere.radius * base.motion.velocity
            exact = theory.brenner_lambda(delta)
            lam, lam_surface = record["f_variational"][-1] / unit, record["f_surface"][-1] / unit
            rows.append([f"{cells:g}", f"{delta:g}", f"{exact:.4f}", f"{lam:.4f}", pct(lam, exact),
                         f"{lam_surface:.4f}", pct(lam_surface, exact), data["sizes"]["unknowns"],
                         f"{data['wall_time_s']:.1f} s"])
    table(ROOT / "brenner" / "brenner.md", ["cells/D", "delta", "Brenner", "lambda (variational)", "error",
                                            "lambda (stress integral)", "error", "unknowns", "wall time"], rows)


def drag(args) -> None:
    """Cd of a fixed sphere in a stream (steady Navier-Stokes by Newton) against Johnson & Patel / Fornberg."""
    rows = []
    targets = {100: 1.087, 200: 0.77}
    settings = [(cells, 10.0) for cells in (args.cells or (8.0, 16.0, 32.0))] + [(16.0, 20.0)]
    for re, target in targets.items():
        for cells, far in settings:
            changes = {"numerics.ale.cells_per_diameter": cells, "numerics.ale.far_field": far}
            run_dir = run(f"re{re}-n{cells:g}-far{far:g}", "drag", f"sphere-drag-re{re}", changes, force=args.force)
            data, record = summary(run_dir), forces(run_dir)
            scene = scenes.load(f"sphere-drag-re{re}")
            q = 0.5 * scene.liquid.density * scene.motion.stream_velocity**2 * math.pi * scene.sphere.radius**2
            cd, cd_surface = record["f_variational"][-1] / q, record["f_surface"][-1] / q
            rows.append([re, f"{cells:g}", f"{far:g}", f"{target}", f"{cd:.4f}", pct(cd, target),
                         f"{cd_surface:.4f}", data["sizes"]["unknowns"], f"{data['wall_time_s']:.1f} s"])
    table(ROOT / "drag" / "drag.md", ["Re", "cells/D", "far field / D", "reference", "Cd (variational)", "error",
                                      "Cd (stress integral)", "unknowns", "wall time"], rows)


# -- free motion -------------------------------------------------------------------------------------------
def tencate(args) -> None:
    """ten Cate et al. (2002) E4: peak settling speed and the velocity curve (trajectory.png of the run)."""
    rows = []
    for cells in args.cells or (16.0,):
        run_dir = run(f"n{cells:g}", "tencate", "tencate2002-e4", {"numerics.ale.cells_per_diameter": cells},
                      force=args.force)
        data = summary(run_dir)
        trajectory = output.read_trajectory(run_dir)
        peak = -trajectory["velocity"].min()
        t_exp, u_exp = reference.velocity_curve("tencate2002_E4")
        model = np.interp(t_exp, trajectory["t"], trajectory["velocity"])
        rms = math.sqrt(np.mean((model - u_exp) ** 2)) / 0.1226
        rows.append([f"{cells:g}", f"{peak:.4f}", pct(peak, 0.1226), f"{100 * rms:.1f} %",
                     data["ale"]["remesh_count"], data["steps"], f"{data['wall_time_s']:.0f} s",
                     str(run_dir / "trajectory.png")])
    table(ROOT / "tencate" / "tencate.md", ["cells/D", "peak speed [m/s]", "error (target 0.1226)",
                                            "rms velocity difference / peak", "remeshes", "steps", "wall time",
                                            "figure"], rows)


def bounce_rows(run_dir: Path, measured: dict) -> list:
    data = summary(run_dir)
    impacts = data["impacts"]
    first = impacts[0] if impacts else None
    second = impacts[1] if len(impacts) > 1 else None
    return [f"{first['impact_speed']:.4f}" if first else "-",
            pct(first["impact_speed"], measured["V_i_m_per_s"]) if first else "-",
            f"{first['Re']:.1f}" if first else "-",
            f"{second['Re']:.1f}" if second else "-",
            pct(second["Re"], measured["Re_II"]) if second else "-",
            sum(1 for r in data["rebounds"] if r["apex_gap"] is not None),
            data["ale"]["remesh_count"] if "ale" in data else "-", data["steps"], f"{data['wall_time_s']:.0f} s",
            data["status"]]


def case3(args) -> None:
    """Li et al. case 3 with three bounces: first impact speed (target 0.393 m/s) and Re of the second."""
    measured = {int(r["case"]): r for r in reference.table("li2011_table2_experiments")}[3]
    rows = []
    for cells in args.cells or (8.0, 16.0, 24.0):
        for cfl in (0.5,) if cells != 16.0 else (0.5, 0.25):
            changes = {"numerics.ale.cells_per_diameter": cells, "numerics.ale.cfl": cfl}
            run_dir = run(f"n{cells:g}-cfl{cfl:g}", "case3", "li2011-case3", changes, force=args.force)
            rows.append([f"{cells:g}", f"{cfl:g}", *bounce_rows(run_dir, measured)])
    run_dir = run("ode", "case3", "li2011-case3", {}, model="ode", force=args.force)
    rows.append(["ode", "-", *bounce_rows(run_dir, measured)])
    table(ROOT / "case3" / "case3.md", ["cells/D", "cfl", "V_i [m/s]", "vs 0.393", "Re_I", "Re_II", "vs 55",
                                        "rebounds", "remeshes", "steps", "wall time", "status"], rows)


def near_contact(args) -> None:
    """With the hold switched off (hold_delta = 0) the mesh follows the sphere (its predicted position)
    until a step would carry it through the wall: the smallest mesh gap reached per resolution and time
    step, beside the default hold.  Case 3 to its first rebound, with the paper's blend (docs/validation.md, "How close
    the mesh can follow": under the default near-wall correction the mesh holds at delta_sl D, reads no hold_delta)."""
    rows = []
    settings = [(cells, 0.5, hold) for cells in (args.cells or (8.0, 16.0, 32.0)) for hold in (0.0, 0.02)]
    settings += [(8.0, 1.0, 0.0), (8.0, 2.0, 0.0), (16.0, 2.0, 0.0)]
    for cells, cfl, hold in settings:
        changes = {"numerics.ale.cells_per_diameter": cells, "numerics.ale.hold_delta": hold,
                   "numerics.ale.cfl": cfl, "run.bounces": 1, "run.end_time": 0.1, "contact.near_wall": "blend"}
        name = f"n{cells:g}-hold{hold:g}" + ("" if cfl == 0.5 else f"-cfl{cfl:g}")
        run_dir = run(name, "near-contact", "li2011-case3", changes, force=args.force)
        data, record = summary(run_dir), forces(run_dir)
        diameter = data["scene"]["sphere"]["diameter"]
        first = data["impacts"][0] if data["impacts"] else None
        rows.append([f"{cells:g}", f"{cfl:g}", f"{hold:g}", f"{record['mesh_gap'].min() / diameter:.4f}",
                     f"{first['min_gap'] / diameter:.4f}" if first else "-",
                     f"{first['impact_speed']:.4f}" if first else "-",
                     int(record["remeshed"].sum()), data["status"][:100]])
    table(ROOT / "near-contact" / "near-contact.md",
          ["cells/D", "cfl", "hold_delta", "smallest mesh gap / D", "sphere's min gap / D", "V_i [m/s]", "remeshes",
           "status"], rows)


def fig7(args) -> None:
    """The paper's Fig. 7: with the case-3 approach prescribed (from the ODE model's trajectory up to its
    first impact), the resolved force against the gap, with f_thr along the same path."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    folder = ROOT / "fig7"
    ode_dir = run("ode", "fig7", "li2011-case3", {"run.bounces": 1}, model="ode", force=args.force)
    series = folder / "case3-approach.csv"
    ode = output.read_trajectory(ode_dir)
    scene = scenes.load("li2011-case3")
    # the approach down to delta_ss: the contact itself (microseconds) is no flow problem, and a spline
    # through its velocity jump would wiggle.  The runs stop at delta = 0.025, so that their last step,
    # which may end up to one dt past end_time, stays on the series.
    series_end = float(ode["t"][np.argmax(ode["gap"] <= scene.contact.delta_ss * scene.sphere.diameter)])
    end = float(ode["t"][np.argmax(ode["gap"] <= 0.025 * scene.sphere.diameter)])
    keep = ode["t"] <= series_end
    if COMM.rank == 0:
        with open(series, "w", newline="") as stream:
            writer = csv.writer(stream)
            writer.writerow(["t", "velocity"])
            writer.writerows(zip(ode["t"][keep], ode["velocity"][keep]))
    COMM.barrier()
    changes = {"motion.mode": "prescribed", "motion.series": str(series.resolve()), "run.end_time": end,
               "run.bounces": 0}
    cells = args.cells[0] if args.cells else 16.0
    runs = {"ale": ("ale", {"numerics.ale.cells_per_diameter": cells}),
            "ale-dt/4": ("ale", {"numerics.ale.cells_per_diameter": cells, "numerics.ale.cfl": 0.125})}
    if args.fd:
        runs["fd"] = ("fd", {"numerics.fd.cells_per_diameter": cells})
    curves = {}
    for name, (model, extra) in runs.items():
        run_dir = run(name.replace("/", "-"), "fig7", "li2011-case3", {**changes, **extra}, model=model,
                      force=args.force)
        # every run follows the same prescribed path: any run's rows (all sub-steps) give f_thr along it
        path = output.read_trajectory(run_dir)
        curves[name] = at_fluid_steps(path, summary(run_dir)["sizes"]["dt"])
    unit = scene.displaced_mass * scene.gravity  # (4/3) pi a^3 rho_l g, the paper's force unit
    diameter = scene.sphere.diameter
    hold = scene.numerics.ale.hold_delta
    # the quasi-steady Stokes wall drag along the same path, Brenner's lambda without an inertial factor
    drag_unit = 6.0 * math.pi * scene.liquid.viscosity * scene.sphere.radius
    path["f_stokes"] = np.array([-drag_unit * v * theory.brenner_lambda(h / diameter)
                                 for h, v in zip(path["gap"], path["velocity"])])

    def at(delta, data, values):
        return float(np.interp(delta, data["gap"][::-1] / diameter, values[::-1])) / unit

    rows = []
    for delta in (0.5, 0.35, 0.2, 0.1, 0.05, 0.03):
        rows.append([f"{delta:g}", f"{at(delta, path, path['f_theory']):.3f}",
                     f"{at(delta, path, path['f_stokes']):.3f}",
                     *[f"{at(delta, data, data['f_sim']):.3f}" for data in curves.values()]])
    table(folder / "fig7.md", ["delta", "f_thr / (m_l g)", "Brenner Stokes drag / (m_l g)",
                               *[f"f_sim {m} / (m_l g)" for m in curves]], rows)
    if COMM.rank == 0:
        fig, ax = plt.subplots(figsize=(6.5, 4.5))
        ax.plot(path["gap"] / diameter, path["f_theory"] / unit, "k-", lw=1.5, label=r"$f_{thr}$ (theory, same path)")
        ax.plot(path["gap"] / diameter, path["f_stokes"] / unit, "k--", lw=1.0,
                label=r"$6\pi\mu a |V| \lambda_{Brenner}(\delta)$ (Stokes, no inertia)")
        styles = {"ale": ("C0", "ale (boundary-fitted)"), "ale-dt/4": ("C2", "ale, dt / 4"),
                  "fd": ("C3", "fd (fictitious domain)")}
        for model, data in curves.items():
            color, label = styles[model]
            ax.plot(data["gap"] / diameter, data["f_sim"] / unit, color=color, lw=1.2, label=rf"$f_{{sim}}$ {label}")
        ax.axvspan(0.0, hold, color="0.85", label=f"ale mesh held (gap < {hold:g} D)")
        ax.set_xlim(0.0, 0.6)
        ax.set_ylim(0.0, 1.2 * at(0.03, path, path["f_theory"]))
        ax.axvline(scene.contact.delta_sl, color="0.5", ls=":", lw=0.8)
        ax.text(scene.contact.delta_sl, ax.get_ylim()[1] * 0.95, r" $\delta_{sl}$", fontsize=8, va="top")
        ax.set_xlabel(r"$\delta = h/D$")
        ax.set_ylabel(r"force $/ (\frac{4}{3}\pi a^3 \rho_l g)$")
        ax.set_title("Li et al. (2011) Fig. 7: case-3 approach prescribed (ODE-model trajectory)", fontsize=9)
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(folder / "fig7.png", dpi=130)
        plt.close(fig)
        say(f"figure: {folder / 'fig7.png'}")


def at_fluid_steps(trajectory: dict, dt: float) -> dict:
    """The trajectory rows at the ends of the fluid steps: between them the sphere integrator's sub-steps
    hold the step's linearised force while the gap moves on, which draws a saw-tooth."""
    steps = np.arange(dt, trajectory["t"][-1] + 0.5 * dt, dt)
    rows = np.unique(np.clip(np.searchsorted(trajectory["t"], steps - 1e-9 * dt), 0, len(trajectory["t"]) - 1))
    return {name: values[rows] for name, values in trajectory.items()}


def density(args) -> None:
    """Lowest stable density ratio: case-3 geometry, the sphere's density varied, 0.05 s of motion
    (it sinks or rises); stable when it completes and the sphere's speed stays below the inviscid bound."""
    rows = []
    cells = args.cells[0] if args.cells else 12.0
    base = scenes.load("li2011-case3")
    for ratio in (8.0, 1.167, 1.01, 0.5, 0.2, 0.1, 0.05, 0.01):
        changes = {"sphere.density": ratio * base.liquid.density, "numerics.ale.cells_per_diameter": cells,
                   "run.end_time": 0.05, "run.bounces": 1}
        run_dir = run(f"ratio{ratio:g}", "density", "li2011-case3", changes, force=args.force)
        data = summary(run_dir)
        trajectory = output.read_trajectory(run_dir)
        speed = np.abs(trajectory["velocity"]).max()
        # inviscid bound: released from rest with acceleration |rho_p - rho_l| g / (rho_p + rho_l / 2)
        bound = abs(ratio - 1.0) * base.gravity / (ratio + 0.5) * data["final"]["time"]
        steady = data["status"] == "completed" and np.all(np.isfinite(trajectory["velocity"])) and speed <= bound
        rows.append([f"{ratio:g}", f"{speed:.4f}", f"{bound:.4f}", "stable" if steady else "UNSTABLE",
                     f"{data['ale']['added_mass_over_displaced']:.3f}" if "ale" in data else "-", data["status"][:60]])
    table(ROOT / "density" / "density.md", ["rho_p / rho_l", "max |V| [m/s]", "inviscid bound [m/s]", "verdict",
                                            "m_a / m_l (last step)", "status"], rows)


def cost(args) -> None:
    """Seconds per step and where they go (case 3, 60 steps)."""
    rows = []
    for cells in args.cells or (8.0, 16.0, 24.0, 32.0):
        base = scenes.load("li2011-case3", {"numerics.ale.cells_per_diameter": cells})
        from fem_bounce.models.ale.domain import time_step

        changes = {"numerics.ale.cells_per_diameter": cells, "run.end_time": 60 * time_step(base)}
        run_dir = run(f"n{cells:g}", "cost", "li2011-case3", changes, force=args.force)
        data = summary(run_dir)
        ale, steps = data["ale"], data["steps"]
        timings = ale["timings_s"]
        rows.append([f"{cells:g}", data["sizes"]["unknowns"], steps, f"{ale['time_per_step_s']:.3f}",
                     f"{timings['factorise_and_solve'] / steps:.3f}", f"{timings['integrator'] / steps:.4f}",
                     f"{timings['remesh']:.1f} s / {ale['remesh_count']}",
                     f"{ale['peak_memory_bytes'] / 2**20:.0f} MB"])
    table(ROOT / "cost" / "cost.md", ["cells/D", "unknowns", "steps", "s / step", "assemble+factorise+solve s / step",
                                      "integrator s / step", "remeshing", "peak memory"], rows)


STUDIES = {"brenner": brenner, "drag": drag, "tencate": tencate, "case3": case3, "near-contact": near_contact,
           "fig7": fig7, "density": density, "cost": cost}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("study", choices=[*STUDIES, "all"])
    parser.add_argument("--cells", type=float, nargs="*", help="cells per diameter (default: the study's ladder)")
    parser.add_argument("--fd", action="store_true", help="fig7: also run the fd model on the same path")
    parser.add_argument("--force", action="store_true", help="re-run finished runs")
    args = parser.parse_args()
    for name in STUDIES if args.study == "all" else [args.study]:
        start = time.perf_counter()
        say(f"== {name}")
        STUDIES[name](args)
        say(f"({name}: {time.perf_counter() - start:.0f} s)")


if __name__ == "__main__":
    main()
