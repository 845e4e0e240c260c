"""What a run leaves behind, the same for every model.

    DIR/scene.toml        the resolved scene (runs again unchanged)
    DIR/trajectory.csv    t, gap, velocity, acceleration and each force term [SI]
    DIR/summary.json      scene, model, impacts, rebounds, cost, versions, command
    DIR/*.png             drawn from those files by fem_bounce.plots

Only rank 0 writes.  A directory is never reused silently: an existing one
needs `force=True`, which clears it first.
"""
from __future__ import annotations

import csv
import dataclasses
import json
import platform
import shutil
import sys
import time
from pathlib import Path

from . import __version__
from . import scene as scenes

TRAJECTORY_COLUMNS = ("t", "gap", "velocity", "acceleration", "f_drag", "f_history", "f_added_mass", "f_theory",
                      "f_sim", "blend", "f_liquid", "f_elastic", "f_correction")


class OutputError(RuntimeError):
    pass


def prepare_directory(path: Path, force: bool = False, resume: bool = False) -> Path:
    """Create a fresh run directory; refuse an existing non-empty one unless forced or resuming."""
    path = Path(path)
    if path.exists() and any(path.iterdir()) and not resume:
        if not force:
            raise OutputError(f"{path} exists and is not empty; pass --force to replace it, or choose --out")
        shutil.rmtree(path)
    path.mkdir(parents=True, exist_ok=True)
    return path


def unused_directory(base: Path) -> Path:
    """base, or base-2, base-3, ... : the first that does not exist yet."""
    candidate, n = Path(base), 1
    while candidate.exists():
        n += 1
        candidate = Path(f"{base}-{n}")
    return candidate


class TrajectoryWriter:
    """Streams trajectory rows to CSV (rank 0), thinned to one row per `interval` seconds if asked."""

    def __init__(self, path: Path | None, interval: float = 0.0, append: bool = False):
        self.interval = interval
        self._last_t = -float("inf")
        self._file = None
        if path is not None:
            fresh = not (append and Path(path).exists())
            self._file = open(path, "a" if not fresh else "w", newline="")
            self._writer = csv.writer(self._file)
            if fresh:
                self._writer.writerow(TRAJECTORY_COLUMNS)

    def __call__(self, row: dict) -> None:
        if self._file is None or row["t"] - self._last_t < self.interval:
            return
        self._last_t = row["t"]
        self._writer.writerow([f"{row[c]:.10g}" for c in TRAJECTORY_COLUMNS])

    def flush(self) -> None:
        if self._file is not None:
            self._file.flush()

    def close(self) -> None:
        if self._file is not None:
            self._file.close()
            self._file = None


def versions() -> dict:
    found = {"fem_bounce": __version__, "python": platform.python_version()}
    for module in ("numpy", "scipy", "petsc4py", "dolfinx", "gmsh", "mpi4py"):
        mod = sys.modules.get(module)
        if mod is not None:
            found[module] = getattr(mod, "__version__", "?")
    return found


def summary(scene, model: str, integrator, wall_time: float, steps: int, ranks: int, command: str,
            status: str = "completed", sizes: dict | None = None, extra: dict | None = None) -> dict:
    """The summary.json contract (issue 2, section 7) plus cost and state details."""
    return {
        "scene": scenes.to_dict(scene),
        "model": model,
        "status": status,
        "impacts": [dataclasses.asdict(i) for i in integrator.impacts],
        "rebounds": [dataclasses.asdict(r) for r in integrator.rebounds],
        "blend_crossings": integrator.blend_crossings,
        "wall_time_s": wall_time,
        "steps": steps,
        "sphere_steps": integrator.steps,
        "ranks": ranks,
        "sizes": sizes or {},
        "final": {"time": integrator.time, "gap": integrator.gap, "velocity": integrator.velocity},
        "versions": versions(),
        "command": command,
        "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S"),
        **(extra or {}),
    }


def write_summary(path: Path, data: dict) -> None:
    tmp = Path(path).with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=2) + "\n")
    tmp.replace(path)  # a killed run never leaves half a summary


def write_scene(path: Path, scene) -> None:
    Path(path).write_text(scenes.dumps(scene))


class Progress:
    """One status line on stderr (rank 0): model time, steps, gap, speed and the remaining wall time."""

    def __init__(self, end_time: float, diameter: float, enabled: bool = True, every: float = 1.0):
        self.end_time, self.diameter, self.enabled, self.every = end_time, diameter, enabled, every
        self.start = time.perf_counter()
        self._last = -float("inf")
        self._tty = sys.stderr.isatty()

    def __call__(self, t: float, steps: int, gap: float, velocity: float, force: bool = False) -> None:
        now = time.perf_counter()
        if not self.enabled or (now - self._last < (0.2 if self._tty else self.every) and not force):
            return
        self._last = now
        elapsed = now - self.start
        fraction = min(max(t / self.end_time, 0.0), 1.0)
        left = f"~{elapsed * (1.0 - fraction) / fraction:4.0f} s left" if fraction > 0.01 else ""
        width = 24
        bar = "#" * int(width * fraction) + "-" * (width - int(width * fraction))
        line = (f"[{bar}] t = {t:.4f}/{self.end_time:g} s  step {steps}  gap/D {gap / self.diameter:7.4f}  "
                f"V {velocity:+.4f} m/s  {elapsed:5.0f} s elapsed {left}")
        print(("\r" + line) if self._tty else line, end="" if self._tty else "\n", file=sys.stderr, flush=True)

    def close(self) -> None:
        if self.enabled and self._tty:
            print(file=sys.stderr)
