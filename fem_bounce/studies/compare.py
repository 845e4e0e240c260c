"""Several models on one scene: one figure and one table.

    fem-bounce compare li2011-case3 --models ode,fd,ib --out runs/compare-case3

Each model's run lands in DIR/MODEL (the usual run directory: trajectory.csv,
summary.json, plots).  Runs go through the study cache (fem_bounce.cache): a finished
run of the same resolved scene, model and code is copied, not run again.  Then, from
those files only:

    DIR/comparison.csv   one row per model (and one for the measurement, if the scene
                         has one): status, wall time, steps, size, and per impact the
                         impact speed, Re, restitution and the rebound apex
    DIR/comparison.png   trajectory and velocity overlays, impact speeds, apexes and
                         restitution per impact, wall time

A model that diverges is kept in the table with its status; the others still run.
"""
from __future__ import annotations

import csv
import math
import shutil
from pathlib import Path

from .. import models, output, reference
from ..cache import cached_run, default_root
from ..run import on_root
from ..scene import SceneError

MAX_IMPACTS = 3  # columns per impact in the table


def run_models(scene, names: list[str], comm, out_dir: Path, *, force: bool = False, progress: bool = True,
               plots: bool = True, command: str = "") -> list[Path]:
    """Each model's run (through the cache) copied to out_dir/NAME, with its figures unless `plots` is false;
    returns those directories, diverged runs included (their summary.json says so and the comparison shows it)."""
    for name in names:
        models.get(name)  # an unknown or missing model fails before anything runs
    out_dir = Path(out_dir)
    cache = on_root(comm, default_root)  # a cache that cannot be made refuses the comparison before out_dir
    directory = output.RunDirectory(out_dir)
    on_root(comm, lambda: directory.prepare(force))  # a refusal stops every rank
    runs = []
    for name in names:
        try:
            finished = cached_run(scene, name, comm, root=comm.bcast(cache, root=0), progress=progress,
                                  command=command)
        except Exception:
            if not runs:  # nothing in out_dir yet but its marker: out_dir goes (if this comparison made it)
                on_root(comm, directory.abandon)
            raise
        run_dir = out_dir / name
        if comm.rank == 0:
            # a copy inside the comparison, not a run directory of its own (no marker: --force replaces it)
            shutil.copytree(finished, run_dir, ignore=shutil.ignore_patterns(output.MARKER))
            if plots:
                from ..plots import draw_run  # matplotlib only for a comparison that draws

                draw_run(run_dir)
        comm.barrier()
        runs.append(run_dir)
    return runs


def table_rows(run_dirs: list[Path]) -> list[dict]:
    """One row per run directory (from summary.json), plus the scene's measured reference."""
    rows = []
    summaries = [output.read_summary(d) for d in run_dirs]
    for summary in summaries:
        sizes = summary.get("sizes") or {}
        row = {"model": summary["model"], "status": summary["status"], "wall_time_s": round(summary["wall_time_s"], 3),
               "steps": summary["steps"], "unknowns": sizes.get("unknowns", ""),
               "impacts": len(summary["impacts"])}
        d = summary["scene"]["sphere"]["diameter"]
        for k in range(MAX_IMPACTS):
            impact = summary["impacts"][k] if k < len(summary["impacts"]) else None
            rebound = summary["rebounds"][k] if k < len(summary["rebounds"]) else None
            row[f"impact_speed_{k + 1}"] = _fmt(impact and impact["impact_speed"])
            row[f"Re_{k + 1}"] = _fmt(impact and impact["Re"], 2)
            row[f"restitution_{k + 1}"] = _fmt(rebound and rebound["restitution"])
            apex = rebound and rebound["apex_gap"]
            row[f"apex_gap_over_D_{k + 1}"] = _fmt(apex / d if apex is not None else None)
        rows.append(row)
    ref = summaries[0]["scene"].get("reference", {}) if summaries else {}
    if ref.get("impact_speed") or ref.get("re_first"):
        row = {key: "" for key in rows[0]}
        row.update(model="measured", status=ref.get("source", ""))
        row["impact_speed_1"] = _fmt(ref.get("impact_speed"))
        row["Re_1"] = _fmt(ref.get("re_first"), 2)
        row["Re_2"] = _fmt(ref.get("re_second"), 2)
        rows.append(row)
    return rows


def _fmt(value, digits: int = 4):
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return ""
    return float(f"{value:.{digits + 2}g}")


