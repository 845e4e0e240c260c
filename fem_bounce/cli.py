"""The `fem-bounce` command.

    fem-bounce run [SCENE] [--model M] [--set key=value ...] [--out DIR] [--force] [--restart DIR]
    fem-bounce scenes                  list the shipped scenes
    fem-bounce scenes show NAME        print a scene as TOML (it runs unchanged as a scene file)
    fem-bounce restitution [--model M] coefficient of restitution against impact Stokes number
    ... [--jobs N | --executor mpi]     (restitution, study) the runs at once over N processes or an MPI pool
    fem-bounce study KIND [...]        convergence | speed-accuracy | stability | restitution | figures | band
    fem-bounce compare [SCENE] --models ode,fd,ib,...     several models on one scene: one figure, one table

Only this module, the Python API behind it (api.py, the default communicator of fem_bounce.simulate), the study
runner (studies.runner.study_runner, a study's default communicator) and the demos touch MPI.COMM_WORLD (mpi_pool
asks its size, to find the workers of an mpi4py.futures pool).  Errors a user can cause print one line (on rank 0
only under mpiexec) naming the field or path and exit with status 2; a run that ends early prints one line and
exits with 1 (diverged, or an output could not be written) or 128 + the signal (130 for SIGINT, 143 for SIGTERM)
when interrupted.  What the libraries print (ffcx's compiler lines and ResourceWarnings on a form's first
compile) goes to the run directory's run.log, not the terminal (`fem-bounce run --verbose`: to both;
fem_bounce.library_log).

A parser and printer over the library below it: the API (api.py), the run (run.run_logged, run.restart_target)
and the studies.  The modules that import PETSc (run.py and the studies) are imported inside the commands, once
main has given PETSc COMM_SELF under an mpi4py.futures pool (fem_bounce.mpi_pool).
"""
from __future__ import annotations

import argparse
import contextlib
import math
import os
import shlex
import signal
import sys
import warnings
from pathlib import Path

from . import api, library_log, models, output
from . import scene as scenes
from .errors import RunFailed, RunInterrupted, RunnerError
from .library_log import LIBRARY_LOG, say
from .mpi_pool import petsc_on_self, under_mpi_futures

DEFAULT_SCENE = "li2011-case3"


