"""Figures drawn only from the files a run wrote, so they can be redrawn without re-running.

    python -m fem_bounce.plots runs/li2011-case3-ode     # redraw one run's figures

Units follow the paper: time in sqrt(D/g), velocity in sqrt(g D), gap in D; a pair's figure is in
milliseconds, sphere 1's diameter D1 and m/s (a pair may have no gravity).
"""
from __future__ import annotations

import csv
import json
import math
import shutil
import sys
import tempfile
from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt

from . import reference
from .contact import REBOUND_MIN_APEX
from .library_log import quiet_on_a_closed_pipe
from .losses import PHASES
from .output import read_summary, read_trajectory
from .scene import reduced_radius


# The figures' resolution [dots per inch].  They are made at it, not only saved at it: the layout (tight_layout)
# then measures the text with the renderer that draws it, and the drawing reuses those measures (~10 % less work).
DPI = 130


def _saved(fig, path: Path) -> Path:
    """Lay `fig` out, write it to `path` (PNG) and free it."""
    fig.tight_layout()
    fig.savefig(path, dpi="figure")
    plt.close(fig)
    return path


def units(scene: dict) -> tuple[float, float, float]:
    """(D, sqrt(D/g), sqrt(g D)) from a summary's scene; without gravity (a launched sphere) (D, D/V0, V0)."""
    diameter, gravity = scene["sphere"]["diameter"], scene["gravity"]
    if gravity == 0.0:
        speed = abs(scene.get("initial_velocity", 0.0))
        return diameter, diameter / speed, speed
    return diameter, (diameter / gravity) ** 0.5, (gravity * diameter) ** 0.5


def unit_labels(scene: dict) -> tuple[str, str]:
    """The time and velocity units' names, as units() chose them."""
    return (r"$t V_0 / D$", r"$V / |V_0|$") if scene["gravity"] == 0.0 else (r"$t / \sqrt{D/g}$", r"$V / \sqrt{gD}$")


def draw_run(run_dir: Path, trajectory: dict | None = None, summary: dict | None = None) -> list[Path]:
    """A run directory's figures from its files; `trajectory` and `summary` when the caller has read them already
    (the run, which has just written them)."""
    run_dir = Path(run_dir)
    return draw(read_trajectory(run_dir) if trajectory is None else trajectory,
                read_summary(run_dir) if summary is None else summary, run_dir)


def draw(traj: dict, summary: dict, directory: Path) -> list[Path]:
    """A run's figures from its trajectory columns and summary, into directory/trajectory.png (and
    velocity_gap.png for one sphere); fem_bounce.Result.draw draws a run kept in memory through this."""
    directory = Path(directory)
    if "second_sphere" in summary["scene"]:
        return [pair_figure(traj, summary, directory / "trajectory.png")]
    made = [trajectory_figure(traj, summary, directory / "trajectory.png"),
            velocity_gap_figure(traj, summary, directory / "velocity_gap.png")]
    if any("losses" in impact for impact in summary.get("impacts", [])):
        made.append(losses_figure(summary, directory / "losses.png"))
    if "x" in traj:  # an oblique collision
        made.append(path_figure(traj, summary, directory / "path.png"))
    return made


