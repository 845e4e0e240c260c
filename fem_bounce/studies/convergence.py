"""Mesh and time-step convergence of one model on one scene.

    mpiexec -n 2 fem-bounce study convergence li2011-case3 --model fd
    fem-bounce study convergence sphere-drag-re100 --model fd --levels 8,12,16,24

A ladder of resolutions at the default time step, and a ladder of time steps (CFL) at the default
resolution (none where the run takes no steps: held spheres the ale model solves steady, models/unread.py);
errors of the scene's quantities (impact speed and first rebound apex, Cd, or peak settling speed) against the
finest run, observed orders between levels, and Richardson extrapolation from the three finest levels where they
converge monotonically.  Writes convergence.csv, convergence.json and convergence.png into the study directory.
"""
from __future__ import annotations

from pathlib import Path

from .. import scene as scenes
from ..models.unread import refuse_unread, unread
from .common import CFL_LADDER, LADDERS, StudyDirectory, measure_all, observed_orders, primary, richardson
from .runner import Runner


def run(scene: scenes.Scene, model: str, comm, out: Path, levels: tuple | None = None,
        cfls: tuple | None = None, runner: Runner | None = None) -> dict:
    ladder = LADDERS[model]
    if cfls and ladder.time_step_key is None:
        raise scenes.SceneError(f"--cfls {','.join(f'{c:g}' for c in cfls)!r}: the {model} model has no time-step "
                                "setting (its tolerance sets its steps; --levels refines it): drop --cfls")
    timed = ladder.time_step_key and ladder.time_step_key.rsplit(".", 1)[1] not in unread(scene, model)
    if cfls and ladder.time_step_key and not timed:  # no steps (held spheres solved steady): say why, up front
        refuse_unread(scene.replace(**ladder.time_step(scene, cfls[0])), model)
    levels = tuple(levels or ladder.values)
    study = StudyDirectory(out, comm)
    names = primary(scene)
    plan = [("space", value, ladder.spacing(value), scene.replace(**{ladder.key: value}),
             f"{ladder.key} = {value:g}") for value in levels]
    if timed:
        plan += [("time", cfl, cfl, scene.replace(**ladder.time_step(scene, cfl)), f"{ladder.time_step_key} = {cfl:g}")
                 for cfl in cfls or CFL_LADDER]
    measured = measure_all([(trial, model, label) for *_, trial, label in plan], study, runner)
    rows = [{"ladder": which, "value": value, "spacing": spacing, **row}
            for (which, value, spacing, _, _), row in zip(plan, measured)]
    analysis = {}
    for which in ("space", "time"):
        mine = [r for r in rows if r["ladder"] == which]
        for name in names:
            usable = [r for r in mine if r.get(name) is not None]
            if len(usable) < 3:
                continue
            spacing = [r["spacing"] for r in usable]
            values = [r[name] for r in usable]
            finest = values[-1]
            extrapolated = richardson(spacing, values)
            analysis[f"{which}:{name}"] = {
                "spacing": spacing, "values": values,
                "errors_vs_finest": [abs(v / finest - 1.0) for v in values[:-1]],
                "observed_orders": observed_orders(spacing, values),
                "richardson_order": extrapolated[0] if extrapolated else None,
                "richardson_value": extrapolated[1] if extrapolated else None,
            }
    study.write_csv("convergence.csv", rows)
    study.write_json("convergence.json", {"scene": scene.name, "model": model, "key": ladder.key,
                                          "analysis": analysis, "rows": rows})
    if comm.rank == 0:
        figure(analysis, scene.name, model, ladder.key, out / "convergence.png")
        for key, a in analysis.items():
            orders = ", ".join("-" if p is None else f"{p:.2f}" for p in a["observed_orders"])
            rich = (f"; Richardson order {a['richardson_order']:.2f}, extrapolated {a['richardson_value']:.6g}"
                    if a["richardson_order"] else "")
            study.log(f"{key}: errors vs finest "
                      + ", ".join(f"{e:.2%}" for e in a["errors_vs_finest"]) + f"; observed orders {orders}{rich}")
    return analysis


def figure(analysis: dict, scene_name: str, model: str, key: str, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2))
    for ax, which, label in ((axes[0], "space", f"1 / {key.split('.')[-1]}"), (axes[1], "time", "CFL")):
        for k, (name, a) in enumerate((n.split(":", 1)[1], a) for n, a in analysis.items() if n.startswith(which)):
            errors = a["errors_vs_finest"]
            spacing = a["spacing"][: len(errors)]
            keep = [(h, e) for h, e in zip(spacing, errors) if e > 0]
            if not keep:
                continue
            hs, es = zip(*keep)
            ax.loglog(hs, es, "o-", color=f"C{k}", label=name)
            if a["richardson_order"]:
                ax.text(hs[-1], es[-1], f"  p = {a['richardson_order']:.2f}", color=f"C{k}", fontsize=8)
        ax.set_xlabel(label)
        ax.set_ylabel("relative error against the finest run")
        ax.set_title("space" if which == "space" else "time step", fontsize=9)
        ax.grid(True, which="both", alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
    fig.suptitle(f"{scene_name}: {model} model convergence", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