def _parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="fem-bounce", description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)

    run = sub.add_parser("run", help="simulate one scene with one model")
    run.add_argument("scene", nargs="?", default=None, help=f"preset name or TOML file (default {DEFAULT_SCENE})")
    run.add_argument("--model", default=None, help=f"one of {', '.join(models.MODELS)} (default: the speed-accuracy "
                                                  "front's pick for the scene, docs/usage.md)")
    run.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                     help="override a scene value, e.g. --set sphere.density=8000 (repeatable)")
    run.add_argument("--out", default=None, help="run directory (default runs/SCENE-MODEL[-N])")
    run.add_argument("--force", action="store_true",
                     help="replace an existing run directory (only a run directory: one holding .fem-bounce-run)")
    run.add_argument("--restart", type=Path, default=None, metavar="DIR",
                     help="continue the killed run in DIR from its last checkpoint")
    run.add_argument("--quiet", action="store_true", help="no progress line")
    run.add_argument("--no-plots", action="store_true",
                     help="draw no figures (about 1 s less; `python -m fem_bounce.plots DIR` draws them later)")
    run.add_argument("--verbose", action="store_true",
                     help="show what the libraries say (the form compiler's log, their warnings) on the terminal "
                          "too, not only in the run directory's run.log")
    run.add_argument("--accuracy", default=None, metavar="PERCENT",
                     help="pick the cheapest model and resolution that the recorded study says reaches this "
                          "error on the scene's quantities (1%%, 2%%, 5%% or 10%%)")

    cmp_ = sub.add_parser("compare", help="run several models on one scene; one figure and one table")
    cmp_.add_argument("scene", nargs="?", default=None, help=f"preset name or TOML file (default {DEFAULT_SCENE})")
    cmp_.add_argument("--models", default="ode,fd,ib", help="comma-separated models (default ode,fd,ib)")
    cmp_.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                      help="override a scene value for every model (repeatable)")
    cmp_.add_argument("--out", default=None, help="output directory (default runs/compare-SCENE[-N])")
    cmp_.add_argument("--force", action="store_true", help="replace an existing output directory")
    cmp_.add_argument("--quiet", action="store_true", help="no progress lines")
    cmp_.add_argument("--no-plots", action="store_true", help="draw no figures: comparison.csv and the runs only")

    show = sub.add_parser("scenes", help="list the shipped scenes, or show one as TOML")
    show.add_argument("action", nargs="?", choices=["list", "show"], default="list")
    show.add_argument("name", nargs="?")

    rest = sub.add_parser("restitution", help="e against impact Stokes number over the Table 3 sets (Fig. 13-14)")
    rest.add_argument("--model", default="ode", help="any model (default ode)")
    rest.add_argument("--points", type=int, default=None,
                      help="Stokes numbers, log-spaced over 1-1000 (default 40 for ode, 12 otherwise)")
    rest.add_argument("--st-min", type=float, default=1.0)
    rest.add_argument("--st-max", type=float, default=1000.0)
    rest.add_argument("--out", default=None, help="directory for CSV and PNG (default results/restitution-MODEL)")
    rest.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                      help="override a value of every scene the sweep runs")
    rest.add_argument("--band", action="store_true",
                      help="e(St) with its 5-95 %% band: --samples runs per Stokes number over the uncertain "
                           "properties (the default ranges, --vary)")
    _band_options(rest, samples=32)
    _parallel_options(rest)
    study = sub.add_parser("study", help="studies that run many simulations (cached, resumable)")
    kinds = study.add_subparsers(dest="kind", required=True)
    conv = kinds.add_parser("convergence", help="resolution and time-step ladders, observed orders")
    conv.add_argument("scene")
    conv.add_argument("--model", required=True)
    conv.add_argument("--levels", default=None, help="comma-separated resolutions (default: the model's ladder)")
    conv.add_argument("--cfls", default=None, help="comma-separated CFL numbers for the time-step ladder")
    speed = kinds.add_parser("speed-accuracy", help="wall time against error for several models")
    speed.add_argument("scene")
    speed.add_argument("--models", default="ode", help="comma-separated, e.g. ode,fd,ib")
    speed.add_argument("--levels", action="append", default=[], metavar="MODEL=V1,V2,...",
                       help="resolutions of one model (default: its ladder); repeat per model; V@F runs the "
                            "resolution V with F times the time step, e.g. ale=8,8@0.5,12,16")
    speed.add_argument("--reference-step", type=float, default=None, metavar="FACTOR",
                       help="the reference run: the finest level of the highest-fidelity model again, with FACTOR "
                            "times its time step (default 0.25; 1: the finest level as it is)")
    speed.add_argument("--record", action="store_true",
                       help="store the recommendations in --out (default results/) for `run --accuracy`, which reads "
                            "results/accuracy_recommendations.json over the record shipped with the package")
    stab = kinds.add_parser("stability", help="density ratio, time step, contact resolution and delta_sl sweeps")
    stab.add_argument("scene", nargs="?", default=DEFAULT_SCENE)
    stab.add_argument("--model", required=True)
    stab.add_argument("--sweeps", default=None,
                      help="comma-separated subset of density_ratio,cfl,cells_per_gap,delta_sl")
    figs = kinds.add_parser("figures", help="the paper's Fig. 9-12 from a model")
    figs.add_argument("--model", required=True)
    tilt = kinds.add_parser("oblique", help="oblique impacts: psi_out(psi_in), e_n, e_t and spin over incidence angles")
    tilt.add_argument("scene", help="a scene whose sphere is launched at the wall, e.g. foerster1994-glass")
    tilt.add_argument("--angles", default=None, help="comma-separated degrees from the normal (default: 40, 2-80)")
    tilt.add_argument("--model", default="ode", choices=["ode", "fd3d"],
                      help="the model that runs the sweep: ode (default; under a second a run) or fd3d (the resolved "
                           "3-D flow; minutes a run)")
    bands = kinds.add_parser("band", help="predictions with bands: percentiles and Sobol' indices over the "
                                          "uncertain properties")
    bands.add_argument("scene", help="preset name or TOML file (its [uncertain] table, if any, gives the ranges)")
    bands.add_argument("--model", default="ode", help="any model (default ode)")
    _band_options(bands, samples=64)
    for kind in (conv, speed, stab, figs, tilt, bands):
        kind.add_argument("--out", default=None, help="study directory (default results/study-...)")
        kind.add_argument("--set", dest="overrides", action="append", default=[], metavar="KEY=VALUE",
                          help="override a value of every scene the study runs")
        _parallel_options(kind)
    return parser