def path_figure(traj: dict, summary: dict, path: Path) -> Path:
    """An oblique collision's path in the plane of incidence (gap against the distance along the wall, drawn to
    scale) and its velocity along the wall, its contact point's and its spin against time."""
    scene = summary["scene"]
    diameter, t_unit, v_unit = units(scene)
    radius = 0.5 * diameter
    fig, (ax_path, ax_along) = plt.subplots(1, 2, figsize=(11, 4.2), dpi=DPI)
    ax_path.plot(traj["x"] / diameter, traj["gap"] / diameter, lw=1.2)
    for impact in summary.get("oblique_impacts", []):
        seen = impact["contact"]
        k = min(range(len(traj["t"])), key=lambda i: abs(traj["t"][i] - seen["time"]))
        ax_path.plot(traj["x"][k] / diameter, traj["gap"][k] / diameter, "v", color="C3", ms=5)
    ax_path.axhline(0.0, color="k", lw=1.0)
    ax_path.set_aspect("equal", adjustable="datalim")
    ax_path.set(xlabel="x / D, along the wall", ylabel="gap h / D", title="the path in the plane of incidence")
    t = traj["t"] / t_unit
    ax_along.plot(t, traj["tangential_velocity"] / v_unit, lw=1.2, label="velocity along the wall U")
    ax_along.plot(t, (traj["tangential_velocity"] - radius * traj["spin"]) / v_unit, lw=1.0,
                  label=r"contact point $U - a\Omega$")
    ax_along.plot(t, radius * traj["spin"] / v_unit, lw=1.0, ls="--", label=r"rolling speed $a\Omega$")
    ax_along.axhline(0.0, color="0.7", lw=0.6)
    ax_along.set(xlabel=unit_labels(scene)[0], ylabel=unit_labels(scene)[1], title="along the wall")
    ax_along.legend(fontsize=8)
    fig.suptitle(f"{scene['name']}: {summary['model']} model, an oblique collision", fontsize=10)
    return _saved(fig, path)


def losses_figure(summary: dict, path: Path, impacts: int = 3) -> Path:
    """Where each of the first `impacts` collisions' momentum went (summary.json's `losses`, fem_bounce.losses):
    every force's impulse in each phase as a share of the momentum the sphere brought in, positive away
    from the wall (on the way in a positive impulse slows the sphere, on the way out a negative one).  The
    axis stops at +-1.2: a bar beyond it (the contact's, which reverses the sphere) is labelled with its value."""
    audited = [(k, impact) for k, impact in enumerate(summary["impacts"]) if "losses" in impact][:impacts]
    fig, axes = plt.subplots(1, len(audited), figsize=(4.6 * len(audited), 4.4), sharey=True, squeeze=False,
                             dpi=DPI)
    colours = {"approach": "C0", "contact": "C3", "rebound": "C2"}
    limit = 1.2
    for ax, (k, impact) in zip(axes[0], audited):
        audit = impact["losses"]
        names = list(audit["share"])
        for j, phase in enumerate(PHASES):
            values = [audit["share"][name][j] for name in names]
            places = [i + (j - 1) * 0.27 for i in range(len(names))]
            ax.bar(places, values, width=0.27, color=colours[phase], label=phase if ax is axes[0][0] else None)
            for x, value in zip(places, values):
                if abs(value) > limit:
                    ax.text(x, 0.93 * limit * (1 if value > 0 else -1), f"{value:.2f}", ha="center", fontsize=7,
                            va="top" if value > 0 else "bottom", color="w", rotation=90)
        ax.axhline(0.0, color="k", lw=0.6)
        ax.set_ylim(-limit, limit)
        ax.set_xticks(range(len(names)))
        ax.set_xticklabels([name.replace("_", " ") for name in names], rotation=45, ha="right")
        out = (f"out at {audit['speed_out']:.3g} m/s" if audit["left_blend_gap"]
               else "apex below delta_sl" if audit["left_contact"] else "stayed in contact")
        ax.set_title(f"impact {k + 1}: St {impact['St']:.3g}; in at {audit['peak_speed']:.3g} m/s, {out}", fontsize=9)
    axes[0][0].set_ylabel("impulse / momentum brought in\n(away from the wall > 0)")
    axes[0][0].legend(fontsize=8)
    fig.suptitle(f"{summary['scene'].get('name', '')} ({summary.get('model', '')}): where the momentum went",
                 fontsize=10)
    return _saved(fig, path)


def _paper(contact: dict) -> bool:
    """The paper's contact model (its elastic layer delta_ss is then drawn)."""
    return contact.get("model") == "li2011"


