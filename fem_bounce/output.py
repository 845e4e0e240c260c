"""What a run leaves behind, the same for every model.

    DIR/.fem-bounce-run   the marker, written first and locked while a run uses DIR: `--force` replaces
                          only a directory that holds it, and never one that another run holds
    DIR/scene.toml        the resolved scene (runs again unchanged)
    DIR/trajectory.csv    t, gap, velocity, acceleration and each force term [SI]
    DIR/summary.json      scene, model, status, stop reason, impacts, rebounds, cost, versions, command
    DIR/checkpoint/       the last checkpoint of a model that writes them: model.txt, state.json, data
    DIR/*.png             drawn from those files by fem_bounce.plots

Only rank 0 writes, through one RunDirectory per run (prepare or resume, reserve, commit, release),
which alone opens the marker, the checkpoint and the trajectory's restart.  Nothing is lost by accident:

- a directory is never reused silently: an existing non-empty one needs `force=True`, and even then
  only a run directory (one holding the marker) is replaced; the current directory, the home directory,
  a repository root and their parents never are;
- one process at a time uses a run directory: the marker is locked (flock) before anything is written
  or deleted, so a second run on it is refused, `--force` included; a run directory is never made inside
  another, and `--force` never deletes one that holds another run;
- a file whose half would mislead (scene.toml, summary.json, every checkpoint file) is written beside
  its place, flushed to the disk and renamed over it, so a kill or a full disk leaves the old file or
  the new one, never a mix;
- trajectory rows reach the disk (flushed and fsynced) with every checkpoint, which records how many
  there are; a restart cuts the file back to that count, so no row is lost or doubled;
- a write that fails (disk full, no permission) becomes one OutputError naming the path and the reason,
  and what was written before stays whole (a half-written trajectory row is cut off).
"""
from __future__ import annotations

import contextlib
import csv
import dataclasses
import errno
import fcntl
import hashlib
import io
import json
import os
import platform
import shutil
import sys
import time
import tomllib
import warnings
import zipfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from . import cachedir
from . import scene as scenes
from ._version import __version__
from .errors import CheckpointError, OutputError
from .kinematics import pair_name

# One scheme for any number of spheres: the time, each neighbouring pair's surface gap (named after its contact,
# kinematics.pair_name: pair_gap for two spheres, pair_gap_12, pair_gap_23, ... for more), then each sphere's
# columns, suffixed _1, _2, ... (sphere 1 the lowest) when there are several.  gap is a sphere's lowest point
# above z = 0; f_pair, the pairs' Stokes interaction in the theory force, is there only with pairs (docs/usage.md).
SPHERE_COLUMNS = ("gap", "velocity", "acceleration", "f_drag", "f_lubrication", "f_history", "f_pair", "f_added_mass",
                  "f_theory", "f_sim", "blend", "f_liquid", "f_elastic", "f_correction")


# An oblique collision's (one sphere): its position and velocity along the wall, its spin, the liquid's force and
# torque along the wall and the contact's friction, the free sphere's part of the liquid's force and torque, the
# spring's stretch and stored energy, the power the contact dissipates sliding and sticking (fem_bounce.oblique,
# TangentialMotion.row; the loss audit's, fem_bounce.losses) and the lift on the normal motion (fem_bounce.wall_lift)
TANGENTIAL_COLUMNS = ("x", "tangential_velocity", "spin", "f_tangential_liquid", "f_friction", "torque_liquid",
                      "f_tangential_drag", "torque_drag", "stretch", "spring_energy", "dissipation_sliding",
                      "dissipation_sticking", "f_lift")


# A pair's off its line of centres (fem_bounce.pair_oblique, PairTangentialMotion.row): the centres in the plane x-z,
# the angle of the line of centres from z, each sphere's velocity across it and spin, the liquid's force across it and
# torque on each (the film's on sphere 1 apart), the contact's friction on sphere 1, the spring's stretch and stored
# energy and the power the contact dissipates.  A pair's gap_k and velocity_k are then along the line of centres.
PAIR_TANGENTIAL_COLUMNS = ("x_1", "z_1", "x_2", "z_2", "theta", "tangential_velocity_1", "tangential_velocity_2",
                           "spin_1", "spin_2", "f_tangential_liquid_1", "f_tangential_liquid_2", "torque_liquid_1",
                           "torque_liquid_2", "f_tangential_film_1", "f_friction", "stretch", "spring_energy",
                           "dissipation_sliding", "dissipation_sticking")