def _band_options(parser: argparse.ArgumentParser, samples: int) -> None:
    parser.add_argument("--samples", type=int, default=samples,
                        help=f"runs of the design (default {samples}; a power of two for --design sobol)")
    parser.add_argument("--vary", action="append", default=[], metavar="KEY=RANGE",
                        help="an uncertain setting: LOW:HIGH (uniform), LOW:HIGH:log, MEAN~SD (normal), +-P%% or "
                             "~P%% of the scene's value; adds to or replaces the defaults (repeatable)")
    parser.add_argument("--no-defaults", action="store_true",
                        help="vary only the --vary settings, not the packaged default ranges")
    parser.add_argument("--design", default="sobol", choices=["sobol", "lhs", "saltelli"],
                        help="sobol (scrambled Sobol' points, default), lhs (Latin hypercube) or saltelli (Saltelli's "
                             "scheme: first-order and total indices, N (d + 2) runs)")
    parser.add_argument("--seed", type=int, default=0, help="the design's seed (default 0): the same seed, the same "
                                                            "samples")


def _parallel_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--jobs", type=int, default=1, metavar="N",
                        help="runs at once in N local processes, each serial (default 1: one run at a time, "
                             "on every rank under mpiexec)")
    parser.add_argument("--executor", choices=["local", "mpi"], default="local",
                        help="mpi: the runs go to the workers of `mpiexec -n K python -m mpi4py.futures -m "
                             "fem_bounce ...` (K - 1 of them); see docs/usage.md, Studies")


def _unused_directory(comm, base: Path) -> Path:
    """The default --out: base, or base-2, base-3, ... (output.unused_directory), chosen on rank 0 for all."""
    return comm.bcast(output.unused_directory(base) if comm.rank == 0 else None, root=0)


def _cmd_run(args) -> int:
    from mpi4py import MPI

    from . import run

    comm = MPI.COMM_WORLD
    if args.restart is not None:
        if args.scene or args.overrides:
            raise scenes.SceneError("--restart takes the scene from DIR/scene.toml; drop SCENE and --set")
        if args.out is not None:
            raise output.OutputError("--restart continues the run in DIR and writes nowhere else: drop --out "
                                     "(copy DIR first to keep the original)")
        if args.force:
            raise output.OutputError("--force does not apply to --restart: nothing is replaced")
        if args.accuracy is not None:
            raise scenes.SceneError("--accuracy does not apply to --restart: the scene is DIR/scene.toml")
        scene, model = run.restart_target(args.restart, args.model)
        out, chosen = args.restart, None
    else:
        scene = api.load(args.scene or DEFAULT_SCENE, args.overrides)
        model, chosen = args.model, None
        if args.accuracy is not None:
            scene, model = _scene_for_accuracy(scene, args.accuracy, args.model, args.overrides)
        elif model is None:  # the speed-accuracy front's pick for the scene, and the line that says why
            model, chosen = models.choose(scene)
        models.get(model)  # fail early on an unknown or missing model
        out = output.out_path(args.out) or _unused_directory(comm, Path("runs") / f"{scene.name}-{model}")
    _route_warnings()
    LIBRARY_LOG.verbose = args.verbose
    command = shlex.join(["fem-bounce", *sys.argv[1:]])

    def start_line() -> None:  # once nothing can refuse the run: a refusal prints its one line alone
        if chosen:  # no --model: which model the run took and why (models.choose)
            print(f"fem-bounce: {chosen}", file=sys.stderr)
        print(f"fem-bounce: {scene.name} with the {model} model on {comm.size} rank(s) -> {out}", file=sys.stderr)

    summary = run.run_logged(scene, model, comm, out, force=args.force, restart=args.restart is not None,
                             command=command, progress=not args.quiet, plots=not args.no_plots,
                             on_start=start_line)
    if comm.rank == 0:
        _print_records(summary)
    return 0


