"""fem_bounce from Python: the command line's scenes, runs and studies as functions.

    import fem_bounce as fb

    scene = fb.load("li2011-case3")                               # a preset or a TOML file
    softer = scene.replace(**{"contact.dry_restitution": 0.9})    # a variant: the checks of --set
    result = fb.simulate(scene, "ode")                            # in memory: nothing written
    result.impacts[0].impact_speed, result.trajectory["velocity"]
    fine = fb.simulate(scene, "ale", out="runs/case3-ale", cells_per_diameter=8)   # a run directory
    table = fb.restitution("ode", points=6)                       # e against St, as `fem-bounce restitution`

Each function is what the command of the same name runs (fem_bounce.cli calls them or shares their
parts, which live below both: run.run_logged, run.restart_target, output.out_path, models.model_list,
studies.runner.study_runner): the same checks, the same one-line errors (fem_bounce.Error and its kinds), the
same run directory, the same study cache.  MPI is optional: under `mpiexec` the runs use MPI.COMM_WORLD as the
command line does, serially they use the one process.

`import fem_bounce` imports neither PETSc nor matplotlib: the run and the studies (which import PETSc) are
imported when a function first needs them, because under `python -m mpi4py.futures` PETSc must be given
COMM_SELF before it starts (fem_bounce.mpi_pool), and plots.py selects matplotlib's Agg backend, which must
not replace a notebook's own on import.
"""
from __future__ import annotations

import contextlib
import dataclasses
import functools
import math
import numbers
import shutil
import sys
import tempfile
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np

from . import models as _models
from . import output as _output
from . import scene as _scenes
# the records and errors of the API, re-exported by fem_bounce/__init__.py
from .bounces import Impact, Rebound
from .errors import Error, RunDiverged, RunFailed, RunInterrupted, RunnerError  # noqa: F401
from .output import CheckpointError, OutputError  # noqa: F401
from .scene import Scene, SceneError

ModelError = _models.ModelError


def _public(function):
    """A public function that leaves the matplotlib backend the caller chose (a notebook's inline one) as it
    was: the package draws its files with the Agg backend (plots.py and the studies select it), which would
    otherwise stay."""

    @functools.wraps(function)
    def wrapper(*args, **kwargs):
        if "matplotlib.pyplot" not in sys.modules:  # the caller has chosen none
            return function(*args, **kwargs)
        import matplotlib
        import matplotlib.pyplot as plt

        chosen = matplotlib.get_backend()
        try:
            return function(*args, **kwargs)
        finally:
            if matplotlib.get_backend() != chosen:
                plt.switch_backend(chosen)

    return wrapper


# -- scenes -------------------------------------------------------------------------------------


def _overrides(changes: Mapping[str, Any] | Iterable[str] | str | None) -> dict[str, Any]:
    """{dotted key: value}, from a mapping or from "key=value" texts read as `--set` reads them."""
    if changes is None:
        return {}
    if isinstance(changes, Mapping):
        wrong = next((key for key in changes if not isinstance(key, str)), None)
        if wrong is not None:
            raise SceneError(f"overrides: the key {wrong!r} is not a dotted scene key such as 'sphere.density'")
        return dict(changes)
    if isinstance(changes, str):
        changes = [changes]
    if not isinstance(changes, Iterable):
        raise SceneError(f"overrides = {changes!r} must be a mapping {{'sphere.density': 8000.0}} or texts "
                         "['sphere.density=8000']")
    return dict(_scenes.parse_override(text) for text in changes)


def _scene(scene: Scene | str | Path) -> Scene:
    """A Scene as given, or the one a preset name or a TOML file holds; SceneError for anything else."""
    if isinstance(scene, Scene):
        return scene
    if not isinstance(scene, (str, PathLike)):
        raise SceneError(f"scene = {scene!r} must be a fem_bounce.Scene, a preset name or a TOML file's path "
                         "(fb.presets() lists the presets)")
    return load(scene)


def _path(value, what: str) -> Path:
    """A path as given; an empty one is refused, not read as the current directory (as out="" is)."""
    if not isinstance(value, (str, PathLike)):
        raise OutputError(f"{what} = {value!r} must be a path (a str or a pathlib.Path)")
    if not str(value).strip():
        raise OutputError(f"{what} is empty: give a path (an empty one is not taken as the current directory)")
    return Path(value)


def _plots(value) -> bool:
    """plots= as given: True or False (a string such as "no" is refused, not taken as true)."""
    if not isinstance(value, (bool, np.bool_)):
        raise OutputError(f"plots = {value!r} must be True or False (draw the run's figures or not)")
    return bool(value)


