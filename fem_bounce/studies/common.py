"""What every study shares: what to measure in a run, each model's resolution ladder, error
arithmetic (observed orders, Richardson extrapolation, Pareto fronts) and the study directory."""
from __future__ import annotations

import csv
import json
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import reference
from .. import scene as scenes
from ..errors import OutputError
from ..output import MARKER, is_run_directory, read_summary, read_trajectory
from ..models.registry import MODELS
from ..models.unread import unread
from ..motion import is_held, is_stream
from ..run import on_root
from .runner import Runner


@dataclass(frozen=True)
class Ladder:
    """A model's resolution knob: the scene key, its values coarse to fine, and the length it sets;
    its time-step knob (a CFL number), and any other step limits that must shrink with it."""

    key: str
    values: tuple
    time_step_key: str | None
    scaled_with_time_step: tuple = ()  # e.g. the fd model's forcing number, which usually sets its dt

    def spacing(self, value: float) -> float:
        """A length-like measure that shrinks under refinement (1/cells, or the tolerance itself)."""
        return value if self.key.endswith("rtol") else 1.0 / value

    def time_step(self, scene: scenes.Scene, cfl: float) -> dict:
        """Scene changes that set the CFL number to `cfl` and scale the other step limits by the
        same factor, so that the time step itself changes whichever limit is binding (those the scene's run
        reads: the fd model's forcing_number with the one-shot penalty only, models.unread)."""
        if self.time_step_key is None:
            return {}
        factor = cfl / _setting(scene, self.time_step_key)
        _, model, _ = self.time_step_key.split(".")
        ignored = unread(scene, model)
        return {self.time_step_key: cfl, **{k: factor * _setting(scene, k) for k in self.scaled_with_time_step
                                            if k.rsplit(".", 1)[1] not in ignored}}

    def scaled_step(self, scene: scenes.Scene, factor: float) -> dict:
        """Scene changes that multiply the scene's time step by `factor` (its CFL number and the other
        step limits alike); {} for a model without a time-step setting (its tolerance sets its steps)."""
        if self.time_step_key is None:
            return {}
        return self.time_step(scene, factor * _setting(scene, self.time_step_key))


def _setting(scene: scenes.Scene, key: str) -> float:
    """The value of a dotted key; an unset one as its table resolves it (numerics.FdNumerics.resolved)."""
    *path, name = key.split(".")
    table = scene
    for part in path:
        table = getattr(table, part)
    value = getattr(table, name)
    return table.resolved(name) if value is None else value


# each model's ladder, from the registry of models
LADDERS = {name: Ladder(m.resolution_key, m.ladder, m.time_step_key, m.scaled_with_time_step)
           for name, m in MODELS.items()}
CFL_LADDER = (0.8, 0.4, 0.2, 0.1)


def quantities(scene: scenes.Scene, run_dir: Path) -> dict:
    """The numbers a study compares, for the kind of scene this is [SI]."""
    summary = read_summary(run_dir)
    found: dict = {"wall_time_s": summary["wall_time_s"], "status": summary["status"]}
    motion = scene.motion
    if is_held(scene):
        force = read_trajectory(run_dir)["f_sim"][-1]
        a, mu = scene.sphere.radius, scene.liquid.viscosity
        if motion.stream_velocity:
            found["drag_coefficient"] = scene.drag_coefficient(force, motion.stream_velocity)
        if motion.velocity:
            found["wall_drag_factor"] = -force / (6 * math.pi * mu * a * motion.velocity)
        return found
    trajectory = read_trajectory(run_dir)
    found["peak_speed"] = float(max(0.0, -trajectory["velocity"].min()))
    impacts, rebounds = summary["impacts"], summary["rebounds"]
    if impacts:
        found["impact_speed"] = impacts[0]["impact_speed"]
    if len(impacts) > 1:
        found["re_second"] = impacts[1]["Re"]
    if rebounds:
        found["restitution"] = rebounds[0]["restitution"]
        if rebounds[0]["apex_gap"] is not None:
            found["apex_gap"] = rebounds[0]["apex_gap"]
    return found


def primary(scene: scenes.Scene) -> list[str]:
    """The quantities a scene is judged by, most important first."""
    if is_held(scene):
        return ["drag_coefficient"] if scene.motion.stream_velocity else ["wall_drag_factor"]
    if scene.reference.peak_speed is not None or scene.run.bounces == 0:
        return ["peak_speed"]
    return ["impact_speed", "apex_gap"]


def measured(scene: scenes.Scene) -> dict:
    """Experimental or published reference values for this scene, where they exist."""
    ref = scene.reference
    values = {"impact_speed": ref.impact_speed, "peak_speed": ref.peak_speed,
              "re_second": ref.re_second}
    if is_stream(scene):
        reynolds = scene.reynolds(scene.motion.stream_velocity)
        for row in reference.table("sphere_drag_reference"):
            if abs(row["Re"] - reynolds) < 0.01 * reynolds:
                values["drag_coefficient"] = row["Cd_reference"]
    if is_held(scene) and scene.motion.velocity:
        delta = scene.initial_gap / scene.sphere.diameter
        for row in reference.table("brenner1961_wall_drag"):
            if abs(row["delta"] - delta) < 1e-9 * delta:
                values["wall_drag_factor"] = row["lambda_brenner"]
    return {k: v for k, v in values.items() if v is not None}


def relative_error(value: float | None, ref: float | None) -> float | None:
    if value is None or ref is None or ref == 0:
        return None
    return abs(value / ref - 1.0)