def _cmd_compare(args) -> int:
    from mpi4py import MPI

    from .studies import compare

    comm = MPI.COMM_WORLD
    names = models.model_list(args.models)
    _route_warnings()
    scene = api.load(args.scene or DEFAULT_SCENE, args.overrides)
    out = output.out_path(args.out) or _unused_directory(comm, Path("runs") / f"compare-{scene.name}")
    command = shlex.join(["fem-bounce", *sys.argv[1:]])
    rows = api.compare(scene, names, out, force=args.force, progress=not args.quiet, plots=not args.no_plots,
                       comm=comm, command=command)
    if comm.rank == 0:
        print(compare.format_table(rows))
        print(f"-> {out}/comparison.csv" + ("" if args.no_plots else f", {out}/comparison.png"))
    return 0 if all(r["status"] == "completed" for r in rows if r["model"] != "measured") else 1


def _scene_for_accuracy(scene: scenes.Scene, accuracy: str, requested: str | None, overrides: list[str]):
    """The scene with the recorded setting that reaches `accuracy` on it (speed_accuracy.pick_for), and its
    model; a --set of a key the record sets is refused (the recorded error would not hold)."""
    from .studies import speed_accuracy

    key = f"{accuracy.strip().rstrip('%')}%"
    pick = speed_accuracy.pick_for(scene, key)
    if requested and requested != pick["model"]:
        raise models.ModelError(f"--accuracy {accuracy} picks the {pick['model']} model, not {requested}")
    given = dict(scenes.parse_override(text) for text in overrides)
    for name, value in pick["setting"].items():
        if name in given:
            raise scenes.SceneError(f"--set {name}={given[name]} and --accuracy {key} (which sets {name} = {value}, "
                                    f"from {pick['record']}) disagree: give one of them")
    try:
        chosen = scene.replace(**pick["setting"])
    except scenes.SceneError as err:
        raise scenes.SceneError(f"{pick['record']}: the {key} pick for {scene.name!r}: {err}; fix or delete it") \
            from None
    say(f"--accuracy {key}: {pick['model']} with {pick['setting']} "
        f"(recorded error {pick['error']:.2%} on {', '.join(pick['quantities'])})")
    return chosen, pick["model"]


def _number(value: float, decimals: int = 1) -> str:
    """A dimensionless group for a person: fixed decimals, or three digits and an exponent when huge."""
    return f"{value:.{decimals}f}" if abs(value) < 1e6 else f"{value:.3g}"