def trajectory_figure(traj: dict, summary: dict, path: Path) -> Path:
    scene = summary["scene"]
    diameter, t_unit, v_unit = units(scene)
    ref = scene.get("reference", {})
    fig, (ax_gap, ax_vel) = plt.subplots(2, 1, figsize=(7, 6.5), sharex=True, dpi=DPI)
    t = traj["t"] / t_unit
    ax_gap.plot(t, traj["gap"] / diameter, lw=1.2, label=f"{summary['model']} model")
    for impact in summary["impacts"]:
        ax_gap.plot(impact["time"] / t_unit, impact["min_gap"] / diameter, "v", color="C3", ms=5)
    for rebound in summary["rebounds"]:
        if rebound["apex_time"] is not None:
            ax_gap.plot(rebound["apex_time"] / t_unit, rebound["apex_gap"] / diameter, "^", color="C2", ms=5)
    contact = scene["contact"]
    ax_gap.axhline(contact["delta_sl"], color="0.6", ls=":", lw=0.8, label=r"$\delta_{sl}$")
    if _paper(contact):
        ax_gap.axhline(contact["delta_ss"], color="0.3", ls="--", lw=0.8, label=r"$\delta_{ss}$")
    ax_gap.set_ylabel(r"gap $h/D$")
    ax_gap.set_ylim(bottom=0.0)
    ax_gap.legend(loc="upper right", fontsize=8)
    ax_vel.plot(t, traj["velocity"] / v_unit, lw=1.2, label=f"{summary['model']} model")
    if ref.get("velocity_curve"):
        t_exp, u_exp = reference.velocity_curve(ref["velocity_curve"])
        ax_vel.plot(t_exp / t_unit, u_exp / v_unit, "o", ms=3.5, mfc="none", color="k", label="experiment")
    if ref.get("peak_speed"):
        ax_vel.axhline(-ref["peak_speed"] / v_unit, color="k", ls="--", lw=0.8, label="measured peak speed")
    if ref.get("impact_speed") and summary["impacts"]:
        first = summary["impacts"][0]
        ax_vel.plot(first["time"] / t_unit, -ref["impact_speed"] / v_unit, "s", color="k", ms=6, mfc="none",
                    label="measured impact speed (2 ms mean)")
        ax_vel.plot(first["time"] / t_unit, -first["impact_speed"] / v_unit, "x", color="C3", ms=7,
                    label="model impact speed (2 ms mean)")
    ax_vel.axhline(0.0, color="0.7", lw=0.6)
    ax_vel.set_xlabel(unit_labels(scene)[0])
    ax_vel.set_ylabel(unit_labels(scene)[1] + " (up +)")
    ax_vel.legend(loc="lower right", fontsize=8)
    fig.suptitle(f"{scene['name']}: {summary['model']} model", fontsize=10)
    return _saved(fig, path)


def velocity_gap_figure(traj: dict, summary: dict, path: Path) -> Path:
    """Like the paper's Fig. 10: velocity against gap, with the approach and rebound near the wall enlarged."""
    scene = summary["scene"]
    diameter, _, v_unit = units(scene)
    delta, v = traj["gap"] / diameter, traj["velocity"] / v_unit
    contact = scene["contact"]
    fig = plt.figure(figsize=(9, 5), dpi=DPI)
    main = fig.add_subplot(1, 2, 1)
    main.plot(delta, v, lw=1.0)
    main.set_xlabel(r"$\delta = h/D$")
    main.set_ylabel(unit_labels(scene)[1])
    main.set_title("(a) whole run", fontsize=9)
    # the paper's three elastic layers, or the 0.05 D below which a rebound counts as none (contact.py)
    zoom = 3.0 * contact["delta_ss"] if _paper(contact) else REBOUND_MIN_APEX
    for k, (title, sign) in enumerate([("(b) approach", -1.0), ("(c) rebound", 1.0)]):
        ax = fig.add_subplot(2, 2, 2 * (k + 1))
        keep = (delta < zoom) & (sign * v >= 0.0)
        ax.plot(delta[keep], v[keep], ".", ms=2)
        if _paper(contact):
            ax.axvline(contact["delta_ss"], color="0.4", ls="--", lw=0.8)
        ax.set_xlim(min(0.0, delta.min()), zoom)
        ax.set_title(title + (r" near the wall ($\delta_{ss}$ dashed)" if _paper(contact)
                              else " near the wall (below 0: the Hertz overlap)"), fontsize=9)
        ax.set_xlabel(r"$\delta$")
    fig.suptitle(f"{scene['name']}: velocity against gap ({summary['model']} model)", fontsize=10)
    return _saved(fig, path)