def observed_orders(spacings: list[float], values: list[float]) -> list[float | None]:
    """Order between consecutive levels, errors taken against the finest value."""
    errors = [abs(v - values[-1]) for v in values[:-1]]
    orders: list[float | None] = []
    for k in range(len(errors) - 1):
        e0, e1 = errors[k], errors[k + 1]
        ratio = spacings[k] / spacings[k + 1]
        orders.append(math.log(e0 / e1) / math.log(ratio) if e0 > 0 and e1 > 0 and ratio != 1 else None)
    return orders


def richardson(spacings: list[float], values: list[float]) -> tuple[float, float] | None:
    """(order, extrapolated value) from the three finest levels, when they converge monotonically."""
    (h1, h2, h3), (q1, q2, q3) = spacings[-3:], values[-3:]
    if (q1 - q2) * (q2 - q3) <= 0:
        return None
    target = (q1 - q2) / (q2 - q3)

    def mismatch(p):
        return (h1**p - h2**p) / (h2**p - h3**p) - target

    lo, hi = 0.05, 8.0
    if mismatch(lo) * mismatch(hi) > 0:
        return None
    for _ in range(100):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if mismatch(lo) * mismatch(mid) > 0 else (lo, mid)
    p = 0.5 * (lo + hi)
    return p, q3 + (q3 - q2) / ((h2 / h3) ** p - 1.0)


def pareto(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points no other point beats in both cost and error, cheapest first."""
    order = sorted(range(len(points)), key=lambda k: (points[k][0], points[k][1]))
    front, best = [], math.inf
    for k in order:
        if points[k][1] < best:
            front.append(k)
            best = points[k][1]
    return front


def check_study_directory(path: Path) -> None:
    """Refuse a study's --out before the study runs (rank 0), naming the path: a file, a run directory (its
    files are a run's own), or a place this process cannot write (the nearest existing folder on its way)."""
    path = Path(path)
    try:
        if path.exists() and not path.is_dir():
            raise OutputError(f"{path} exists and is not a directory: a study writes a directory; choose another --out")
        if is_run_directory(path) or any(is_run_directory(parent) for parent in path.resolve().parents):
            raise OutputError(f"{path} is a run directory or inside one (it holds {MARKER}): a study writes beside "
                              "runs, not into one; choose another --out")
        existing = next(p for p in (path, *path.absolute().parents) if p.exists())
        if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
            raise OutputError(f"cannot write the study in {path}: {existing} is not writable (Permission denied); "
                              "choose another --out")
    except OSError as err:
        raise OutputError(f"cannot use {path} for the study: {err.strerror or err}") from None


class StudyDirectory:
    """Where a study writes: CSV/JSON data, PNG figures and a progress log (rank 0).  A write that fails is one
    OutputError naming the file."""

    def __init__(self, path: Path, comm):
        self.path, self.comm = Path(path), comm
        self._start = time.perf_counter()
        on_root(comm, lambda: check_study_directory(self.path))  # refused on every rank alike

    def file(self, name: str) -> Path:
        """DIR/name, the directory made at the first write: a study refused before it writes leaves nothing."""
        try:
            self.path.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise OutputError(f"cannot write the study in {self.path}: {err.strerror or err}") from None
        return self.path / name

    def _write(self, name: str, write) -> None:
        path = self.file(name)
        try:
            with open(path, "a" if name == "progress.log" else "w", newline="") as stream:
                write(stream)
        except OSError as err:
            raise OutputError(f"cannot write {path}: {err.strerror or err}") from None

    def log(self, message: str) -> None:
        if self.comm.rank != 0:
            return
        line = f"[{time.perf_counter() - self._start:7.0f} s] {message}"
        print(line, file=sys.stderr, flush=True)
        self._write("progress.log", lambda stream: stream.write(line + "\n"))

    def write_csv(self, name: str, rows: list[dict]) -> None:
        if self.comm.rank != 0 or not rows:
            return
        columns = list(dict.fromkeys(k for row in rows for k in row))

        def write(stream) -> None:
            writer = csv.DictWriter(stream, columns)
            writer.writeheader()
            writer.writerows(rows)

        self._write(name, write)

    def write_json(self, name: str, data) -> None:
        if self.comm.rank == 0:
            self._write(name, lambda stream: stream.write(json.dumps(data, indent=2, default=float) + "\n"))


def measure_all(tasks: list[tuple[scenes.Scene, str, str]], study: StudyDirectory,
                runner: Runner | None = None) -> list[dict]:
    """Each (scene, model, label) run through the cache, spread by `runner` (one after the other on the
    study's communicator when None), and what it measured; rows in the order of `tasks`."""
    runner = runner or Runner(study.comm)
    if len(tasks) > 1:
        study.log(f"{len(tasks)} runs, {runner.describe()} (finished runs are reused from the cache)")
    rows: list = [None] * len(tasks)
    for k, run_dir in runner.run([(scene, model) for scene, model, _ in tasks]):
        scene, model, label = tasks[k]
        found = quantities(scene, run_dir)
        study.log(f"{model} {label}: {found['status']}, {found['wall_time_s']:.1f} s "
                  f"(load average now {os.getloadavg()[0]:.2f})  "
                  + "  ".join(f"{name} = {value:.5g}" for name, value in found.items()
                              if isinstance(value, float) and name != "wall_time_s"))
        rows[k] = {"model": model, "label": label, "run_dir": str(run_dir), **found}
    return rows


def finite(values) -> np.ndarray:
    return np.array([np.nan if v is None else v for v in values], dtype=float)