def _print_records(summary: dict) -> None:
    print(f"{summary['status']} in {summary['wall_time_s']:.2f} s, {summary['steps']} steps "
          f"(stop: {summary.get('stop_reason')})")
    diameter = summary["scene"]["sphere"]["diameter"]
    if "collisions" in summary:  # a pair
        _print_collisions(summary)
        return
    final = summary["final"]
    if not summary["impacts"] and final.get("in_contact"):
        print(f"impact in progress: the run ended at t = {final['time']:.4g} s in the contact, before the minimum "
              f"gap (gap {final['gap'] / diameter:.4g} D, {-final['velocity']:.4g} m/s toward the wall)")
    elif not summary["impacts"] and not summary["scene"]["wall"].get("present", True):
        travel = (summary["scene"]["initial_gap"] - final["gap"]) / diameter  # the gap is the height above z = 0
        print(f"no wall: the sphere ended {abs(travel):.4g} D {'below' if travel >= 0 else 'above'} its start at "
              f"t = {final['time']:.4g} s")
    elif not summary["impacts"]:
        print(f"no impact: the sphere ended {final['gap'] / diameter:.4g} D above the wall at t = "
              f"{final['time']:.4g} s")
    for k, (impact, rebound) in enumerate(zip(summary["impacts"], summary["rebounds"] + [None] * 99), 1):
        line = (f"impact {k}: t = {impact['time']:.4f} s  V_i = {impact['impact_speed']:.4f} m/s  "
                f"Re = {_number(impact['Re'])}  St = {_number(impact['St'])}  min gap/D = "
                f"{impact['min_gap'] / diameter:.4f}")
        if rebound is not None:
            line += f"  e = {rebound['restitution']:.3f}"
            if rebound["apex_gap"] is not None:
                line += f"  apex gap = {rebound['apex_gap'] * 1e3:.3f} mm"
        print(line)
    for k, oblique in enumerate(summary.get("oblique_impacts", []), 1):
        seen = oblique["outer"] or oblique["contact"]  # at delta_sl D, or at the contact when it never left it
        e_t = seen["tangential_restitution"]
        print(f"  oblique {k} ({'at delta_sl D' if oblique['outer'] else 'at the contact'}): incidence "
              f"{seen['incidence_deg']:.1f} deg  psi_in = {seen['psi_in']:.3f}  psi_out = {seen['psi_out']:.3f}  "
              f"e_n = {seen['normal_restitution']:.3f}  e_t = {'-' if e_t is None else f'{e_t:.3f}'}  "
              f"mu_eff = {seen['effective_friction']:.3f}  spin after = {seen['spin_out']:.4g} 1/s")
    for k, impact in enumerate(summary["impacts"], 1):  # the energy audit along the wall (fem_bounce.losses)
        along = (impact.get("losses") or {}).get("tangential")
        if along:
            shares = ", ".join(f"{name.replace('_', ' ')} {100 * sum(values):+.2f} %"
                               for name, values in along["share"].items())
            print(f"  energy along the wall {k}: {along['energy_in']:.4g} J in, "
                  f"{100 * (along['kinetic']['end'] / along['energy_in'] - 1):+.2f} % over the bounce: {shares} "
                  f"(residual {along['imbalance']:.1e})")


def _print_collisions(summary: dict) -> None:
    """A pair's collisions, pair and wall, in time order (relative impact speed, binary St, e, or that the run
    ended inside the collision)."""
    final = summary["final"]
    if not summary["collisions"]:
        print("no collision: the pair gap ended at "
              f"{final['gap'][1] - final['gap'][0] - summary['scene']['sphere']['diameter']:.4g} m "
              f"at t = {final['time']:.4g} s")
    last = {c["kind"]: c for c in summary["collisions"]}  # each contact's latest collision
    at_rest = "came to rest" in (summary.get("stop_reason") or "")
    for k, c in enumerate(summary["collisions"], 1):
        line = (f"collision {k} ({c['kind']}): t = {c['time']:.4f} s  V_rel = {c['impact_speed']:.4f} m/s  "
                f"Re = {_number(c['Re'])}  St = {_number(c['St'])}  min gap = {c['min_gap'] * 1e3:.4g} mm")
        # no apex (nor separation) recorded after a contact's last collision: the run ended before one, unless the
        # bodies came to rest there; a wall collision's record then has no e, a pair's an e = 0 that was not measured
        unfinished = last[c["kind"]] is c and c.get("apex_time") is None and not at_rest
        if "restitution" not in c or unfinished:
            line += f"  e: in progress (the run ended at t = {final['time']:.4g} s, before the rebound was complete)"
        else:
            line += f"  e = {c['restitution']:.3f}"
        print(line)


def _cmd_scenes(args) -> int:
    if args.action == "show":
        if not args.name:
            raise scenes.SceneError("scenes show needs a NAME (see `fem-bounce scenes`)")
        text = scenes.dumps(scenes.load(args.name))
        with contextlib.suppress(AttributeError, ValueError):  # a stream whose encoding cannot be set
            sys.stdout.reconfigure(encoding="utf-8")  # TOML is UTF-8, whatever the locale says (C: ASCII)
        print(text, end="")
        return 0
    for name in scenes.preset_names():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            print(f"{name:34s} {scenes.load(name).description}")
    return 0