def trajectory_columns(spheres: int, oblique: bool = False) -> tuple:
    """The trajectory's columns for this many spheres (SPHERE_COLUMNS), and an oblique collision's."""
    if spheres == 1:
        return ("t", *(name for name in SPHERE_COLUMNS if name != "f_pair"), *(TANGENTIAL_COLUMNS if oblique else ()))
    gaps = tuple(pair_name(k, spheres).replace("pair", "pair_gap") for k in range(spheres - 1))
    return ("t", *gaps, *(f"{name}_{k}" for k in range(1, spheres + 1) for name in SPHERE_COLUMNS),
            *(PAIR_TANGENTIAL_COLUMNS if oblique else ()))


TRAJECTORY_COLUMNS = trajectory_columns(1)  # one sphere's


MARKER = cachedir.RUN_MARKER  # defined there, as the cache refuses to lie in a run directory
MARKER_TEXT = "fem-bounce run directory: `fem-bounce run --force` may replace everything in it.\n"


def _reason(err: Exception) -> str:
    """Why an operation failed: an OSError's strerror, else the exception's message."""
    return getattr(err, "strerror", None) or str(err)


# -- whole files ------------------------------------------------------------------------------


def sync_file(path: Path) -> None:
    """fsync a file (or a directory: the renames inside it)."""
    fd = os.open(path, os.O_RDONLY)
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def file_digest(path: Path) -> str:
    """The SHA-256 of a file's bytes (hex), read in blocks."""
    with open(path, "rb") as stream:
        return hashlib.file_digest(stream, "sha256").hexdigest()


def _sync_directory(path: Path) -> None:
    """Make a rename inside `path` durable (where the file system supports it)."""
    with contextlib.suppress(OSError):
        sync_file(path)


def _write_all(fd: int, data: bytes) -> None:
    """os.write until every byte of `data` is written (one call may write only part)."""
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def _partial(path: Path) -> Path:
    return path.with_name(f".{path.name}.partial")


def atomic_write_text(path: Path, text: str) -> None:
    """Write `text` to `path` whole or not at all (write beside, fsync, rename).  Space reserved for
    it beforehand (RunDirectory.reserve) is written into, so the write succeeds on a disk that filled since."""
    path = Path(path)
    partial, data = _partial(path), text.encode()
    try:
        fd = os.open(partial, os.O_WRONLY | os.O_CREAT, 0o644)  # no O_TRUNC: keep reserved blocks
        try:
            _write_all(fd, data)
            os.ftruncate(fd, len(data))
            os.fsync(fd)
        finally:
            os.close(fd)
        os.replace(partial, path)
    except OSError as err:
        with contextlib.suppress(OSError):
            partial.unlink()
        raise OutputError(f"cannot write {path}: {_reason(err)}") from None
    _sync_directory(path.parent)


def write_scene(path: Path, scene) -> None:
    atomic_write_text(path, scenes.dumps(scene))


# -- the run directory ------------------------------------------------------------------------


def _protected(path: Path) -> str | None:
    """Why `path` may never be a run directory (or None): replacing it would destroy what the user
    works in.  Symbolic links and '..' are resolved first, so no spelling gets around it."""
    resolved = path.resolve()
    if resolved == Path(resolved.anchor):
        return "the filesystem root"
    cwd = Path.cwd().resolve()
    if resolved == cwd:
        return "the current directory"
    if resolved in cwd.parents:
        return "a parent of the current directory"
    with contextlib.suppress(RuntimeError, KeyError):  # no HOME and no passwd entry: nothing to protect
        home = Path.home().resolve()
        if resolved == home:
            return "the home directory"
        if resolved in home.parents:
            return "a parent of the home directory"
    if (resolved / ".git").exists():
        return "a repository root (it holds .git)"
    return None


def is_run_directory(path: Path) -> bool:
    return (Path(path) / MARKER).is_file()


# A flock belongs to an open file of this process: one per directory, whichever RunDirectory holds it.
_LOCKS: dict[Path, int] = {}  # run directory (resolved) -> its marker, held open and locked by this process

SUMMARY_RESERVE_BYTES = 1 << 16  # a summary is 3-10 kB, more with many impacts or remeshes
RESTART_MAY_CHANGE = ("run.end_time", "run.bounces", "description")  # how long to run, not what is run


