"""The paper's Fig. 9-12 regenerated from a model, beside the paper's data where it is tabulated.

    mpiexec -n 2 fem-bounce study figures --model fd

- Fig. 9:  case 3 trajectory for delta_ss = 0.015, 0.017, 0.019 (the paper's contact model, contact.model = "li2011");
- Fig. 10: case 3 velocity against gap;
- Fig. 11: case 7 vorticity snapshots (models that write field snapshots; see fem_bounce.fields);
- Fig. 12: relative error of the impact Reynolds numbers Re_I and Re_II against Table 2, by case and
  Stokes number (a), and for the low-St cases against delta_ss (b, the paper's contact model).
"""
from __future__ import annotations

import importlib
from pathlib import Path

from .. import models, plots, reference
from .. import scene as scenes
from ..output import read_summary, read_trajectory
from .common import StudyDirectory
from .runner import Runner

DELTA_SS = (0.015, 0.017, 0.019)
DELTA_SS_LOW_ST = (0.017, 0.01785, 0.0187)


def run(model: str, comm, out: Path, cases=(1, 2, 3, 4, 5, 6, 7), overrides: dict | None = None,
        runner: Runner | None = None) -> dict:
    study = StudyDirectory(out, comm)
    extra = dict(overrides or {})
    runner = runner or Runner(comm)
    snapshots_key = models.info(model).fields_key
    # every run the figures need, named by (figure, its key); all of them go to the runner at once
    # delta_ss belongs to the paper's contact model: Fig. 9 and 12b vary it under contact.model = "li2011"
    paper = {"contact.model": "li2011"}
    wanted = {("fig9", dss): (3, {**paper, "contact.delta_ss": dss}) for dss in DELTA_SS}
    wanted |= {("fig12", case): (case, {}) for case in cases}
    wanted |= {("fig12b", (case, dss)): (case, {**paper, "contact.delta_ss": dss}) for case in (1, 2)
               if case in cases for dss in DELTA_SS_LOW_ST}
    if snapshots_key:
        wanted[("fig11", 7)] = (7, {snapshots_key: 20})
    keys = list(wanted)
    tasks = [(scenes.load(f"li2011-case{case}", {"run.bounces": 3, **extra, **changes}), model,
              f"case {case} " + ", ".join(f"{k} = {v:g}" for k, v in changes.items()))
             for case, changes in wanted.values()]
    study.log(f"{len(tasks)} runs, {runner.describe()} (finished runs are reused from the cache)")
    found: dict = {}
    for k, run_dir in runner.run([(scene, name) for scene, name, _ in tasks]):
        study.log(f"{model} {tasks[k][2]}: {read_summary(run_dir)['status']}")
        found[keys[k]] = run_dir
    fig9 = {dss: found[("fig9", dss)] for dss in DELTA_SS}
    fig12 = {case: found[("fig12", case)] for case in cases}
    fig12b = {key: found[("fig12b", key)] for (figure, key) in keys if figure == "fig12b"}
    made = {}
    if comm.rank == 0:
        made["fig9"] = figure_9(fig9, out / "fig09_case3_delta_ss.png")
        summary = read_summary(fig9[0.017])
        made["fig10"] = plots.velocity_gap_figure(read_trajectory(fig9[0.017]), summary,
                                                  out / "fig10_case3_velocity_gap.png")
        made["fig12"] = figure_12(fig12, fig12b, out / "fig12_relative_error.png")
    if snapshots_key and comm.rank == 0:
        made["fig11"] = figure_11(found[("fig11", 7)], out / "fig11_case7_vorticity.png", study)
    elif not snapshots_key:
        study.log(f"fig 11 skipped: the {model} model writes no flow field")
    study.write_json("figures.json", {k: str(v) for k, v in made.items() if v})
    return made


def figure_9(runs: dict, path: Path) -> Path:
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4))
    for k, (dss, run_dir) in enumerate(runs.items()):
        traj, summary = read_trajectory(run_dir), read_summary(run_dir)
        diameter, t_unit, _ = plots.units(summary["scene"])
        ax.plot(traj["t"] / t_unit, traj["gap"] / diameter, color=f"C{k}", lw=1.2,
                label=rf"$\delta_{{ss}}$ = {dss:g}")
    ax.set_xlabel(r"$t/\sqrt{D/g}$")
    ax.set_ylabel(r"$h/D$")
    ax.set_ylim(bottom=0)
    ax.set_title(f"Fig. 9: case 3 trajectory ({summary['model']} model)", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def figure_12(runs: dict, low_st: dict, path: Path) -> Path:
    import matplotlib.pyplot as plt

    table = {int(r["case"]): r for r in reference.table("li2011_table2_experiments")}
    fig, (ax_a, ax_b) = plt.subplots(1, 2, figsize=(10, 4))
    model = None
    for case, run_dir in runs.items():
        summary = read_summary(run_dir)
        model = summary["model"]
        impacts = summary["impacts"]
        for k, (key, name) in enumerate((("Re_I", "first impact"), ("Re_II", "second impact"))):
            if len(impacts) > k:
                error = impacts[k]["Re"] / table[case][key] - 1.0
                ax_a.plot(table[case]["St_I_derived" if k == 0 else "St_II_derived"], 100 * error, "os"[k],
                          color=f"C{k}", label=name if case == min(runs) else None)
                ax_a.annotate(str(case), (table[case]["St_I_derived" if k == 0 else "St_II_derived"], 100 * error),
                              fontsize=7, xytext=(3, 3), textcoords="offset points")
    ax_a.axhspan(-3, 3, color="0.9", label="experimental spread (3 %)")
    ax_a.axhline(0, color="0.5", lw=0.8)
    ax_a.set_xlabel("measured impact Stokes number")
    ax_a.set_ylabel("relative error of Re against Table 2 (%)")
    ax_a.set_title(f"(a) cases 1-7 ({model})", fontsize=9)
    ax_a.legend(fontsize=8)
    for k, case in enumerate(sorted({c for c, _ in low_st})):
        points = sorted((dss, read_summary(d)) for (c, dss), d in low_st.items() if c == case)
        xs = [dss for dss, s in points if len(s["impacts"]) > 1]
        ys = [100 * (s["impacts"][1]["Re"] / table[case]["Re_II"] - 1) for _, s in points if len(s["impacts"]) > 1]
        ax_b.plot(xs, ys, "o-", color=f"C{k}", label=f"case {case}, second impact")
    ax_b.axhspan(-3, 3, color="0.9")
    ax_b.set_xticks(DELTA_SS_LOW_ST)
    ax_b.set_xlabel(r"$\delta_{ss}$")
    ax_b.set_ylabel("relative error of Re_II (%)")
    ax_b.set_title("(b) low Stokes numbers against delta_ss", fontsize=9)
    ax_b.legend(fontsize=8)
    fig.suptitle("Fig. 12 (with impact Reynolds numbers, which Table 2 tabulates)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def figure_11(run_dir: Path, path: Path, study: StudyDirectory) -> Path | None:
    try:
        fields = importlib.import_module("fem_bounce.fields")
        return fields.vorticity_figure(run_dir, path=path)
    except (ModuleNotFoundError, AttributeError, FileNotFoundError) as err:
        study.log(f"fig 11 skipped: {err}")
        return None