def _model(model) -> str:
    if not isinstance(model, str):
        raise ModelError(f"model = {model!r} must be a model's name: one of {', '.join(_models.MODELS)}")
    return model


def load(source: str | Path, overrides: Mapping[str, Any] | Iterable[str] | None = None) -> Scene:
    """The scene of a preset name (see presets()) or a TOML file, with dotted-key overrides applied and
    checked as `--set` does: {"contact.delta_ss": 0.01} or ["contact.delta_ss=0.01"].  Raises SceneError
    naming the key and its allowed range.  A loaded scene's variant: scene.replace(**{"key": value})."""
    if isinstance(source, Scene):
        raise SceneError("load() takes a preset name or a TOML file's path, not a fem_bounce.Scene (which is loaded "
                         "already): a variant of it is scene.replace(**{'key': value})")
    if not isinstance(source, (str, PathLike)):
        raise SceneError(f"load() takes a preset name or a TOML file's path, not a {type(source).__name__} "
                         "(fb.presets() lists the presets)")
    return _scenes.load(source, _overrides(overrides))


def save(scene: Scene, path: str | Path) -> Path:
    """Write the scene as TOML (whole or not at all) that load() reads back to an equal scene; OutputError
    when it cannot be written."""
    if not isinstance(scene, Scene):
        raise SceneError(f"save() needs a fem_bounce.Scene, not {scene!r}: load it first, e.g. "
                         "fb.save(fb.load('li2011-case3'), 'my.toml')")
    path = _path(path, "path")
    _output.write_scene(path, scene)
    return path


def presets() -> list[str]:
    """The shipped scenes' names (`fem-bounce scenes`)."""
    return _scenes.preset_names()


def model_names(available: bool = False) -> list[str]:
    """The models, cheapest first (ode, fd, ib, ale); with available=True only those whose libraries import."""
    return _models.available() if available else list(_models.MODELS)


# -- one run ------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Collision:
    """A collision of a pair scene (sphere-sphere or sphere 1 on the wall), in time order: `kind` "pair" or
    "wall", the time of the minimum gap [s], the relative impact speed [m/s], its Re and (binary) St, the
    minimum gap [m] and the restitution (None when the run ended before it was known); `details` holds
    every number summary.json records for it (docs/usage.md, two spheres)."""

    kind: str
    time: float
    impact_speed: float
    Re: float
    St: float
    min_gap: float
    restitution: float | None = None
    details: dict = field(default_factory=dict, repr=False)


def _record(cls, data: dict):
    return cls(**{f.name: data[f.name] for f in dataclasses.fields(cls) if f.name in data})


@dataclass(frozen=True)
class Result:
    """One run: its scene, model, summary (summary.json as a dict), trajectory (trajectory.csv as
    {column: NumPy array}, SI units, positive away from the wall) and run directory (None for a run kept in
    memory)."""

    scene: Scene
    model: str
    summary: dict = field(repr=False)
    trajectory: dict[str, np.ndarray] = field(repr=False)
    run_dir: Path | None = None

    @property
    def status(self) -> str:
        """completed, diverged: ..., interrupted or failed: ... (docs/usage.md)."""
        return self.summary["status"]

    @property
    def stop_reason(self) -> str:
        return self.summary.get("stop_reason", "")

    @property
    def impacts(self) -> list[Impact]:
        """Sphere 1's impacts on the wall (time, impact_speed as the 2 ms mean, peak_speed, contact_speed,
        Re, St, min_gap, contact_gap)."""
        return [_record(Impact, d) for d in self.summary["impacts"]]

    @property
    def rebounds(self) -> list[Rebound]:
        """What followed each impact (restitution, rebound_speed, peak_rebound_speed, peak_restitution,
        apex_gap, apex_time, rebounded)."""
        return [_record(Rebound, d) for d in self.summary["rebounds"]]

    @property
    def collisions(self) -> list[Collision]:
        """A pair's collisions, pair and wall, in time order (empty for one sphere)."""
        return [_record(Collision, {**c, "details": dict(c)}) for c in self.summary.get("collisions", [])]

    @property
    def wall_time(self) -> float:
        """Seconds the run took (all its segments)."""
        return self.summary["wall_time_s"]

    def to_pandas(self):
        """The trajectory as a pandas DataFrame (pandas is not a dependency: ImportError without it)."""
        return _data_frame(self.trajectory)

    def draw(self, directory: str | Path | None = None) -> list[Path]:
        """Draw the run's figures (trajectory.png, and velocity_gap.png for one sphere) into `directory`,
        by default the run directory; a run kept in memory needs a directory.  Returns the files."""
        if directory is None:
            if self.run_dir is None:
                raise OutputError("this run was kept in memory: give draw() a directory for its figures")
            directory = self.run_dir
        from . import plots

        directory = Path(directory)
        try:
            directory.mkdir(parents=True, exist_ok=True)
            return plots.draw(self.trajectory, self.summary, directory)
        except OSError as err:
            raise OutputError(f"cannot draw the figures in {directory}: {err.strerror or err}") from None