def pair_figure(traj: dict, summary: dict, path: Path) -> Path:
    """Two spheres or more: (a) each sphere's lowest point above z = 0, (b) each neighbouring pair's gap
    (and sphere 1's gap to the wall, if there is one) on a log scale with delta_ss and delta_sl, (c) the
    velocities (and a pair's relative one), with the collisions marked."""
    scene = summary["scene"]
    spheres = [scene["sphere"], scene["second_sphere"], *scene.get("further_spheres", ())]
    count, d1 = len(spheres), spheres[0]["diameter"]
    contact, wall = scene["contact"], scene["wall"].get("present", True)
    t = traj["t"] * 1e3
    fig, (ax_pos, ax_gap, ax_vel) = plt.subplots(3, 1, figsize=(7, 8.5), sharex=True, dpi=DPI)
    for k in range(1, count + 1):
        ax_pos.plot(t, traj[f"gap_{k}"] / d1, lw=1.2, label=f"sphere {k}" + (" (lower)" if k == 1 else ""))
        ax_vel.plot(t, traj[f"velocity_{k}"], lw=1.2, label=f"sphere {k}")
    if wall:
        ax_pos.axhline(0.0, color="k", lw=1.0)
    ax_pos.set_ylabel(r"lowest point above $z=0$, $/D_1$")
    ax_pos.legend(loc="best", fontsize=8)
    for k, (lower, upper) in enumerate(zip(spheres, spheres[1:]), start=1):
        pair_d = 2.0 * reduced_radius(0.5 * lower["diameter"], 0.5 * upper["diameter"])  # 2 a*
        column, name = ("pair_gap", "pair gap") if count == 2 else (f"pair_gap_{k}{k + 1}", f"gap {k}-{k + 1}")
        ax_gap.semilogy(t, traj[column] / pair_d, lw=1.2, color=f"C{3 + k}", label=f"{name} $h/2a^*$")
    if wall:
        ax_gap.semilogy(t, traj["gap_1"] / d1, lw=1.0, color="C0", ls="--", label=r"sphere 1 to wall $h_1/D_1$")
    ax_gap.axhline(contact["delta_sl"], color="0.6", ls=":", lw=0.8, label=r"$\delta_{sl}$")
    if _paper(contact):
        ax_gap.axhline(contact["delta_ss"], color="0.3", ls="--", lw=0.8, label=r"$\delta_{ss}$")
    ax_gap.set_ylabel("gap (scaled)")
    ax_gap.legend(loc="best", fontsize=8)
    if count == 2:
        ax_vel.plot(t, traj["velocity_2"] - traj["velocity_1"], lw=0.9, color="C4", ls="--",
                    label=r"relative $V_2 - V_1$")
    collisions = summary.get("collisions", [])
    for k, collision in enumerate(collisions):
        colour = "C2" if collision["kind"] == "wall" else "C3"
        for ax in (ax_gap, ax_vel):
            ax.axvline(collision["time"] * 1e3, color=colour, lw=0.6, ls="-.")
        if k < 4:  # the first few in the legend; summary.json has them all
            label = f"{collision['kind']}: St {collision['St']:.3g}, e {collision.get('restitution', 0.0):.2f}"
            ax_vel.plot([], [], "|", color=colour, label=label)
    ax_vel.axhline(0.0, color="0.7", lw=0.6)
    ax_vel.set_xlabel("t [ms]")
    ax_vel.set_ylabel("V [m/s] (up +)")
    ax_vel.legend(loc="best", fontsize=7)
    walls = sum(c["kind"] == "wall" for c in collisions)
    fig.suptitle(f"{scene['name']}: {summary['model']} model ({len(collisions) - walls} pair and "
                 f"{walls} wall collisions)", fontsize=10)
    return _saved(fig, path)


