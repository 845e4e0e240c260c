"""The coefficient of restitution against impact Stokes number for any model (paper Fig. 13-14).

    mpirun -n 2 fem-bounce study restitution --model fd --points 12

The Table 3 material sets, with initial gaps planned by the ODE model so that the impact Stokes
numbers spread from 1 to 1000 (fem_bounce.restitution.plan); delta_ss = 0.017 throughout, plus the
paper's runs 30-35 (85 % glycerol, delta_ss + 5 %) over St 8-100.  The ODE curve is drawn for comparison.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import restitution
from .. import scene as scenes
from ..cache import load_summary
from .common import StudyDirectory, run_and_measure

DSS_PLUS_5 = (("li2011-table3-steel-85-dss105", 100.0),)


def run(model: str, comm, out: Path, points: int = 12, st_range=(1.0, 1000.0)) -> list[dict]:
    study = StudyDirectory(out, comm)
    targets = restitution.log_targets(*st_range, points)
    planned = restitution.plan(targets)
    low = [st for st in targets if 8.0 <= st <= 100.0]
    planned += restitution.plan(low, ladder=DSS_PLUS_5) if low else []
    rows = []
    for name, target, gap in planned:
        trial = restitution.bounce_scene(scenes.load(name), gap)
        row = run_and_measure(trial, model, comm, study, f"{name} St ~ {target:.3g}")
        summary = load_summary(Path(row["run_dir"]))
        impact = summary["impacts"][0] if summary["impacts"] else None
        rebound = summary["rebounds"][0] if summary["rebounds"] else None
        rows.append({"scene": name, "target_St": target, "gap": gap, "status": row["status"],
                     "St": impact["St"] if impact else None, "Re": impact["Re"] if impact else None,
                     "restitution": rebound["restitution"] if rebound else 0.0,
                     "peak_restitution": rebound["peak_restitution"] if rebound else 0.0,
                     "wall_time_s": row["wall_time_s"]})
    study.write_csv("restitution.csv", rows)
    if comm.rank == 0:
        ode = restitution.sweep(restitution.log_targets(*st_range, 30)) if model != "ode" else rows
        figure(rows, ode, model, out / "restitution.png")
    return rows


def figure(rows: list[dict], ode: list[dict], model: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    base = [r for r in rows if r["St"] and not r["scene"].endswith("dss105")]
    plus = [r for r in rows if r["St"] and r["scene"].endswith("dss105")]
    ax.semilogx([r["St"] for r in base], [r["restitution"] for r in base], "o", color="C0",
                label=rf"{model}, $\delta_{{ss}}$ = 0.017")
    if plus:
        ax.semilogx([r["St"] for r in plus], [r["restitution"] for r in plus], "s", mfc="none", color="C1",
                    label=rf"{model}, $\delta_{{ss}}$ = 0.017 + 5 %")
    if ode is not rows:
        ax.semilogx([r["St"] for r in ode], [r.get("restitution", 0.0) for r in ode], "-", color="0.5", lw=1,
                    label="ode model")
    st = np.geomspace(1, 2000, 200)
    ax.semilogx(st, 0.97 * np.exp(-35.0 / st), "k--", lw=1, label=r"Legendre et al. (2006) $e_d e^{-35/St}$")
    ax.axvline(10.0, color="0.6", ls=":", lw=1)
    ax.set_xlabel("impact Stokes number St")
    ax.set_ylabel("coefficient of restitution e (2 ms mean speeds)")
    ax.set_ylim(-0.02, 1.05)
    ax.legend(fontsize=8, loc="upper left")
    ax.set_title(f"Restitution against Stokes number, Table 3 material sets ({model})", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