def _data_frame(columns):
    try:
        import pandas
    except ImportError:
        raise ImportError("to_pandas() needs pandas, which fem_bounce does not install: pip install pandas") from None
    return pandas.DataFrame(columns)


def _world(comm=None):
    """The communicator a run uses: the caller's, else MPI.COMM_WORLD (one process when not under mpiexec)."""
    from mpi4py import MPI

    if comm is None:
        return MPI.COMM_WORLD
    if not isinstance(comm, MPI.Comm):
        raise RunnerError(f"comm = {comm!r} must be an mpi4py communicator, e.g. MPI.COMM_WORLD (or None for it)")
    return comm


class _Scratch:
    """A temporary directory that every rank sees (rank 0 makes it and removes it), for a run or a study
    kept in memory: nothing is left where the user looks."""

    def __init__(self, comm):
        self.comm = comm
        self.path = Path(comm.bcast(tempfile.mkdtemp(prefix="fem-bounce-") if comm.rank == 0 else None, root=0))

    def __enter__(self) -> Path:
        return self.path

    def __exit__(self, *exc) -> None:
        self.comm.barrier()
        if self.comm.rank == 0:
            shutil.rmtree(self.path, ignore_errors=True)


def _read_run(scene: Scene, model: str, run_dir: Path, comm, kept: bool) -> Result | None:
    """The run in run_dir as a Result (read on rank 0, the same on every rank); None without a summary."""
    def read():
        try:
            return _output.read_summary(run_dir), _output.read_trajectory(run_dir)
        except (OSError, ValueError):
            return None

    found = comm.bcast(read() if comm.rank == 0 else None, root=0)
    return None if found is None else Result(scene, model, *found, run_dir if kept else None)


@_public
def simulate(scene: Scene | str | Path, model: str | None = None, out: str | Path | None = None, *,
             force: bool = False, progress: bool = False, plots: bool = True, comm=None, **settings: Any) -> Result:
    """Run `model` on `scene` (a Scene, a preset name or a TOML file), as `fem-bounce run` does.

    model=None takes the model `fem-bounce run` takes without --model: the speed-accuracy front's pick for the
    scene (models.choose: fd for spheres on the axis, ode off it; docs/usage.md, "Which model a run takes");
    Result.model names it.  model="ode" is the reduced model, a run in well under a second.

    out=None keeps the run in memory: it runs in a temporary directory that is removed afterwards, so
    nothing is left behind; out=DIR writes the run directory (scene.toml, trajectory.csv, summary.json,
    the figures unless plots=False; an existing run directory only with force=True).  settings are the
    model's numerical settings by name, e.g. cells_per_diameter=8 for numerics.MODEL.cells_per_diameter
    (dotted scene keys go through **{"run.bounces": 2}), checked as --set is.  progress draws the progress
    line on stderr.  comm: an mpi4py communicator (default MPI.COMM_WORLD).

    A run that ends early raises RunDiverged, RunInterrupted or RunFailed (all RunFailed); the exception's
    `result` attribute holds what was computed until then (None when nothing was)."""
    scene, plots = _scene(scene), _plots(plots)
    model = _model(model) if model is not None else _models.choose(scene)[0]
    _models.info(model)
    if settings:
        scene = scene.replace(**{key if "." in key else f"numerics.{model}.{key}": value
                                 for key, value in settings.items()})
    _models.get(model)  # an unknown or missing model fails before anything runs, as on the command line
    comm = _world(comm)
    out = _output.out_path(out)
    command = f"fem_bounce.simulate({scene.name!r}, {model!r}" + (f", out={str(out)!r})" if out else ")")
    if out is not None:
        return _run(scene, model, comm, out, True, force=force, command=command, progress=progress, plots=plots)
    with _Scratch(comm) as scratch:
        return _run(scene, model, comm, scratch, False, command=command, progress=progress, plots=False)


