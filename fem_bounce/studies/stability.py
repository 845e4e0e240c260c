"""Where each method fails: sweeps of density ratio, time step, resolution near contact and delta_sl.

    mpiexec -n 2 fem-bounce study stability --model fd
    fem-bounce study stability --model ode                # only the density sweep applies

Each run (li2011-case3 to the first apex unless another scene is given) is classified
- unstable: it diverged (NaN, solver failure, the sphere inside the wall) or the sphere's mechanical
  energy 1/2 m_p V^2 + (m_p - m_l) g h rose above its initial value (the liquid can only take energy);
- inaccurate: stable, but its first impact speed differs by more than 5 %, or its first rebound apex by
  more than 10 %, from the sweep's most conservative member (smallest CFL, finest mesh, delta_sl = 0.2);
- stable otherwise.
Writes stability.csv, stability.json and stability.png (one panel per sweep).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..bodies import scene_bodies
from ..output import read_trajectory
from .. import scene as scenes
from .common import LADDERS, StudyDirectory, measure_all
from .runner import Runner

SWEEPS = {
    "density_ratio": (0.5, 0.8, 1.1, 1.5, 2.0, 4.0, 8.0),
    "cfl": (0.1, 0.2, 0.4, 0.8, 1.2, 2.0),
    "cells_per_gap": (0.5, 1.0, 2.0, 4.0, 8.0),  # fine cells across the delta_sl gap
    "delta_sl": (0.05, 0.1, 0.2, 0.4),
}
SAFEST = {"cfl": min, "cells_per_gap": max, "delta_sl": lambda values: 0.2 if 0.2 in values else max(values)}
TOLERANCE = {"impact_speed": 0.05, "apex_gap": 0.10}
ENERGY_SLACK = 0.02  # of |m_p - m_l| g h0: room for the integrator's error before calling it growth


def applicable(model: str) -> list[str]:
    return ["density_ratio"] if model == "ode" else list(SWEEPS)


def scene_for(base: scenes.Scene, model: str, sweep: str, value: float) -> scenes.Scene:
    ladder = LADDERS[model]
    change = {
        "density_ratio": {"sphere.density": value * base.liquid.density},
        "cfl": ladder.time_step(base, value),
        "cells_per_gap": {ladder.key: value / base.contact.delta_sl},
        "delta_sl": {"contact.delta_sl": value},
    }[sweep]
    return base.replace(**change)


def energy_grew(scene: scenes.Scene, run_dir: Path) -> bool:
    trajectory = read_trajectory(run_dir)
    net = scene_bodies(scene)[0].net_weight
    energy = 0.5 * scene.sphere.mass * trajectory["velocity"] ** 2 + net * trajectory["gap"]
    return bool(np.nanmax(energy) - energy[0] > ENERGY_SLACK * abs(net) * scene.initial_gap)


def classify(row: dict, scene: scenes.Scene, safest: dict | None) -> str:
    if row["status"] != "completed" or energy_grew(scene, Path(row["run_dir"])):
        return "unstable"
    if safest is not None and safest is not row:
        for name, tolerance in TOLERANCE.items():
            if safest.get(name) and (row.get(name) is None or abs(row[name] / safest[name] - 1) > tolerance):
                return "inaccurate"
    return "stable"


def run(base: scenes.Scene, model: str, comm, out: Path, sweeps: dict | None = None,
        runner: Runner | None = None) -> dict:
    study = StudyDirectory(out, comm)
    sweeps = {name: values for name, values in (sweeps or SWEEPS).items() if name in applicable(model)}
    plan = [(sweep, value) for sweep, values in sweeps.items() for value in values]
    measured = measure_all([(scene_for(base, model, sweep, value), model, f"{sweep} = {value:g}")
                            for sweep, value in plan], study, runner)
    results = {}
    for sweep, values in sweeps.items():
        rows = [{"sweep": sweep, "value": value, **row} for (name, value), row in zip(plan, measured) if name == sweep]
        pick = SAFEST.get(sweep)
        safest = next(r for r in rows if r["value"] == pick([r["value"] for r in rows])) if pick else None
        for row, value in zip(rows, values):
            row["class"] = classify(row, scene_for(base, model, sweep, value), safest)
        results[sweep] = rows
        study.log(f"{sweep}: " + ", ".join(f"{r['value']:g} {r['class']}" for r in rows))
    limits = {sweep: limits_of(rows) for sweep, rows in results.items()}
    study.write_csv("stability.csv", [r for rows in results.values() for r in rows])
    study.write_json("stability.json", {"scene": base.name, "model": model, "limits": limits, "sweeps": results})
    if comm.rank == 0:
        figure(results, limits, base.name, model, out / "stability.png")
    return {"limits": limits, "sweeps": results}


def limits_of(rows: list[dict]) -> dict:
    good = [r["value"] for r in rows if r["class"] == "stable"]
    bad = [r["value"] for r in rows if r["class"] == "unstable"]
    return {"stable_and_accurate": [min(good), max(good)] if good else None, "unstable_at": bad,
            "inaccurate_at": [r["value"] for r in rows if r["class"] == "inaccurate"]}


COLOURS = {"stable": "tab:green", "inaccurate": "tab:orange", "unstable": "tab:red"}


def figure(results: dict, limits: dict, scene_name: str, model: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import matplotlib.ticker

    fig, axes = plt.subplots(1, len(results), figsize=(3.6 * len(results), 3.8), squeeze=False)
    for ax, (sweep, rows) in zip(axes[0], results.items()):
        for row in rows:
            speed = row.get("impact_speed") or row.get("peak_speed") or 0.0
            ax.semilogx(row["value"], speed, "o", ms=9, color=COLOURS[row["class"]])
        for label, colour in COLOURS.items():
            ax.plot([], [], "o", color=colour, label=label)
        ax.set_xlabel(sweep.replace("_", " "))
        ax.set_ylabel("first impact speed (m/s; 0: never reached the wall)", fontsize=8)
        ax.xaxis.set_minor_formatter(matplotlib.ticker.NullFormatter())  # no crowded minor labels
        ax.set_xticks(sorted(row["value"] for row in rows), minor=False)
        ax.set_xticklabels([f"{row['value']:g}" for row in sorted(rows, key=lambda r: r["value"])], fontsize=7)
        ax.set_title(f"unstable at {limits[sweep]['unstable_at'] or 'none'}", fontsize=8)
        ax.grid(True, alpha=0.3)
    axes[0][0].legend(fontsize=8)
    fig.suptitle(f"{scene_name}: where the {model} model fails", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