class DamagedRun(ValueError):
    """A run directory's file that does not hold what a run writes; the message names the file and the fault."""

    def __init__(self, path: Path, fault: str):
        super().__init__(f"{path}: {fault}")


def read_run(run_dir: Path) -> tuple[dict, dict]:
    """(trajectory, summary) of a run directory, checked for what the figures read: DamagedRun naming the file
    and what is wrong with it (OSError when a file cannot be read at all)."""
    run_dir = Path(run_dir)
    return _read_trajectory(run_dir / "trajectory.csv"), _read_summary(run_dir / "summary.json")


def _read_trajectory(path: Path) -> dict:
    """trajectory.csv as {column: array}: a header of names and at least two rows of as many numbers."""
    with open(path, newline="") as stream:
        rows = list(csv.reader(stream))
    if not rows or not any(rows[0]):
        raise DamagedRun(path, "it is empty (a run writes a header and a row per step)")
    header = rows[0]
    for line, row in enumerate(rows[1:], start=2):
        if len(row) != len(header):
            raise DamagedRun(path, f"line {line} has {len(row)} values for the header's {len(header)} columns")
        for name, value in zip(header, row):
            try:
                float(value)
            except ValueError:
                raise DamagedRun(path, f"line {line}: {name} = {value[:40]!r} is not a number") from None
    if len(rows) < 3:
        raise DamagedRun(path, f"it has {'no rows' if len(rows) == 1 else 'one row'} below its header (a run writes "
                               "one a step: nothing to draw)")
    data = np.array(rows[1:], dtype=float)
    return {name: data[:, k] for k, name in enumerate(header)}


def _read_summary(path: Path) -> dict:
    try:
        summary = json.loads(path.read_text())
    except json.JSONDecodeError as err:
        raise DamagedRun(path, f"not JSON ({err.msg} at line {err.lineno}, column {err.colno})") from None
    except UnicodeDecodeError:
        raise DamagedRun(path, "not text (UTF-8 JSON)") from None
    if not isinstance(summary, dict):
        raise DamagedRun(path, f"not an object of the run's records but a {type(summary).__name__}")
    return summary