@_public
def resume(run_dir: str | Path, model: str | None = None, *, progress: bool = False, plots: bool = True,
           comm=None) -> Result:
    """Continue the killed fd, ib or ale run in run_dir from its last checkpoint (`fem-bounce run --restart
    DIR`): the scene is run_dir/scene.toml, the model the checkpoint's (model, if given, must match)."""
    from . import run

    run_dir, plots = _path(run_dir, "run_dir"), _plots(plots)
    if model is not None:
        _models.info(_model(model))
    scene, model = run.restart_target(run_dir, model)
    return _run(scene, model, _world(comm), run_dir, True, restart=True, progress=progress, plots=plots,
                command=f"fem_bounce.resume({str(run_dir)!r})")


def _run(scene: Scene, model: str, comm, run_dir: Path, kept: bool, **options) -> Result:
    from .run import run_logged

    try:
        run_logged(scene, model, comm, run_dir, **options)
    except RunFailed as err:
        message = str(err) if kept else str(err).replace(f"; outputs kept in {run_dir}", "")
        again = RunInterrupted(message, err.signum) if isinstance(err, RunInterrupted) else type(err)(message)
        again.result = _read_run(scene, model, run_dir, comm, kept)
        raise again from None
    return _read_run(scene, model, run_dir, comm, kept)


# -- studies ------------------------------------------------------------------------------------


class Table(list):
    """A study's rows (one dict per run or model, the columns of its CSV file), with `summary` (what the
    study concluded, e.g. the restitution sweep against the Legendre et al. fit) and `to_pandas()`."""

    def __init__(self, rows: Iterable[dict] = (), summary: dict | None = None):
        super().__init__(rows)
        self.summary = summary or {}

    def column(self, name: str) -> np.ndarray:
        """One column as a float array (missing values as NaN)."""
        return np.array([np.nan if row.get(name) in (None, "") else row[name] for row in self], dtype=float)

    def to_pandas(self):
        """The rows as a pandas DataFrame (needs pandas, which fem_bounce does not install)."""
        return _data_frame(list(self))


@_public
def restitution(model: str = "ode", *, points: int | None = None, st_range: tuple[float, float] = (1.0, 1000.0),
                overrides: Mapping[str, Any] | Iterable[str] | None = None, out: str | Path | None = None,
                jobs: int = 1, executor: str = "local", cache: str | Path | None = None, comm=None,
                band: int | None = None, vary: Iterable[str] = (), defaults: bool = True, design: str = "sobol",
                seed: int = 0) -> Table:
    """The coefficient of restitution against impact Stokes number, as `fem-bounce restitution`: the Table 3
    material sets launched at the wall without gravity, `points` Stokes numbers over st_range (default 40
    for ode, 12 otherwise) plus one every factor 1.3 over St 3-30, e and St where the gap passes 0.2 D
    (docs/usage.md, Studies).  A row per run (scene, target_St, St, Re, speed_in, speed_out, restitution,
    fit, status, failed, ...); `summary` compares them with the Legendre et al. (2006) fit (rms_to_fit,
    max_abs_to_fit, critical_St, failed).  Runs go through the study cache `cache` and are spread over
    `jobs` local processes or an mpi4py.futures pool (executor="mpi"), as --jobs and --executor.
    out=DIR also writes restitution.csv, .json and .png there; out=None keeps only the cache.

    band=N (`--band --samples N`): e(St) with its band, N runs per Stokes number over the uncertain properties
    (`vary`, `defaults`, `design`, `seed` as in band()); a row per Stokes number (St_p5/p50/p95, e_p5/p50/p95,
    fit, fit_inside, leading, ...) and `summary` band.json (fit_inside_St, leading_below_St, warnings, ...);
    out=DIR also writes restitution_band.csv, samples.csv, band.json and restitution_band.png there."""
    from .studies import restitution as study
    from .studies.runner import study_runner

    model = _model(model)
    if points is not None and not (isinstance(points, numbers.Integral) and not isinstance(points, bool)):
        raise SceneError(f"points = {points!r} must be a whole number of Stokes numbers (--points), e.g. 12")
    points = (40 if model == "ode" else 12) if points is None else int(points)
    try:
        st_min, st_max = st_range
    except (TypeError, ValueError):
        st_min = st_max = None  # not two of anything
    if not all(isinstance(x, numbers.Real) and not isinstance(x, bool) for x in (st_min, st_max)):
        # numbers, not texts that float() would read: the same rule as points
        raise SceneError(f"st_range = {st_range!r} must be two numbers (--st-min, --st-max), e.g. (1, 1000)")
    st_min, st_max = float(st_min), float(st_max)
    if points < 2 or not (math.isfinite(st_min) and math.isfinite(st_max) and 0 < st_min < st_max):
        raise SceneError(f"restitution: need --points >= 2 and 0 < --st-min < --st-max, both finite (got --points "
                         f"{points}, --st-min {st_min:g}, --st-max {st_max:g})")
    _models.get(model)
    out = _output.out_path(out)
    changes = _overrides(overrides)
    comm, runner = study_runner(jobs, executor, None if comm is None else _world(comm), cache)
    if band is not None:
        from .studies import band as bands

        with runner, _Scratch(comm) if out is None else contextlib.nullcontext(out) as where:
            found = bands.restitution_band(model, comm, where, points, (st_min, st_max), changes, _texts(vary, "vary"),
                                           bool(defaults), band, design, seed, runner=runner)
        return Table(found["stations"], found)
    with runner, _Scratch(comm) if out is None else contextlib.nullcontext(out) as where:
        rows = study.run(model, comm, where, points, (st_min, st_max), overrides=changes, runner=runner)
    return Table(rows, study.compare(rows))