def _cmd_restitution(args) -> int:
    from mpi4py import MPI

    if args.band:
        return _restitution_band(args)
    out = Path("results") / f"restitution-{args.model}" if args.out is None else output.out_path(args.out)
    rows = api.restitution(args.model, points=args.points, st_range=(args.st_min, args.st_max),
                           overrides=args.overrides, out=out, jobs=args.jobs, executor=args.executor)
    found = rows.summary
    if (MPI.COMM_SELF if args.executor == "mpi" else MPI.COMM_WORLD).rank == 0:
        print(f"{_runs(len(rows))} -> {out}/restitution.csv, {out}/restitution.json, {out}/restitution.png")
        for station, found_there in (("at 0.2 D", found), ("at the collision (2 ms means)", found.get("two_ms")),
                                     ("at the camera's frames (0.25 ms)", found.get("frame")),
                                     ("at the peaks", found.get("peak"))):
            if not found_there or found_there["rms_to_fit"] is None:
                continue
            stuck, first = found_there["critical_St"]
            critical = (f"; no rebound up to St {stuck:.3g}" if stuck else "") + (
                f", first rebound at St {first:.3g}" if first else "")
            covered = found_there["covered_St"]
            print(f"e {station} against the Legendre et al. (2006) fit over St {covered[0]:.3g}-"
                  f"{covered[1]:.3g}: rms {found_there['rms_to_fit']:.3f}, largest "
                  f"{found_there['max_abs_to_fit']:.3f} ({_runs(found_there['compared_runs'])}){critical}; e = "
                  f"{found_there['e_at_largest_St']:.3f} at St {found_there['largest_St']:.4g}")
    if found["failed"]:
        say(f"error: {len(found['failed'])} of {len(rows)} runs failed (marked in restitution.csv and the figure, "
            f"not counted as e = 0): " + "; ".join(found["failed"][:3]) + (" ..." if len(found["failed"]) > 3 else ""))
        return 1
    return 0


def _restitution_band(args) -> int:
    from mpi4py import MPI

    out = Path("results") / f"restitution-band-{args.model}" if args.out is None else output.out_path(args.out)
    table = api.restitution(args.model, points=args.points, st_range=(args.st_min, args.st_max),
                            overrides=args.overrides, out=out, jobs=args.jobs, executor=args.executor,
                            band=args.samples, vary=args.vary, defaults=not args.no_defaults, design=args.design,
                            seed=args.seed)
    found = table.summary
    if (MPI.COMM_SELF if args.executor == "mpi" else MPI.COMM_WORLD).rank == 0:
        print(f"{len(found['stations'])} Stokes numbers x {found['samples']} samples -> {out}/band.json, "
              f"{out}/restitution_band.csv, {out}/samples.csv, {out}/restitution_band.png")
        inside = ", ".join(f"{x:.3g}" for x in found["fit_inside_St"]) or "none"
        print(f"the experiments' fit inside the 5-95 % band at St {inside}; outside at "
              f"{len(found['fit_outside_St'])} stations")
        if found["leading_below_St"]:
            print(f"below St {found['below_St']:g} the band's leading property is {found['leading_below_St']} "
                  f"(mean first-order index {found['mean_S1_below_St'][found['leading_below_St']]:.2f})")
    failed = sum(s["failed"] for s in found["stations"])
    return 1 if failed else 0


def _runs(count: int) -> str:
    return f"{count} run" if count == 1 else f"{count} runs"


def _cmd_study(args) -> int:
    from .studies.runner import study_runner

    comm, runner = study_runner(args.jobs, args.executor)
    with runner:  # its worker processes end with the study
        return _study(args, comm, runner)