def _number(value) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def check_run(traj: dict, summary: dict, run_dir: Path) -> None:
    """The entries of trajectory.csv and summary.json that the figures read, each of the kind a run writes:
    DamagedRun naming the file and the first entry that is not."""
    run_dir = Path(run_dir)
    where = run_dir / "summary.json"

    def table(owner: dict, key: str, name: str) -> dict:
        value = owner.get(key) if isinstance(owner, dict) else None
        if not isinstance(value, dict):
            raise DamagedRun(where, f"{name} is {'missing' if value is None else 'not a table'}")
        return value

    def numbers(owner: dict, name: str, keys, optional: bool = False) -> None:
        for key in keys:
            value = owner.get(key)
            if not (_number(value) or (optional and value is None)):
                raise DamagedRun(where, f"{name}.{key} = {value!r} is not a number")

    if not isinstance(summary.get("model"), str):
        raise DamagedRun(where, f"model = {summary.get('model')!r} is not a model's name")
    scene = table(summary, "scene", "scene")
    numbers(table(scene, "sphere", "scene.sphere"), "scene.sphere", ["diameter"])
    numbers(scene, "scene", ["gravity"])
    numbers(table(scene, "contact", "scene.contact"), "scene.contact", ["delta_sl", "delta_ss"])
    if not scene["sphere"]["diameter"] > 0.0:
        raise DamagedRun(where, f"scene.sphere.diameter = {scene['sphere']['diameter']!r} is not positive")
    pair = "second_sphere" in scene  # a pair's figure is in ms and m/s; one sphere's in units of its motion
    if not pair and scene["gravity"] == 0.0 and not (_number(scene.get("initial_velocity"))
                                                     and scene["initial_velocity"] != 0.0):
        raise DamagedRun(where, "scene.gravity = 0 and no initial_velocity: no unit to scale the figures with")
    lists = {"collisions": ["time", "St"]} if pair else {"impacts": ["time", "min_gap"], "rebounds": []}
    for key, needed in lists.items():
        entries = summary.get(key)
        if not isinstance(entries, list) or not all(isinstance(entry, dict) for entry in entries):
            raise DamagedRun(where, f"{key} = {str(entries)[:40]} is not a list of records")
        for k, entry in enumerate(entries):
            numbers(entry, f"{key}[{k}]", needed)
            if key == "rebounds":
                numbers(entry, f"{key}[{k}]", ["apex_time", "apex_gap"], optional=True)
                if "apex_time" not in entry or (entry["apex_time"] is not None) != _number(entry.get("apex_gap")):
                    raise DamagedRun(where, f"rebounds[{k}] has no apex_time and apex_gap (both numbers, or "
                                            "apex_time null)")
            if key == "collisions" and not isinstance(entry.get("kind"), str):
                raise DamagedRun(where, f"collisions[{k}].kind = {entry.get('kind')!r} is not a contact's name")
    if pair:
        spheres = [scene["second_sphere"], *scene.get("further_spheres", ())]
        for k, sphere in enumerate(spheres, start=2):
            if not (isinstance(sphere, dict) and _number(sphere.get("diameter"))):
                raise DamagedRun(where, f"sphere {k}'s diameter is missing or not a number")
        pair_gaps = ["pair_gap"] if len(spheres) == 1 else [f"pair_gap_{k}{k + 1}" for k in range(1, len(spheres) + 1)]
        bodies = range(1, len(spheres) + 2)
        columns = ["t", *(f"{kind}_{k}" for k in bodies for kind in ("gap", "velocity")), *pair_gaps]
    else:
        columns = ["t", "gap", "velocity", *(("x", "tangential_velocity", "spin") if "x" in traj else ())]
    missing = next((name for name in columns if name not in traj), None)
    if missing:
        raise DamagedRun(run_dir / "trajectory.csv", f"no column {missing!r} (a run's has {', '.join(columns)})")


def redraw(run_dir: Path) -> list[Path]:
    """Check a run directory's files (check_run) and draw its figures from them: each is drawn into a hidden folder
    beside them and moved into place only when all are, so a failure leaves the old figures (or none)."""
    run_dir = Path(run_dir)
    traj, summary = read_run(run_dir)
    check_run(traj, summary, run_dir)
    scratch = Path(tempfile.mkdtemp(prefix=".figures-", dir=run_dir))
    try:
        made = draw(traj, summary, scratch)
        return [made_file.replace(run_dir / made_file.name) for made_file in made]
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def main(argv: list[str]) -> int:
    """python -m fem_bounce.plots RUN_DIR...: redraw run directories' figures; one line for each that cannot be
    (naming the damaged file and what is wrong in it), and no figure of it left behind.  Under mpiexec rank 0
    alone draws and speaks (the others would write the same files at once)."""
    from mpi4py import MPI  # loaded already with the package

    if MPI.COMM_WORLD.rank != 0:
        return 0
    if not argv or argv[0] in ("-h", "--help"):
        print("usage: python -m fem_bounce.plots RUN_DIR [RUN_DIR ...]  (redraw a run's figures)", file=sys.stderr)
        return 0 if argv else 2
    status = 0
    with quiet_on_a_closed_pipe():  # `... | head -1`: the rest is drawn, not reported as a failure to draw
        for folder in argv:
            try:
                for made in redraw(Path(folder)):
                    print(made)
            except DamagedRun as err:
                print(f"fem-bounce plots: error: cannot draw {folder}: {err}", file=sys.stderr)
                status = 2
            except (OSError, ValueError, KeyError, IndexError, TypeError) as err:
                reason = err.strerror if isinstance(err, OSError) and err.strerror else f"{type(err).__name__}: {err}"
                where = f" ({err.filename})" if isinstance(err, OSError) and err.filename else ""
                print(f"fem-bounce plots: error: cannot draw {folder}: {reason}{where}; is it a run directory with "
                      "trajectory.csv and summary.json?", file=sys.stderr)
                status = 2
    return status


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
