"""Figures drawn only from the files a run wrote, so they can be redrawn without re-running.

    python -m fem_bounce.plots runs/li2011-case3-ode     # redraw one run's figures

Units follow the paper: time in sqrt(D/g), velocity in sqrt(g D), gap in D.
"""
from __future__ import annotations

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from . import reference  # noqa: E402
from .output import read_summary, read_trajectory  # noqa: E402,F401 -- also read from here by older scripts


def units(scene: dict) -> tuple[float, float, float]:
    """(D, sqrt(D/g), sqrt(g D)) from a summary's scene."""
    diameter, gravity = scene["sphere"]["diameter"], scene["gravity"]
    return diameter, (diameter / gravity) ** 0.5, (gravity * diameter) ** 0.5


def draw_run(run_dir: Path) -> list[Path]:
    run_dir = Path(run_dir)
    traj, summary = read_trajectory(run_dir), read_summary(run_dir)
    return [trajectory_figure(traj, summary, run_dir / "trajectory.png"),
            velocity_gap_figure(traj, summary, run_dir / "velocity_gap.png")]


def trajectory_figure(traj: dict, summary: dict, path: Path) -> Path:
    scene = summary["scene"]
    diameter, t_unit, v_unit = units(scene)
    ref = scene.get("reference", {})
    fig, (ax_gap, ax_vel) = plt.subplots(2, 1, figsize=(7, 6.5), sharex=True)
    t = traj["t"] / t_unit
    ax_gap.plot(t, traj["gap"] / diameter, lw=1.2, label=f"{summary['model']} model")
    for impact in summary["impacts"]:
        ax_gap.plot(impact["time"] / t_unit, impact["min_gap"] / diameter, "v", color="C3", ms=5)
    for rebound in summary["rebounds"]:
        if rebound["apex_time"] is not None:
            ax_gap.plot(rebound["apex_time"] / t_unit, rebound["apex_gap"] / diameter, "^", color="C2", ms=5)
    contact = scene["contact"]
    ax_gap.axhline(contact["delta_sl"], color="0.6", ls=":", lw=0.8, label=r"$\delta_{sl}$")
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
    ax_vel.set_xlabel(r"$t / \sqrt{D/g}$")
    ax_vel.set_ylabel(r"$V / \sqrt{gD}$ (up +)")
    ax_vel.legend(loc="lower right", fontsize=8)
    fig.suptitle(f"{scene['name']}: {summary['model']} model", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


def velocity_gap_figure(traj: dict, summary: dict, path: Path) -> Path:
    """Like the paper's Fig. 10: velocity against gap, with the approach and rebound near the wall enlarged."""
    scene = summary["scene"]
    diameter, _, v_unit = units(scene)
    delta, v = traj["gap"] / diameter, traj["velocity"] / v_unit
    contact = scene["contact"]
    fig = plt.figure(figsize=(9, 5))
    main = fig.add_subplot(1, 2, 1)
    main.plot(delta, v, lw=1.0)
    main.set_xlabel(r"$\delta = h/D$")
    main.set_ylabel(r"$V/\sqrt{gD}$")
    main.set_title("(a) whole run", fontsize=9)
    zoom = 3.0 * contact["delta_ss"]
    for k, (title, sign) in enumerate([("(b) approach", -1.0), ("(c) rebound", 1.0)]):
        ax = fig.add_subplot(2, 2, 2 * (k + 1))
        keep = (delta < zoom) & (sign * v >= 0.0)
        ax.plot(delta[keep], v[keep], ".", ms=2)
        for name, style in (("delta_ss", "--"), ("delta_sl", ":")):
            if contact[name] < zoom:
                ax.axvline(contact[name], color="0.4", ls=style, lw=0.8)
        ax.set_xlim(0.0, zoom)
        ax.set_title(title + r" near the wall ($\delta_{ss}$ dashed)", fontsize=9)
        ax.set_xlabel(r"$\delta$")
    fig.suptitle(f"{scene['name']}: velocity against gap ({summary['model']} model)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)
    return path


if __name__ == "__main__":
    for folder in sys.argv[1:]:
        for made in draw_run(Path(folder)):
            print(made)
