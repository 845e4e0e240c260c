"""Speed against accuracy: every model at every resolution on one chart.

    fem-bounce study speed-accuracy li2011-case3 --models ode,fd,ib,ale --levels ale=8,8@0.5,12,16
    fem-bounce study speed-accuracy li2011-case3 --models ode,fd,ib,ale,fd3d --levels fd3d=4,6   # the 3-D model too

x = wall time (log), y = relative error (log) of the scene's quantities against (a) a reference run and
(b) the experiment where one exists; the Pareto front is marked.  The reference is the finest level of the
highest-fidelity model present, run once more with its time step times `reference_step` (0.25 by
default; 1 takes the finest level itself) and its model's reference settings (registry.ModelInfo: the
ale model's steps shortened through each collision and its surface refined): a time-step error that
every run of a model shares at its default step is then measured, not hidden.  A level VALUE@FACTOR
runs the resolution VALUE with the time step times FACTOR.  Also writes, per accuracy threshold (1, 2,
5, 10 %), the cheapest setting that reaches it on every primary quantity: `fem-bounce run --accuracy 5%`
reads these recommendations, which come only from the models `fem-bounce run` would take for the scene's kind
(registry.FRONT_PICKS: never fd3d for a head-on scene, whose points are on the chart all the same).
"""
from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

from .. import scene as scenes
from ..models import ModelError, scene_kind
from ..models.registry import FIDELITY, FRONT_PICKS, MODELS
from .common import LADDERS, StudyDirectory, measure_all, measured, pareto, primary, relative_error
from .runner import Runner

THRESHOLDS = (0.01, 0.02, 0.05, 0.10)
REFERENCE_STEP = 0.25  # the reference run's time step, as a fraction of its model's step at the scene's setting
# reported against the reference beside the primary quantities, not judged: the first rebound's restitution
# and the second impact's Reynolds number.  A bounce's apex_gap goes with the restitution squared and sets the
# second fall, and judges both: in the case-3 study of 2026-11-26 every run's errors in e_1 and Re_II were
# smaller than its error in apex_gap (docs/performance.md, "Speed against accuracy")
SECONDARY = ("restitution", "re_second")


@dataclass(frozen=True)
class Level:
    """One run of a model's ladder: its resolution (the ladder's key) and its time step as a multiple of
    the one the scene sets (1: the scene's step; 0.5: half of it, through Ladder.scaled_step)."""

    resolution: float
    step_factor: float = 1.0

    @classmethod
    def parse(cls, text: str) -> Level:
        """'8' or '8@0.5' (8 cells/D at half the step); ValueError for anything else."""
        value, _, factor = text.partition("@")
        return cls(float(value), float(factor) if factor else 1.0)

    def setting(self, scene: scenes.Scene, model: str) -> dict:
        """The scene changes this level makes."""
        ladder = LADDERS[model]
        changes = {ladder.key: self.resolution}
        if self.step_factor != 1.0:
            changes.update(ladder.scaled_step(scene, self.step_factor))
        return changes


def setting_text(setting: dict) -> str:
    """'numerics.ale.cells_per_diameter = 16, numerics.ale.cfl = 0.125'."""
    return ", ".join(f"{key} = {str(value).lower() if isinstance(value, bool) else format(value, 'g')}"
                     for key, value in setting.items())


def describe(model: str, setting: dict) -> str:
    return f"{model}, {setting_text(setting)}"