def _study(args, comm, runner) -> int:
    from . import studies

    changes = dict(scenes.parse_override(text) for text in args.overrides)
    model_names = models.model_list(args.models if args.kind == "speed-accuracy" else [args.model])
    _route_warnings()
    scene_name = getattr(args, "scene", None)
    default_out = "-".join(["study", args.kind, *([scene_name] if scene_name else []), *model_names])
    out = output.out_path(args.out) or Path("results") / default_out

    def numbers(text: str | None, option: str = "--levels") -> tuple | None:
        try:
            values = tuple(float(x) for x in text.split(",")) if text else None
        except ValueError:
            values = (math.nan,)
        if values is not None and not all(math.isfinite(v) and v > 0.0 for v in values):
            raise scenes.SceneError(f"{option} {text!r}: expected comma-separated positive numbers, e.g. 8,12,16")
        return values

    if args.kind == "convergence":
        studies.convergence.run(scenes.load(args.scene, changes), args.model, comm, out, numbers(args.levels),
                                numbers(args.cfls, "--cfls"), runner=runner)
    elif args.kind == "speed-accuracy":
        levels = {}
        for text in args.levels:
            name = text.partition("=")[0]
            if name not in model_names:
                raise scenes.SceneError(f"--levels {text!r}: expected MODEL=V1,V2,... with MODEL one of {args.models}")
            if name in levels:
                raise scenes.SceneError(f"--levels {text!r}: the {name} model's levels are given twice; give them "
                                        f"once, as --levels {name}=V1,V2,...")
            levels[name] = _speed_levels(text, name)
        reference_step = studies.speed_accuracy.REFERENCE_STEP if args.reference_step is None else args.reference_step
        if not (math.isfinite(reference_step) and 0.0 < reference_step <= 1.0):
            raise scenes.SceneError(f"--reference-step {reference_step:g} is out of range: allowed in (0, 1] "
                                    "(the reference run's time step as a fraction of its model's)")
        result = studies.speed_accuracy.run(scenes.load(args.scene, changes), model_names, comm, out, levels,
                                            runner=runner, reference_step=reference_step)
        if args.record and comm.rank == 0:
            recorded = studies.speed_accuracy.record(result,
                                                     out if args.out else studies.speed_accuracy.RECORD_DIRECTORY)
            print(f"recommendations recorded in {recorded} (`run --accuracy` reads "
                  f"{studies.speed_accuracy.RECORD_DIRECTORY / recorded.name})")
    elif args.kind == "stability":
        sweeps = _stability_sweeps(args.sweeps, args.model)
        studies.stability.run(scenes.load(args.scene, {"run.bounces": 1, **changes}), args.model, comm, out, sweeps,
                              runner=runner)
    elif args.kind == "oblique":
        from .studies import oblique

        angles = oblique.ANGLES if args.angles is None else numbers(args.angles, "--angles") or ()
        oblique.run(scenes.load(args.scene, changes), comm, out, angles, runner=runner, model=args.model)
    elif args.kind == "band":
        from . import uncertain
        from .studies import band

        scene = scenes.load(args.scene, changes)
        ranges = uncertain.ranges_for(scene, args.vary, uncertain.scene_table(args.scene), not args.no_defaults,
                                      where=f"{args.scene} [uncertain]")
        result, _ = band.run(scene, args.model, comm, out, ranges, args.samples, args.design, args.seed,
                             runner=runner)
        if comm.rank == 0:
            print(band.format_table(result))
    else:
        studies.figures.run(args.model, comm, out, overrides=changes, runner=runner)
    if comm.rank == 0:
        print(f"study written to {out}")
    return 0


def _speed_levels(text: str, model: str) -> list:
    """--levels MODEL=V1,V2@F,...: the speed-accuracy study's levels of one model (V@F: F times the step)."""
    from .studies.speed_accuracy import Level

    values = text.partition("=")[2]
    try:
        found = [Level.parse(value) for value in values.split(",")] if values else []
    except ValueError:
        found = []
    if not found or not all(math.isfinite(level.resolution) and level.resolution > 0.0
                            and math.isfinite(level.step_factor) and level.step_factor > 0.0 for level in found):
        raise scenes.SceneError(f"--levels {text!r}: expected MODEL=V1,V2,... with positive numbers, each "
                                "optionally V@F for F times the time step, e.g. ale=8,8@0.5,12")
    from .studies.common import LADDERS

    if LADDERS[model].time_step_key is None and any(lv.step_factor != 1.0 for lv in found):
        raise scenes.SceneError(f"--levels {text!r}: the {model} model has no time-step setting (its tolerance "
                                "sets its steps): drop @F")
    return found