class RunDirectory:
    """DIR as one run uses it: rank 0 calls these methods, in this order:

        run_dir = RunDirectory(path)
        run_dir.prepare(force, scene)  or  resumed = run_dir.resume(scene, model_name, checkpoint_files)
        run_dir.reserve()                                    # room for the summary, while there is some
        writer = run_dir.trajectory(interval, columns)       # continues where the resumed checkpoint did
        run_dir.commit_checkpoint(model_name, state, data_file, arrays)   # as often as the model asks
        run_dir.commit_summary(data)
        run_dir.release()                                    # the reserved room and the lock
    """

    def __init__(self, path: Path):
        self.path = Path(path)
        self.checkpoint: Checkpoint | None = None  # the newest whole one on the disk: resumed, then each committed
        self._continued: dict[str, int] = {}  # a restart: the rows of trajectory.csv and each side file it continues
        self._unsettled: Checkpoint | None = None  # a restart's checkpoint, settled by begin()
        self._made = False  # prepare() made the directory

    # -- prepare and resume --
    def prepare(self, force: bool = False, scene=None) -> None:
        """Create a fresh run directory, its marker first, locked for this process, and write `scene`
        to DIR/scene.toml.  An existing non-empty directory is refused unless `force` and it is a run
        directory that no other run holds and that holds no other run (then its contents are replaced)."""
        path = self.path
        self._check_place()
        try:
            if path.is_dir() and any(path.iterdir()):
                if not force:
                    raise OutputError(f"{path} exists and is not empty; pass --force to replace it, or choose --out")
                if not is_run_directory(path):
                    raise OutputError(f"{path} is not a fem-bounce run directory (it has no {MARKER}): --force "
                                      "replaces only run directories; choose another --out")
                inner = next((marker.parent for marker in path.glob(f"*/**/{MARKER}")), None)
                if inner is not None:
                    raise OutputError(f"{path} holds another run directory, {inner}: --force never deletes a run; "
                                      "move it out or choose another --out")
                self._lock()
                for entry in path.iterdir():  # all but the locked marker (a file: is_run_directory)
                    if entry.is_dir() and not entry.is_symlink():
                        shutil.rmtree(entry)
                    elif entry.name != MARKER:
                        entry.unlink()
            self._made = not path.exists()
            path.mkdir(parents=True, exist_ok=True)
        except OSError as err:
            raise OutputError(f"cannot use {path} as a run directory: {_reason(err)}") from None
        try:
            self._lock()
            if scene is not None:
                write_scene(path / "scene.toml", scene)
        except OutputError:  # no room for the marker or the scene: nothing left behind
            self.abandon()
            for name in (MARKER, "scene.toml"):  # in an (empty) directory that was there already
                with contextlib.suppress(OSError):
                    (path / name).unlink()
            raise

    def resume(self, scene, model_name: str, checkpoint_files: tuple = ()) -> Checkpoint:
        """Lock DIR and check that it can continue `scene` with `model_name`: a whole checkpoint of that
        model (holding `checkpoint_files`), written for the same scene (up to RESTART_MAY_CHANGE), and
        the rows of trajectory.csv and of each side file it continues.  Nothing in DIR changes here: begin()
        settles the checkpoint and cuts the files back once the run has restored it, so a restart refused on
        the way leaves DIR byte for byte as it was.  Returns the checkpoint (the run's state to restore)."""
        path = self.path
        self._check_place(replacing=False)
        if not is_run_directory(path):
            raise OutputError(f"{path} is not a run directory" + ("" if path.is_dir() else ": it does not exist"))
        self._lock()  # no second run continues it at the same time
        found = self.newest_checkpoint(checkpoint_files)
        if found.model != model_name:
            raise CheckpointError(f"the checkpoint in {path} was written by the {found.model!r} model, "
                                  f"not {model_name}")
        record = found.run
        rows = record.get("trajectory_rows") if isinstance(record, dict) else None
        side_rows = record.get("side_rows", {}) if isinstance(record, dict) else None
        counts = [rows, *side_rows.values()] if isinstance(side_rows, dict) else [None]
        if not (isinstance(record.get("scene") if isinstance(record, dict) else None, str)
                and all(_is_count(n) for n in counts)):
            raise CheckpointError(f"the checkpoint in {path} is unreadable: {found.folder.name}/state.json holds no "
                                  "whole run record (scene, row counts; damaged or edited, or written by an older "
                                  "version?); start a new run")
        if record.get("model", found.model) != found.model:
            raise CheckpointError(f"the checkpoint in {path} is unreadable: {found.folder.name}/model.txt names the "
                                  f"{found.model} model, but its state was written by the {record['model']} model "
                                  "(damaged or edited); restore model.txt or start a new run")
        changes = _scene_changes(record["scene"], scene, path)
        if changes:
            raise CheckpointError(
                f"{path}/scene.toml no longer matches its checkpoint ({'; '.join(changes)}): restore it, or start "
                f"a new run (a restart may change only {', '.join(RESTART_MAY_CHANGE[:2])})")
        continued = {"trajectory.csv": rows, **side_rows}
        for name, count in continued.items():
            _trajectory_offset(path / name, count)  # every file holds the rows the checkpoint counts
        for skipped in found.skipped:
            warnings.warn(f"{skipped}; continuing from the older copy ({found.folder.name})", stacklevel=2)
        self.checkpoint, self._continued, self._unsettled = found, continued, found
        return found

    def begin(self) -> None:
        """A restart whose checkpoint the run has restored: make it DIR/checkpoint again and cut trajectory.csv and
        the side files back to the rows it counts, so that no row is lost or doubled (nothing to do otherwise)."""
        chosen, self._unsettled = self._unsettled, None
        if chosen is None:
            return
        self._settle(chosen)
        for name, rows in self._continued.items():
            file = self.path / name
            try:
                os.truncate(file, _trajectory_offset(file, rows))
                sync_file(file)
            except OSError as err:
                raise OutputError(f"cannot write {file}: {_reason(err)}") from None

    def _check_place(self, replacing: bool = True) -> None:
        """Refuse a DIR that cannot be a run directory; `replacing` (prepare: a new run, maybe --force) also one
        the user works in or one inside another run directory (a restart only continues DIR)."""
        path = self.path
        loop = OutputError(f"{path} is a loop of symbolic links; choose another --out")
        try:
            os.stat(path)
        except OSError as err:
            if err.errno == errno.ELOOP:  # Python 3.13's Path.resolve no longer says so
                raise loop from None
        try:
            why = _protected(path) if replacing else None
        except RuntimeError:  # Python 3.12's Path.resolve met a loop of symbolic links
            raise loop from None
        except OSError as err:  # a name too long for the filesystem, ...
            raise OutputError(f"cannot use {path} as a run directory: {_reason(err)}") from None
        if why is not None:
            raise OutputError(f"{path} is {why}: it cannot be a run directory; choose another --out")
        if not replacing:
            return
        try:
            if path.exists() and not path.is_dir():
                raise OutputError(f"{path} exists and is not a directory; choose another --out")
            if path.is_symlink() and not path.exists():
                raise OutputError(f"{path} is a symbolic link to {os.readlink(path)}, which does not exist; make "
                                  "that directory or choose another --out")
            outer = next((parent for parent in path.resolve().parents if is_run_directory(parent)), None)
            if outer is not None:
                raise OutputError(f"{path} is inside the run directory {outer}: a run directory cannot hold "
                                  "another; choose another --out")
        except OSError as err:
            raise OutputError(f"cannot use {path} as a run directory: {_reason(err)}") from None

    def _lock(self) -> None:
        """Lock DIR's marker (creating it) for this process until release(): another process that tries
        is refused.  The marker is never replaced while locked (a new file would not carry the lock)."""
        key = self.path.resolve()
        if key in _LOCKS:
            return
        try:
            fd = os.open(key / MARKER, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as err:
            raise OutputError(f"cannot use {self.path} as a run directory: {_reason(err)}") from None
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            raise OutputError(f"{self.path} is in use by another fem-bounce run; wait for it to end or choose "
                              "another --out") from None
        _LOCKS[key] = fd
        if os.fstat(fd).st_size == 0:
            try:
                _write_all(fd, MARKER_TEXT.encode())
                os.fsync(fd)
            except OSError as err:
                raise OutputError(f"cannot write {self.path / MARKER}: {_reason(err)}") from None

    # -- reserve, write, commit, release --
    def reserve(self, size: int = SUMMARY_RESERVE_BYTES) -> None:
        """Allocate the blocks of the summary's atomic write now, while there is room [bytes]: the
        summary of a run that filled the disk is still written."""
        summary = _partial(self.path / "summary.json")
        try:
            fd = os.open(summary, os.O_WRONLY | os.O_CREAT, 0o644)
            try:
                os.posix_fallocate(fd, 0, size)
            finally:
                os.close(fd)
        except OSError as err:
            with contextlib.suppress(OSError):
                summary.unlink()
            raise OutputError(f"cannot reserve {size // 1024} kB for {self.path / 'summary.json'}: "
                              f"{_reason(err)}") from None

    def trajectory(self, interval: float, columns: tuple, name: str = "trajectory.csv") -> TrajectoryWriter:
        """The writer of DIR/trajectory.csv, or of a side file `name` (a model's own per-step CSV, e.g. the ale
        model's ale_forces.csv): a new file, or after resume() the old one, continued after begin() has cut it
        back.  Every such file is synced with each checkpoint, which records its rows (run.py)."""
        return TrajectoryWriter(self.path / name, interval, continue_from=self._continued.get(name),
                                columns=columns)

    def commit_checkpoint(self, model_name: str, state: dict, data_file: str, arrays: dict) -> None:
        """Write a checkpoint: the model's `arrays` into `data_file` (.npz) of a new folder, then
        state.json and model.txt follow (each fsynced), and the folder is swapped in.  On an error the
        previous checkpoint is kept and OutputError says why."""
        run_dir, final = self.path, self.path / CHECKPOINT
        committed = Checkpoint(final, model_name, state)
        record = committed.run
        if record and record.get("trajectory_error"):  # the rows it would claim are not on the disk
            raise OutputError(f"{record['trajectory_error']}; no checkpoint written")
        partial, old = run_dir / "checkpoint.partial", run_dir / "checkpoint.old"
        archive = io.BytesIO()  # in memory first: a full disk then fails one plain write, not numpy's zip file
        np.savez(archive, **arrays)
        try:
            if partial.exists():
                shutil.rmtree(partial)
            partial.mkdir(parents=True)
            for name, data in ((data_file, archive.getvalue()), ("state.json", json.dumps(state, indent=1).encode()),
                               ("model.txt", (model_name + "\n").encode())):
                fd = os.open(partial / name, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644)
                try:
                    _write_all(fd, data)
                    os.fsync(fd)
                finally:
                    os.close(fd)
            _sync_directory(partial)
            if final.exists():
                final.replace(old)
            partial.replace(final)
            self.checkpoint = committed
            _sync_directory(run_dir)
            if old.exists():
                shutil.rmtree(old)
        except OSError as err:
            with contextlib.suppress(OSError):
                if partial.exists():
                    shutil.rmtree(partial)
            kept = "the previous checkpoint is kept" if (final.exists() or old.exists()) else "no checkpoint is kept"
            raise OutputError(f"cannot write the checkpoint in {run_dir}: {_reason(err)} ({kept})") from None

    def commit_summary(self, data: dict) -> None:
        """DIR/summary.json, into the room reserve() kept; a killed run never leaves half a summary."""
        atomic_write_text(self.path / "summary.json", json.dumps(data, indent=2) + "\n")

    def abandon(self) -> None:
        """A run refused after prepare() or resume() (no room for its summary or its trajectory): remove the
        directory prepare() made, and release() (a directory that was there stays, as resume() left it)."""
        self.release()
        if self._made:
            shutil.rmtree(self.path, ignore_errors=True)

    def release(self) -> None:
        """Give back the room reserve() kept (if the summary did not use it) and this process's lock."""
        with contextlib.suppress(OSError):
            _partial(self.path / "summary.json").unlink()
        fd = _LOCKS.pop(self.path.resolve(), None)
        if fd is not None:
            os.close(fd)

    # -- the checkpoint on the disk --
    def newest_checkpoint(self, required: tuple = ()) -> Checkpoint:
        """The newest whole, readable checkpoint in DIR (`required`: data files it must hold);
        CheckpointError if there is none."""
        run_dir = self.path
        whole = [run_dir / name for name in _NEWEST_FIRST if (run_dir / name / "model.txt").is_file()]
        if not whole:
            found = "it does not exist" if not run_dir.exists() else "it has no checkpoint to restart from"
            raise CheckpointError(f"cannot restart {run_dir}: {found}")
        errors = []
        for folder in whole:
            try:
                found = _read_checkpoint_folder(folder)
                missing = [name for name in required if not (folder / name).is_file()]
                if missing:
                    raise CheckpointError(f"the checkpoint in {run_dir} is unreadable: {folder.name}/{missing[0]}: "
                                          "No such file or directory")
                found.skipped = [str(e) for e in errors]
                return found
            except CheckpointError as err:
                errors.append(err)
        raise errors[0]

    def _settle(self, chosen: Checkpoint) -> None:
        """Make `chosen` DIR/checkpoint again and remove the other copies, so that the next checkpoint
        starts from the usual layout."""
        run_dir, final = self.path, self.path / CHECKPOINT
        try:
            if chosen.folder != final:
                if final.exists():  # older than the chosen copy, or unreadable
                    shutil.rmtree(final)
                chosen.folder.replace(final)
                chosen.folder = final
            for name in _NEWEST_FIRST:
                if name != CHECKPOINT and (run_dir / name).exists():
                    shutil.rmtree(run_dir / name)
            _sync_directory(run_dir)
        except OSError as err:
            raise OutputError(f"cannot restore the checkpoint in {run_dir}: {_reason(err)}") from None


def _flatten(data: dict, prefix: str = "") -> dict:
    flat = {}
    for key, value in data.items():
        if isinstance(value, dict):
            flat.update(_flatten(value, f"{prefix}{key}."))
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def _is_count(value) -> bool:
    """A row count as a checkpoint records it: a whole number >= 0 (not a bool)."""
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _scene_changes(saved_text: str, scene, run_dir: Path) -> list[str]:
    """What differs between a checkpoint's scene and `scene`, beyond RESTART_MAY_CHANGE."""
    try:
        saved = _flatten(tomllib.loads(saved_text))
    except tomllib.TOMLDecodeError as err:
        raise CheckpointError(f"the checkpoint in {run_dir} is unreadable: its scene is not valid TOML ({err}): "
                              "damaged or edited; start a new run") from None
    now = _flatten(tomllib.loads(scenes.dumps(scene)))
    return [f"{key} {saved.get(key, 'unset')!r} -> {now.get(key, 'unset')!r}"
            for key in sorted(saved.keys() | now.keys())
            if saved.get(key) != now.get(key) and key not in RESTART_MAY_CHANGE]


def out_path(text: str | Path | None) -> Path | None:
    """An output directory as the user gave it (--out, out=): an empty string is refused, not read as the
    current directory, and so is a place inside fem_bounce's cache (its runs are the studies' own: a run written
    there by hand would be read back as the cached answer of another scene)."""
    if text is None:
        return None
    if not isinstance(text, (str, os.PathLike)):
        raise OutputError(f"--out {text!r} must be a path (a str or a pathlib.Path)")
    if not str(text).strip():
        raise OutputError("--out is empty: give a directory, e.g. --out runs/mine")
    path = Path(text)
    try:
        resolved, cache = path.resolve(), cachedir.root().resolve()
    except (OSError, RuntimeError):  # a loop of links, ...: RunDirectory says so
        return path
    if resolved == cache or cache in resolved.parents:
        raise OutputError(f"{text} is inside fem_bounce's cache {cache}: its runs belong to the studies "
                          f"(${cachedir.VARIABLE} moves it); choose another --out")
    return path


def unused_directory(base: Path) -> Path:
    """base, or base-2, base-3, ... : the first that does not exist yet."""
    candidate, n = Path(base), 1
    while candidate.exists():
        n += 1
        candidate = Path(f"{base}-{n}")
    return candidate


def segment_path(out_dir: Path) -> Path:
    """The first unused DIR/fields-KKK.xdmf: each segment of a run (one more per --restart) writes its
    own field file, so a restart never rewrites what an earlier segment wrote."""
    k = 0
    while (Path(out_dir) / f"fields-{k:03d}.xdmf").exists():
        k += 1
    return Path(out_dir) / f"fields-{k:03d}.xdmf"


# -- checkpoints --------------------------------------------------------------------------------
#
# DIR/checkpoint/ holds a model's last checkpoint: its data file, state.json and, written last,
# model.txt (the model's name), so a folder holding model.txt is whole.  A new checkpoint is
# written to checkpoint.partial, then checkpoint is renamed to checkpoint.old, checkpoint.partial
# to checkpoint, and checkpoint.old is removed: a kill at any moment leaves at least one whole
# folder, and the newest whole one is what a restart uses.  Every model's state.json carries the
# shared sphere integrator's state under "integrator", and in it the run's record under "run".
# RunDirectory writes, finds and settles them; a Checkpoint is one that was read.

CHECKPOINT = "checkpoint"
_NEWEST_FIRST = ("checkpoint.partial", "checkpoint", "checkpoint.old")


@dataclass
class Checkpoint:
    folder: Path
    model: str
    state: dict
    skipped: list = dataclasses.field(default_factory=list)  # newer copies that were unreadable, and why

    @property
    def run(self) -> dict | None:
        """The run's record (scene, trajectory rows, wall time) saved with the integrator's state."""
        integrator = self.state.get("integrator")
        return integrator.get("run") if isinstance(integrator, dict) else None

    @property
    def wall_time_s(self) -> list[float]:
        """The wall time of each earlier segment of the run, up to this checkpoint [s]."""
        return list((self.run or {}).get("wall_time_s", []))

    def arrays(self, data_file: str) -> dict:
        """The model's arrays saved in `data_file` (.npz) of this checkpoint."""
        try:
            with np.load(self.folder / data_file) as archive:
                return {name: archive[name] for name in archive.files}
        except (OSError, ValueError) as err:
            raise CheckpointError(f"the checkpoint in {self.folder.parent} is unreadable: {data_file}: {err}") from None


def _read_checkpoint_folder(folder: Path) -> Checkpoint:
    def unreadable(name: str, reason: str) -> CheckpointError:
        return CheckpointError(f"the checkpoint in {folder.parent} is unreadable: {folder.name}/{name}: {reason}")

    try:
        model = (folder / "model.txt").read_text().strip()
    except (OSError, UnicodeDecodeError) as err:
        raise unreadable("model.txt", _reason(err)) from None
    try:
        state = json.loads((folder / "state.json").read_text())
    except OSError as err:
        raise unreadable("state.json", _reason(err)) from None
    except ValueError as err:  # JSONDecodeError, UnicodeDecodeError
        raise unreadable("state.json", f"not valid JSON ({err})") from None
    if not isinstance(state, dict):
        raise unreadable("state.json", "holds no state")
    for data in sorted(folder.glob("*.npz")):
        try:
            with zipfile.ZipFile(data) as archive:
                damaged = archive.testzip()
        except (OSError, zipfile.BadZipFile, EOFError) as err:
            raise unreadable(data.name, _reason(err)) from None
        if damaged is not None:
            raise unreadable(data.name, f"{damaged} is damaged")
    return Checkpoint(folder, model, state)


# -- the trajectory ---------------------------------------------------------------------------


def _format_row(values) -> str:
    return ",".join(f"{value:.10g}" for value in values) + "\n"


class TrajectoryWriter:
    """Appends trajectory rows to DIR/trajectory.csv (rank 0), thinned to one per `interval` s if asked.

    Rows are buffered and reach the disk when the buffer fills, at sync() (with every checkpoint,
    which records `rows`) and at close().  A write that fails cuts the file back to its last whole
    row, stops writing and keeps the error in `failure`, for the run to stop on every rank alike;
    sync() and close() raise it.  `rows` counts the data rows written (the header not included);
    `continue_from` opens an existing file of at least that many rows, which RunDirectory.begin() cuts back to
    them."""

    BUFFER_BYTES = 1 << 16

    def __init__(self, path: Path, interval: float = 0.0, continue_from: int | None = None,
                 columns: tuple = TRAJECTORY_COLUMNS):
        self.path = Path(path)
        self.columns = columns
        self.interval = interval
        self.rows = 0 if continue_from is None else continue_from
        self.failure: OutputError | None = None
        self._last_t = -float("inf")
        self._pending: list[str] = []
        self._pending_bytes = 0
        self._fd: int | None = None
        try:
            if continue_from is None:
                self._fd = os.open(self.path, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o644)  # read: to cut a half row
                _write_all(self._fd, ",".join(self.columns).encode() + b"\n")
            else:
                self._fd = os.open(self.path, os.O_RDWR | os.O_APPEND)
        except OSError as err:
            self._fail(err)
            raise self.failure from None

    def __call__(self, row: dict) -> None:
        if self._fd is None or row["t"] - self._last_t < self.interval:
            return
        self._last_t = row["t"]
        line = _format_row(row[c] for c in self.columns)
        self._pending.append(line)
        self._pending_bytes += len(line)
        self.rows += 1
        if self._pending_bytes >= self.BUFFER_BYTES:
            self._flush()

    def _flush(self) -> None:
        if self._fd is None or not self._pending:
            return
        data = "".join(self._pending).encode()
        self._pending.clear()
        self._pending_bytes = 0
        try:
            _write_all(self._fd, data)
        except OSError as err:
            self._fail(err)

    def _fail(self, err: OSError) -> None:
        """Keep the file's whole rows, stop writing, remember why."""
        self.failure = OutputError(f"cannot write {self.path}: {_reason(err)} (its rows up to the failure are kept)")
        if self._fd is not None:
            with contextlib.suppress(OSError):
                _cut_after_last_newline(self._fd)
            with contextlib.suppress(OSError):
                os.close(self._fd)
        self._fd = None
        self._pending.clear()

    def sync(self) -> int:
        """Put every row on the disk; the number of rows in the file."""
        self._flush()
        if self._fd is not None:
            try:
                os.fsync(self._fd)
            except OSError as err:
                self._fail(err)
        if self.failure is not None:
            raise self.failure
        return self.rows

    def close(self) -> None:
        self._flush()
        if self._fd is not None:
            try:
                os.fsync(self._fd)  # on the disk before the summary that counts on it
            except OSError as err:
                self._fail(err)
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
        if self.failure is not None:
            raise self.failure


def _cut_after_last_newline(fd: int) -> None:
    """Truncate an open file after its last newline (drops a half-written row)."""
    end = os.fstat(fd).st_size
    while end > 0:
        start = max(0, end - 65536)
        chunk = os.pread(fd, end - start, start)
        newline = chunk.rfind(b"\n")
        if newline >= 0:
            os.ftruncate(fd, start + newline + 1)
            return
        end = start
    os.ftruncate(fd, 0)


def _trajectory_offset(path: Path, rows: int) -> int:
    """The byte offset just after data row `rows` of a trajectory file (the header is not a data row);
    OutputError if the file is missing or holds fewer whole rows."""
    count, offset = -1, 0
    try:
        with open(path, "rb") as stream:
            for line in stream:
                if not line.endswith(b"\n") or count == rows:
                    break
                count += 1
                offset += len(line)
    except FileNotFoundError:
        raise OutputError(f"{path} is missing, but the checkpoint continues a trajectory of {rows} rows: "
                          "restore it, or start a new run") from None
    except OSError as err:
        raise OutputError(f"cannot read {path}: {_reason(err)}") from None
    if count < rows:
        raise OutputError(f"{path} holds {max(count, 0)} whole rows, but the checkpoint continues a trajectory of "
                          f"{rows} rows: rows were lost (was it edited?); restore it, or start a new run")
    return offset


# -- reading a run directory (plots, studies, comparisons and tests read through these) ------------


def read_trajectory(run_dir: Path) -> dict:
    """DIR/trajectory.csv as {column: numpy array} [SI]."""
    with open(Path(run_dir) / "trajectory.csv", newline="") as stream:
        rows = list(csv.reader(stream))
    data = np.array(rows[1:], dtype=float).reshape(-1, len(rows[0]))
    return {name: data[:, k] for k, name in enumerate(rows[0])}


def read_summary(run_dir: Path) -> dict:
    """DIR/summary.json."""
    return json.loads((Path(run_dir) / "summary.json").read_text())


# -- the summary ----------------------------------------------------------------------------------


def per_body(values: np.ndarray):
    """A per-body array (or N x N matrix) as summary.json has it: one sphere's value as a number, more as a
    list."""
    values = np.asarray(values, dtype=float)
    return values.item() if values.size == 1 else values.tolist()


def body_array(values) -> np.ndarray:
    """Per-body values read back (from a checkpoint) as an array; one sphere's may be a plain number."""
    return np.atleast_1d(np.asarray(values, dtype=float))


def _versions() -> dict:
    found = {"fem_bounce": __version__, "python": platform.python_version()}
    for module in ("numpy", "scipy", "petsc4py", "dolfinx", "gmsh", "mpi4py"):
        mod = sys.modules.get(module)
        if mod is not None:
            found[module] = getattr(mod, "__version__", "?")
    return found


def summary(scene, model: str, integrator, wall_time: float, steps: int, ranks: int, command: str,
            status: str = "completed", sizes: dict | None = None, extra: dict | None = None) -> dict:
    """The summary.json contract (docs/usage.md) plus cost and state details."""
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
        "final": {"time": integrator.time, "gap": per_body(integrator.gaps),
                  "velocity": per_body(integrator.velocities),
                  "in_contact": bool(integrator.wall is not None and integrator.wall.record.in_contact)},
        **({"collisions": integrator.collisions()} if scene.pair else {}),
        **({"oblique_impacts": integrator.oblique_impacts} if scene.oblique else {}),
        "versions": _versions(),
        "command": command,
        "finished_at": time.strftime("%Y-%m-%dT%H:%M:%S"),
        **(extra or {}),
    }