def run(scene: scenes.Scene, models: list[str], comm, out: Path, levels: dict | None = None,
        runner: Runner | None = None, reference_step: float = REFERENCE_STEP) -> dict:
    """Every model at every level (`levels`: {model: [resolution or Level, ...]}, default its ladder), and
    the reference run; the errors, recommendations and figure go to `out`."""
    study = StudyDirectory(out, comm)
    load_at_start = os.getloadavg()  # 1, 5, 15 minutes: a shared machine's load slows the runs timed now
    plan = [(model, value if isinstance(value, Level) else Level(value)) for model in models
            for value in (levels or {}).get(model, LADDERS[model].values)]
    # the reference: the highest-fidelity model listed, in registry.FIDELITY's order (ale, fd, ib, ode), whatever
    # the order of `models`.  fd3d is not in it, by design: on a head-on scene the flow is axisymmetric, and the
    # axisymmetric models resolve it with a body-fitted (ale) or far finer (fd) mesh at a small part of the cost; the
    # 3-D model's affordable 4-8 cells/D are coarser than the axisymmetric ladders, so its difference from the ale
    # reference is its own discretisation error, which is what its points on the chart are to show
    reference_model = next((m for m in FIDELITY if m in models), None)
    if reference_model is None:
        usable = "ode" if scene.oblique else "ale"  # off the axis only the ode model of FIDELITY runs the scene
        raise ModelError(f"--models {','.join(models)}: the speed-accuracy study judges every run against the finest "
                         f"run of the highest-fidelity model listed, one of {', '.join(FIDELITY)}: add one, e.g. "
                         f"--models {usable},{','.join(models)}")
    ladder = LADDERS[reference_model]
    finest = min((level.resolution for model, level in plan if model == reference_model), key=ladder.spacing)
    reference_level = Level(finest, 1.0 if ladder.time_step_key is None else reference_step)
    if (reference_model, reference_level) not in plan:
        plan.append((reference_model, reference_level))
    settings = [level.setting(scene, model) for model, level in plan]
    reference_setting = settings[plan.index((reference_model, reference_level))]
    reference_setting.update(MODELS[reference_model].reference_settings)
    reference_text = describe(reference_model, reference_setting)
    study.log(f"reference: {reference_text}" + (f" ({reference_level.step_factor:g} times the scene's step)"
                                                 if ladder.time_step_key else " (a tolerance: no separate step)"))
    found = measure_all([(scene.replace(**setting), model, setting_text(setting))
                         for (model, _), setting in zip(plan, settings)], study, runner)
    rows = [{"setting": setting, "step_factor": level.step_factor,
             "reference": (model, level) == (reference_model, reference_level), **row}
            for (model, level), setting, row in zip(plan, settings, found)]
    names = primary(scene)
    reference = next(r for r in rows if r["reference"])
    secondary = [n for n in SECONDARY if n not in names and reference.get(n)]  # a settling sphere's e is 0
    experiment = measured(scene)
    judged = [n for n in dict.fromkeys(names + ["re_second"]) if n in experiment]  # what the experiment measured
    for r in rows:
        for name in names + secondary:
            r[f"error_{name}"] = relative_error(r.get(name), reference.get(name))
        for name in judged:
            r[f"experiment_error_{name}"] = relative_error(r.get(name), experiment.get(name))
        r["error"] = _worst(r, "error_", names)
        r["experiment_error"] = _worst(r, "experiment_error_", judged) if judged else None
    eligible = FRONT_PICKS[scene_kind(scene)].order  # the models `fem-bounce run` would take for this scene
    recommendations = recommend(rows, names, reference, eligible)
    result = {"scene": scene.name, "scene_digest": scenes.physics_digest(scene), "quantities": names,
              "secondary_quantities": secondary, "experiment_quantities": judged,
              "reference": {"model": reference_model, "setting": reference["setting"],
                            "step_factor": reference_level.step_factor, "run_dir": reference["run_dir"],
                            "text": reference_text},
              "experiment": experiment, "rows": rows, "recommendations": recommendations,
              "recommended_from": [m for m in eligible if m in models],
              "load_average": {"start": load_at_start, "end": os.getloadavg()}}
    study.write_json("speed_accuracy.json", result)
    study.write_csv("speed_accuracy.csv", [{k: v for k, v in r.items() if k != "setting"} | r["setting"]
                                           for r in rows])
    if comm.rank == 0:
        figure(result, out / "speed_accuracy.png")
        study.log(f"errors against the reference run ({reference_text}): " + ", ".join(names)
                  + (f"; also reported: {', '.join(secondary)}" if secondary else ""))
        for level, rec in recommendations.items():
            study.log(f"within {level}: " + (f"{describe(rec['model'], rec['setting'])} ({rec['wall_time_s']:.1f} s)"
                                             if rec else "no setting reaches it"))
        passed = [m for m in models if m not in eligible]
        if passed:
            study.log(f"not recommended ({FRONT_PICKS[scene_kind(scene)].kind}: `fem-bounce run` takes one of "
                      f"{', '.join(eligible)}): {', '.join(passed)}")
    return result