def _texts(values, what: str) -> list[str]:
    """A text or texts (--vary KEY=RANGE) as a list; SceneError for anything else."""
    if isinstance(values, str):
        return [values]
    if not isinstance(values, Iterable) or not all(isinstance(v, str) for v in values):
        raise SceneError(f"{what} = {values!r} must be texts KEY=RANGE, e.g. ['liquid.viscosity=+-7%']")
    return list(values)


@_public
def band(scene: Scene | str | Path, model: str = "ode", samples: int = 64, *, vary: Iterable[str] = (),
         defaults: bool = True, design: str = "sobol", seed: int = 0,
         overrides: Mapping[str, Any] | Iterable[str] | None = None, out: str | Path | None = None, jobs: int = 1,
         executor: str = "local", cache: str | Path | None = None, comm=None) -> Table:
    """A prediction with its band, as `fem-bounce study band`: `samples` runs of `model` on `scene` over its
    uncertain properties (a seeded Sobol' design, or design="lhs" or "saltelli"), each through the study cache.
    The ranges: the scene file's [uncertain] table, else the packaged defaults (unless defaults=False), with each
    `vary` text KEY=RANGE added or replacing one (LOW:HIGH, LOW:HIGH:log, MEAN~SD, +-P%, ~P%; docs/usage.md).
    A row per sample (the varied values, status and every summary quantity), and `summary` band.json: the 5/50/95 %
    percentiles of each quantity (`quantities`), the measurement inside the band or not (`measured`), the Sobol'
    indices (`indices`), the leading setting per quantity (`leading`) and `warnings`.  out=DIR also writes
    band.json, samples.csv, band_trajectory.csv, band_trajectory.png and sensitivity.png there."""
    from . import uncertain
    from .studies import band as study
    from .studies.runner import study_runner

    model = _model(model)
    _models.get(model)
    table = uncertain.scene_table(scene) if isinstance(scene, (str, PathLike)) else None
    where = f"{scene} [uncertain]"
    scene = _scene(scene)
    if overrides:
        scene = scene.replace(**_overrides(overrides))
    ranges = uncertain.ranges_for(scene, _texts(vary, "vary"), table, bool(defaults), where=where)
    out = _output.out_path(out)
    comm, runner = study_runner(jobs, executor, None if comm is None else _world(comm), cache)
    with runner, _Scratch(comm) if out is None else contextlib.nullcontext(out) as place:
        result, rows = study.run(scene, model, comm, place, ranges, samples, design, seed, runner=runner)
    return Table(rows, result)


@_public
def compare(scene: Scene | str | Path, models: str | Sequence[str] = ("ode", "fd", "ib"), out: str | Path | None = None,
            *, force: bool = False, progress: bool = False, plots: bool = True, comm=None,
            command: str = "") -> Table:
    """Several models on one scene, as `fem-bounce compare`: a row per model (status, wall_time_s, steps,
    unknowns, and per impact impact_speed_K, Re_K, restitution_K, apex_gap_over_D_K) and one for the
    scene's measurement when it has one.  Each run goes through the study cache (fem_bounce.cachedir, as
    the command line).  out=DIR also writes DIR/MODEL run directories, comparison.csv and, unless
    plots=False, comparison.png and each run's figures; out=None keeps only the cache (and draws nothing)."""
    from .studies import compare as study

    names = _models.model_list(models)
    scene, plots = _scene(scene), _plots(plots)
    comm = _world(comm)
    out = _output.out_path(out)
    command = command or f"fem_bounce.compare({scene.name!r}, {','.join(names)!r})"
    with _Scratch(comm) if out is None else contextlib.nullcontext(out) as where:
        rows = study.compare(scene, names, comm, where, force=force, progress=progress,
                             plots=plots and out is not None, command=command)
    return Table(rows)