def _stability_sweeps(text: str | None, model: str) -> dict:
    """The sweeps named by --sweeps (all that apply to the model when not given); unknown names refused."""
    from .studies import stability

    usable = stability.applicable(model)
    if not text:
        return {k: v for k, v in stability.SWEEPS.items() if k in usable}
    chosen = [name.strip() for name in text.split(",") if name.strip()]
    for name in chosen:
        if name not in stability.SWEEPS:
            raise scenes.SceneError(f"--sweeps: unknown sweep {name!r}: choose from {', '.join(stability.SWEEPS)}")
        if name not in usable:
            raise scenes.SceneError(f"--sweeps: {name} does not apply to the {model} model "
                                    f"(it has only {', '.join(usable)})")
    if not chosen:
        raise scenes.SceneError(f"--sweeps {text!r}: name at least one of {', '.join(usable)}")
    return {k: v for k, v in stability.SWEEPS.items() if k in chosen}


# Where a warning from these packages starts, it is theirs, not the user's business (parts of its file's path).
_LIBRARIES = {"ffcx", "cffi", "dolfinx", "ufl", "setuptools", "distutils"}


_SHOWN: set[str] = set()  # the warnings printed by this command: each once, however often it recurs


def _show_warning(message, category, filename, lineno, file=None, line=None) -> None:
    """The package's warnings as one line each, each once; a library's (ffcx's unclosed files...) into run.log."""
    if issubclass(category, ResourceWarning) or not _LIBRARIES.isdisjoint(Path(filename).parts):
        LIBRARY_LOG.add_warning(message, category, filename, lineno)
    elif str(message) not in _SHOWN:
        _SHOWN.add(str(message))
        say(f"warning: {message}")


def _route_warnings() -> None:
    """Warnings through _show_warning.  Again after importing a model: ffcx sends warnings to logging."""
    warnings.showwarning = _show_warning


def main(argv: list[str] | None = None) -> int:
    from mpi4py import MPI

    library_log.RANK = MPI.COMM_WORLD.rank
    try:
        os.getcwd()  # PETSc asks for it as it starts, and fails with an error text of its own
    except OSError as err:
        say(f"error: the working directory cannot be used ({err.strerror or err}: deleted or moved away?): cd into "
            "an existing directory and run again")
        return 2
    if under_mpi_futures():
        petsc_on_self()  # rank 0 of an mpi4py.futures pool: the workers never join PETSc's COMM_WORLD
    # PETSc starts here, after the line above, and before Interrupts installs its handlers (PETSc's own abort on
    # SIGTERM with MPI_Abort)
    from .run import Interrupts, signal_name

    if list(sys.argv[1:] if argv is None else argv)[:2] == ["study", "restitution"]:  # the sweep's old spelling
        say("error: `fem-bounce study restitution` is now `fem-bounce restitution` (the same sweep, cached and "
            "resumable: --model, --points, --st-min, --st-max, --out, --set, --jobs, --executor)")
        return 2
    args = _parser().parse_args(argv)
    command = {"run": _cmd_run, "scenes": _cmd_scenes, "restitution": _cmd_restitution,
               "study": _cmd_study, "compare": _cmd_compare}[args.command]
    graceful = args.command != "scenes"  # runs stop between two steps; listing scenes stops at once
    _SHOWN.clear()
    with warnings.catch_warnings(), library_log.library_output(), library_log.quiet_on_a_closed_pipe(), \
            (Interrupts(announce=library_log.RANK == 0) if graceful else contextlib.nullcontext()):
        warnings.simplefilter("always")
        _route_warnings()
        try:
            return command(args)
        except (scenes.SceneError, models.ModelError, output.OutputError, RunnerError) as err:
            say(f"error: {err}")
            return 2
        except RunInterrupted as err:
            say(str(err))
            return 128 + err.signum
        except RunFailed as err:
            say(str(err) if str(err).startswith("diverged") else f"error: {err}")
            return 1
        except KeyboardInterrupt as err:
            signum = getattr(err, "signum", signal.SIGINT)
            say(f"interrupted by {signal_name(signum)}")
            return 128 + signum
        except OSError as err:  # the terminal's or a redirection's output failed (a full disk, /dev/full, ...)
            sys.stdout = open(os.devnull, "w")  # so that the interpreter's last flush does not fail again
            say(f"error: cannot write the output: {err.strerror or err}")
            return 1
