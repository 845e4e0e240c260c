"""Speed against accuracy: every model at every resolution on one chart.

    mpirun -n 2 fem-bounce study speed-accuracy li2011-case3 --models ode,fd,ib

x = wall time (log), y = relative error (log) of the scene's quantities against (a) the finest run of the
highest-fidelity model present and (b) the experiment where one exists; the Pareto front is marked.  Also
writes, per accuracy threshold (1 %, 5 %, 10 %), the cheapest setting that reaches it on every primary
quantity: `fem-bounce run --accuracy 5%` reads these recommendations.
"""
from __future__ import annotations

import json
from importlib import resources
from pathlib import Path

from .. import scene as scenes
from ..models.registry import FIDELITY, MODELS
from .common import LADDERS, StudyDirectory, measure_all, measured, pareto, primary, relative_error
from .runner import Runner

THRESHOLDS = (0.01, 0.05, 0.10)


def run(scene: scenes.Scene, models: list[str], comm, out: Path, levels: dict | None = None,
        runner: Runner | None = None) -> dict:
    study = StudyDirectory(out, comm)
    plan = [(model, LADDERS[model].key, value) for model in models
            for value in (levels or {}).get(model, LADDERS[model].values)]
    found = measure_all([(scene.replace(**{key: value}), model, f"{key} = {value:g}") for model, key, value in plan],
                        study, runner)
    rows = [{"setting": {key: value}, **row} for (_, key, value), row in zip(plan, found)]
    names = primary(scene)
    reference_model = next(m for m in FIDELITY if m in models)
    finest = [r for r in rows if r["model"] == reference_model][-1]
    experiment = measured(scene)
    judged = [n for n in dict.fromkeys(names + ["re_second"]) if n in experiment]  # what the experiment measured
    for r in rows:
        for name in names:
            r[f"error_{name}"] = relative_error(r.get(name), finest.get(name))
        for name in judged:
            r[f"experiment_error_{name}"] = relative_error(r.get(name), experiment.get(name))
        r["error"] = _worst(r, "error_", names)
        r["experiment_error"] = _worst(r, "experiment_error_", judged) if judged else None
    recommendations = recommend(rows, names, finest)
    result = {"scene": scene.name, "quantities": names, "experiment_quantities": judged,
              "reference_run": finest["run_dir"], "reference_model": reference_model, "experiment": experiment,
              "rows": rows, "recommendations": recommendations}
    study.write_json("speed_accuracy.json", result)
    study.write_csv("speed_accuracy.csv", [{k: v for k, v in r.items() if k != "setting"} | r["setting"]
                                           for r in rows])
    if comm.rank == 0:
        figure(result, out / "speed_accuracy.png")
        for level, rec in recommendations.items():
            study.log(f"within {level}: " + (f"{rec['model']} {rec['setting']} ({rec['wall_time_s']:.1f} s)"
                                             if rec else "no setting reaches it"))
    return result


def _worst(row: dict, prefix: str, names: list[str]) -> float | None:
    errors = [row[prefix + n] for n in names]
    return None if any(e is None for e in errors) else max(errors)


def recommend(rows: list[dict], names: list[str], reference: dict) -> dict:
    """Cheapest run whose worst error against the reference run is within each threshold.
    The reference run itself is excluded: its error is zero by construction."""
    recommendations = {}
    for threshold in THRESHOLDS:
        candidates = [r for r in rows if r is not reference and r["error"] is not None and r["error"] <= threshold
                      and r["status"] == "completed"]
        best = min(candidates, key=lambda r: r["wall_time_s"], default=None)
        recommendations[f"{threshold:.0%}"] = None if best is None else {
            "model": best["model"], "setting": best["setting"], "wall_time_s": best["wall_time_s"],
            "error": best["error"], "quantities": names}
    return recommendations


def figure(result: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = result["rows"]
    panels = [("error", f"against the finest {result['reference_model']} run", result["quantities"])]
    if any(r["experiment_error"] is not None for r in rows):
        panels.append(("experiment_error", "against the experiment", result.get("experiment_quantities", [])))
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4.5), squeeze=False)
    for ax, (key, title, quantities) in zip(axes[0], panels):
        usable = [r for r in rows if r[key] is not None and r[key] > 0]
        for model in dict.fromkeys(r["model"] for r in usable):
            mine = [r for r in usable if r["model"] == model]
            ax.loglog([r["wall_time_s"] for r in mine], [r[key] for r in mine], "o-", color=MODELS[model].colour,
                      label=model)
        points = [(r["wall_time_s"], r[key]) for r in usable]
        front = [points[i] for i in pareto(points)]
        if front:
            xs, ys = zip(*front)
            ax.step(xs, ys, where="post", color="k", lw=1.0, alpha=0.6, label="Pareto front")
            ax.plot(xs, ys, "s", mfc="none", mec="k", ms=9)
        for threshold in THRESHOLDS:
            ax.axhline(threshold, color="0.7", ls=":", lw=0.8)
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel("worst relative error of " + ", ".join(quantities))
        ax.set_title(title, fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle(f"{result['scene']}: speed against accuracy", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


# -- recorded recommendations, for `fem-bounce run --accuracy` ------------------------------------

RECORD = "accuracy_recommendations.json"
RECORD_DIRECTORY = Path("results")  # where `study speed-accuracy --record` writes without --out


def recorded(directory: Path = RECORD_DIRECTORY) -> dict:
    """{scene name: {"5%": {"model": ..., "setting": {...}, ...}}}: the record shipped with the package
    (a deliberate, committed file), overlaid by the user's own in `directory`/accuracy_recommendations.json."""
    shipped = resources.files("fem_bounce") / "data" / RECORD
    data = json.loads(shipped.read_text()) if shipped.is_file() else {}
    own = Path(directory) / RECORD
    if own.is_file():
        data.update(json.loads(own.read_text()))
    return data


def record(result: dict, directory: Path = RECORD_DIRECTORY) -> Path:
    """Add one study's recommendations to `directory`/accuracy_recommendations.json (never to the installed
    package: to ship a record, copy the file into fem_bounce/data/ and commit it)."""
    path = Path(directory) / RECORD
    data = json.loads(path.read_text()) if path.exists() else {}
    data[result["scene"]] = result["recommendations"]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
    return path