def write_table(rows: list[dict], path: Path) -> None:
    with open(path, "w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def format_table(rows: list[dict]) -> str:
    """A short text table: model, status, wall time, and per impact V_i / Re / e / apex."""
    lines = [f"{'model':9s} {'wall s':>9s} {'steps':>6s} {'size':>8s}  per impact: V_i [m/s]  Re  e  apex/D"]
    for row in rows:
        impacts = []
        for k in range(1, MAX_IMPACTS + 1):
            if row.get(f"impact_speed_{k}") != "" or row.get(f"Re_{k}") != "":
                impacts.append(f"{row[f'impact_speed_{k}']} {row[f'Re_{k}']} {row[f'restitution_{k}']} "
                               f"{row[f'apex_gap_over_D_{k}']}".strip())
        status = "" if row["status"] in ("completed", "") or row["model"] == "measured" else f"  [{row['status'][:60]}]"
        lines.append(f"{row['model']:9s} {row['wall_time_s']!s:>9s} {row['steps']!s:>6s} {row['unknowns']!s:>8s}  "
                     + " | ".join(impacts) + status)
    return "\n".join(lines)


def draw(run_dirs: list[Path], rows: list[dict], path: Path) -> Path:
    from ..plots import units  # first: it selects matplotlib's Agg backend

    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 3, figsize=(14, 7.5))
    (ax_gap, ax_vel, ax_cost), (ax_imp, ax_apex, ax_e) = axes
    summaries = [output.read_summary(d) for d in run_dirs]
    scene = summaries[0]["scene"]
    diameter, t_unit, v_unit = units(scene)
    for k, (run_dir, summary) in enumerate(zip(run_dirs, summaries)):
        color, name = f"C{k}", summary["model"]
        traj = output.read_trajectory(run_dir)
        ax_gap.plot(traj["t"] / t_unit, traj["gap"] / diameter, color=color, lw=1.2, label=name)
        ax_vel.plot(traj["t"] / t_unit, traj["velocity"] / v_unit, color=color, lw=1.2, label=name)
        numbers = list(range(1, len(summary["impacts"]) + 1))
        ax_imp.plot(numbers, [i["impact_speed"] for i in summary["impacts"]], "o-", color=color, label=name)
        apexes = [(n, r["apex_gap"] / diameter) for n, r in zip(numbers, summary["rebounds"]) if r["apex_gap"]]
        if apexes:
            ax_apex.plot(*zip(*apexes), "^-", color=color, label=name)
        ax_e.plot(numbers[:len(summary["rebounds"])], [r["restitution"] for r in summary["rebounds"]], "s-",
                  color=color, label=name)
        ax_cost.bar(k, summary["wall_time_s"], color=color)
        size = (summary.get("sizes") or {}).get("unknowns")
        ax_cost.text(k, summary["wall_time_s"], f"{summary['wall_time_s']:.3g} s\n{size or '?'} unknowns\n"
                     f"{summary['status'][:20]}", ha="center", va="bottom", fontsize=7)
    ax_cost.set_xticks(range(len(summaries)), [s["model"] for s in summaries])
    ax_cost.set_yscale("log")
    ax_cost.set_ylim(top=5.0 * max(s["wall_time_s"] for s in summaries))  # room for the labels
    ax_cost.set(ylabel="wall time [s]", title="cost: wall time each run recorded")
    ref = scene.get("reference", {})
    measured = [(1, ref.get("impact_speed"))]
    if ref.get("re_second"):  # Table 2 gives the second impact as a Reynolds number
        liquid = scene["liquid"]
        measured.append((2, ref["re_second"] * liquid["viscosity"] / (liquid["density"] * diameter)))
    measured = [(n, v) for n, v in measured if v]
    if measured:
        ax_imp.plot(*zip(*measured), "k*", ms=10, label="measured (Table 2)")
    if ref.get("velocity_curve"):
        t_exp, u_exp = reference.velocity_curve(ref["velocity_curve"])
        ax_vel.plot(t_exp / t_unit, u_exp / v_unit, "ko", ms=3, mfc="none", label="experiment")
    ax_gap.set(xlabel=r"$t/\sqrt{D/g}$", ylabel=r"gap $h/D$", title="trajectory")
    ax_gap.set_ylim(bottom=0.0)
    ax_vel.set(xlabel=r"$t/\sqrt{D/g}$", ylabel=r"$V/\sqrt{gD}$", title="velocity (up +)")
    ax_imp.set(xlabel="impact", ylabel="impact speed [m/s] (2 ms mean)", title="impact speeds")
    ax_apex.set(xlabel="rebound", ylabel="apex gap h/D", title="rebound apexes")
    ax_e.set(xlabel="impact", ylabel="e (2 ms means)", title="restitution per impact")
    for ax in (ax_imp, ax_apex, ax_e):
        ax.xaxis.get_major_locator().set_params(integer=True)
    for ax in axes.ravel():
        ax.grid(alpha=0.3)
        if ax is not ax_cost and ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7)
    fig.suptitle(f"{scene['name']}: " + ", ".join(s["model"] for s in summaries), fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def compare(scene, names: list[str], comm, out_dir: Path, *, force: bool = False, progress: bool = True,
            plots: bool = True, command: str = "") -> list[dict]:
    """Run the models, then write DIR/comparison.csv and DIR/comparison.png (unless `plots` is false; rank 0).
    A pair scene is refused before anything runs: the table and the figure read one sphere's trajectory."""
    if scene.pair:
        raise SceneError(f"scene {scene.name!r} has a second sphere: `fem-bounce compare` tabulates one sphere; "
                         "run each model with `fem-bounce run` (each run draws both spheres)")
    runs = run_models(scene, names, comm, out_dir, force=force, progress=progress, plots=plots, command=command)
    rows = []
    if comm.rank == 0:
        rows = table_rows(runs)
        write_table(rows, Path(out_dir) / "comparison.csv")
        if plots:
            draw(runs, rows, Path(out_dir) / "comparison.png")
    return comm.bcast(rows, root=0)
