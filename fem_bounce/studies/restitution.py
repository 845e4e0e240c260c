"""The coefficient of restitution against impact Stokes number with any model (paper Fig. 13-14).

    fem-bounce restitution --model ode --points 40             # seconds
    fem-bounce restitution --model ale --points 12 --set numerics.ale.cells_per_diameter=8

The Table 3 material sets released from 0.5-7 diameters, release gaps planned by the ODE model so that
the impact Stokes numbers spread over 1-1000 (fem_bounce.restitution.plan), delta_ss = 0.017; plus the
paper's runs 30-35 (85 % glycerol, delta_ss + 5 %) over the part of that set's band.  Writes
restitution.csv and restitution.png (e against St with the ODE curve, the paper's statements and the
experiments' range); every run goes through the study cache.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import restitution
from .. import scene as scenes
from ..cache import load_summary
from .common import StudyDirectory, measure_all
from .runner import Runner

NO_REBOUND_BELOW_ST = 10.0  # Joseph et al. (2001); the paper's runs 25-29
DRY_ABOVE_ST = 500.0  # Joseph et al. (2001): e close to the dry value above St ~ 500


def run(model: str, comm, out: Path, points: int = 12, st_range=(1.0, 1000.0), overrides: dict | None = None,
        ode_points: int = 60, runner: Runner | None = None) -> list[dict]:
    study = StudyDirectory(out, comm)
    runner = runner or Runner(comm)
    restitution.tabulate_bands((*restitution.MATERIAL_SETS, restitution.DSS_PLUS_5), runner.map)
    planned = restitution.plan(points, st_range)
    lo, hi = restitution.stokes_band(restitution.DSS_PLUS_5)[1][[0, -1]]
    planned += [(restitution.DSS_PLUS_5, st, restitution.gap_for_stokes(restitution.DSS_PLUS_5, st))
                for name, st, _ in planned if name == "li2011-table3-steel-85" and lo <= st <= hi]
    trials = [restitution.bounce_scene(scenes.load(name, overrides), gap) for name, _, gap in planned]
    measured = measure_all([(trial, model, f"{name} St ~ {target:.3g}")
                            for trial, (name, target, _) in zip(trials, planned)], study, runner)
    rows = []
    for (name, target, gap), trial, row in zip(planned, trials, measured):
        summary = load_summary(Path(row["run_dir"]))
        impact = summary["impacts"][0] if summary["impacts"] else None
        rebound = summary["rebounds"][0] if summary["rebounds"] else None
        rows.append({"scene": name, "target_St": target, "gap_over_D": gap / trial.sphere.diameter,
                     "status": row["status"], "St": impact["St"] if impact else None,
                     "Re": impact["Re"] if impact else None,
                     "restitution": rebound["restitution"] if rebound else 0.0,
                     "apex_over_D": (rebound["apex_gap"] / trial.sphere.diameter
                                     if rebound and rebound["apex_gap"] is not None else 0.0),
                     "peak_restitution": rebound["peak_restitution"] if rebound else 0.0,
                     "wall_time_s": row["wall_time_s"], "run_dir": row["run_dir"]})
    study.write_csv("restitution.csv", rows)
    if comm.rank == 0:
        ode = restitution.sweep(ode_points, st_range, runner.map) if model != "ode" else None
        figure(rows, ode, model, out / "restitution.png")
    return rows


def figure(rows: list[dict], ode: list[dict] | None, model: str, path: Path, dry_restitution: float = 0.97) -> Path:
    """e against St: the model's runs by material set, the ODE curve, and what the experiments say."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 5))
    st = np.geomspace(0.8, 2000, 200)
    ax.axvspan(0.8, NO_REBOUND_BELOW_ST, color="0.92", zorder=0)
    ax.text(0.9, 0.62, "Joseph et al. (2001),\nLi et al. (2011): no\nrebound below St ~ 10", fontsize=7, color="0.3")
    ax.axvspan(DRY_ABOVE_ST, 2000, color="0.95", zorder=0)
    ax.text(DRY_ABOVE_ST * 1.05, 0.62, "e near the\ndry value\n(Joseph et\nal. 2001)", fontsize=7, color="0.3")
    ax.semilogx(st, dry_restitution * np.exp(-35.0 / st), "k--", lw=1,
                label=r"Legendre et al. (2006) fit to the experiments, $e_d\,e^{-35/St}$")
    ax.axhline(dry_restitution, color="0.5", ls=":", lw=1)
    if ode:
        for name in restitution.MATERIAL_SETS:
            mine = [r for r in ode if r["scene"] == name]
            if mine:
                ax.semilogx([r["St"] for r in mine], [r.get("restitution", 0.0) for r in mine], "-", color="0.55",
                            lw=1.2, label="ode model" if name == restitution.MATERIAL_SETS[0] else None)
    markers = "os^vD<>ph"
    for k, name in enumerate((*restitution.MATERIAL_SETS, restitution.DSS_PLUS_5)):
        mine = [r for r in rows if r["scene"] == name and r["St"]]
        if mine:
            plus = name == restitution.DSS_PLUS_5
            ax.semilogx([r["St"] for r in mine], [r["restitution"] for r in mine], markers[k % len(markers)],
                        color=f"C{k}", ms=6, mfc="none" if plus else None,
                        label=f"{model}: " + name.replace("li2011-table3-", "").replace("-dss105", r", $\delta_{ss}$+5 %"))
    ax.set_xlabel("impact Stokes number St (2 ms mean impact speed)")
    ax.set_ylabel("coefficient of restitution e")
    ax.set_xlim(0.8, 2000)
    ax.set_ylim(-0.03, 1.05)
    ax.legend(fontsize=7, loc="lower right", ncol=2)
    ax.set_title(f"Restitution against Stokes number, Table 3 sets released 0.5-7 D ({model})", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return Path(path)