def _worst(row: dict, prefix: str, names: list[str]) -> float | None:
    errors = [row[prefix + n] for n in names]
    return None if any(e is None for e in errors) else max(errors)


def recommend(rows: list[dict], names: list[str], reference: dict, eligible: tuple | None = None) -> dict:
    """Cheapest run whose worst error against the reference run is within each threshold, among the runs of the
    `eligible` models (None: every model; the study passes the scene's registry.FRONT_PICKS, so that `run
    --accuracy` never takes a model `fem-bounce run` would not: fd3d for a head-on scene).
    The reference run itself is excluded: its error is zero by construction."""
    recommendations = {}
    for threshold in THRESHOLDS:
        candidates = [r for r in rows if r is not reference and r["error"] is not None and r["error"] <= threshold
                      and r["status"] == "completed" and (eligible is None or r["model"] in eligible)]
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
    reference = result["reference"]
    info = MODELS[reference["model"]]
    against = (f"against {info.label(reference['setting'][info.resolution_key])}"
               + (f" at {reference['step_factor']:g} x its step" if reference["step_factor"] != 1.0 else ""))
    panels = [("error", against, result["quantities"])]
    if any(r["experiment_error"] is not None for r in rows):
        panels.append(("experiment_error", "against the experiment", result.get("experiment_quantities", [])))
    fig, axes = plt.subplots(1, len(panels), figsize=(5.5 * len(panels), 4.5), squeeze=False)
    for ax, (key, title, quantities) in zip(axes[0], panels):
        usable = [r for r in rows if r[key] is not None and r[key] > 0]  # the reference's own error is 0
        for model in dict.fromkeys(r["model"] for r in usable):
            mine = [r for r in usable if r["model"] == model and r["step_factor"] == 1.0]
            marker, label = series_style(model)
            ax.loglog([r["wall_time_s"] for r in mine], [r[key] for r in mine], marker + "-",
                      color=MODELS[model].colour, label=label)
            for factor in sorted({r["step_factor"] for r in usable if r["model"] == model} - {1.0}):
                other = [r for r in usable if r["model"] == model and r["step_factor"] == factor]
                is_reference = all(r["reference"] for r in other)
                ax.loglog([r["wall_time_s"] for r in other], [r[key] for r in other], "*" if is_reference else "^",
                          mfc="none", ms=10 if is_reference else 8, color=MODELS[model].colour,
                          label=f"{label}, {factor:g} x step" + (" (the reference)" if is_reference else ""))
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
        ax.set_title(title, fontsize=8)
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:  # no run has an error here (none reached an impact): no legend
            ax.legend(fontsize=8)
    fig.suptitle(f"{result['scene']}: speed against accuracy", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def series_style(model: str) -> tuple[str, str]:
    """(marker, legend label) of a model's points: a 3-D model's diamonds and "fd3d (3-D)" beside the axisymmetric
    models' circles, in the registry's colour of each."""
    return ("D", f"{model} (3-D)") if MODELS[model].three_d else ("o", model)


# -- recorded recommendations, for `fem-bounce run --accuracy` ------------------------------------

RECORD = "accuracy_recommendations.json"
RECORD_DIRECTORY = Path("results")  # where `study speed-accuracy --record` writes without --out


def recorded(directory: Path = RECORD_DIRECTORY) -> dict:
    """{scene name: {"5%": {"model": ..., "setting": {...}, "scene_digest": ..., ...}}}: the record shipped with
    the package (a deliberate, committed file), overlaid by the user's own in `directory`/accuracy_recommendations
    .json (as `--record` wrote it; SceneError naming the file if it is not such a record).  Each pick also holds
    `record`, the file it was read from."""
    shipped = resources.files("fem_bounce") / "data" / RECORD
    data = _with_source(json.loads(shipped.read_text()), f"fem_bounce/data/{RECORD}") if shipped.is_file() else {}
    own = Path(directory) / RECORD
    if own.is_file():
        data.update(_with_source(_read_record(own), str(own)))
    return data


def _with_source(data: dict, path: str) -> dict:
    return {name: {level: pick and {**pick, "record": path} for level, pick in levels.items()}
            for name, levels in data.items()}


def pick_for(scene: scenes.Scene, level: str, directory: Path = RECORD_DIRECTORY) -> dict:
    """The recorded pick of accuracy `level` ("5%") measured on this scene: the record whose scene_digest is the
    scene's physics_digest (its content, numerics aside, not its name), which sets numerical keys only.
    SceneError naming the scene, the level or the record file otherwise."""
    data = recorded(directory)
    digest = scenes.physics_digest(scene)
    found = {name: levels for name, levels in data.items()
             if any(pick and pick.get("scene_digest") == digest for pick in levels.values())}
    if not found:
        known = ", ".join(sorted(data)) or "none yet"
        other = (f"; the record of {scene.name!r} was measured on other values (a record applies to the scene it "
                 "was measured on, numerics aside)") if scene.name in data else ""
        raise scenes.SceneError(f"--accuracy: no recorded speed-accuracy study for {scene.name!r} as given "
                                f"(recorded: {known}){other}")
    name, choices = next(iter(found.items()))
    if level not in choices:
        raise scenes.SceneError(f"--accuracy {level}: choose one of {', '.join(choices)}")
    pick = choices[level]
    if pick is None:
        raise scenes.SceneError(f"--accuracy {level}: no recorded setting reaches it for {name}")
    physical = [key for key in pick["setting"] if not str(key).startswith("numerics.")]
    if physical:
        raise scenes.SceneError(f"{pick['record']}: the {level} pick of {name!r} sets {physical[0]}, not a numerical "
                                "setting (a record sets numerics.* only); fix or delete it")
    return pick


def _read_record(path: Path) -> dict:
    """A record as `--record` writes it: {scene: {"N%": null or {"model", "setting", "error", "quantities"}}}."""
    what = f"{path} (the accuracy record `--accuracy` reads over the shipped one)"
    try:
        data = json.loads(path.read_text())
    except (OSError, ValueError) as err:
        raise scenes.SceneError(f"{what} cannot be read: {getattr(err, 'strerror', None) or err}; fix or delete "
                                "it") from None
    whole = isinstance(data, dict) and all(
        isinstance(levels, dict) and all(pick is None or _whole_pick(pick) for pick in levels.values())
        for levels in data.values())
    if not whole:
        shape = '{scene: {"5%": {model, setting, error, quantities}}}'
        raise scenes.SceneError(f"{what} is not a record of {shape} as `study speed-accuracy --record` writes it; "
                                "fix or delete it")
    return data


def _whole_pick(pick) -> bool:
    """One recommendation as `--record` writes it: a model's name, a table of settings, the error (a fraction
    >= 0, not a bool) and the names of the quantities it was judged on (`run --accuracy` prints them)."""
    if not isinstance(pick, dict):
        return False
    error = pick.get("error")
    return (isinstance(pick.get("model"), str) and isinstance(pick.get("setting"), dict)
            and isinstance(error, (int, float)) and not isinstance(error, bool) and math.isfinite(error) and error >= 0
            and isinstance(pick.get("quantities"), list) and all(isinstance(q, str) for q in pick["quantities"]))


def record(result: dict, directory: Path = RECORD_DIRECTORY) -> Path:
    """Add one study's recommendations to `directory`/accuracy_recommendations.json (never to the installed
    package: to ship a record, copy the file into fem_bounce/data/ and commit it)."""
    path = Path(directory) / RECORD
    data = _read_record(path) if path.exists() else {}
    data[result["scene"]] = {level: pick and {**pick, "scene_digest": result["scene_digest"]}
                             for level, pick in result["recommendations"].items()}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2, sort_keys=True) + "\n")
    return path
