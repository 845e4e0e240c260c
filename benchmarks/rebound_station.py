"""The first rebound of finished runs seen two ways: the normal speed at gap delta_sl D on the way in and out
(interpolated in the trajectory's rows; the station of summary.json's oblique_impacts "outer"), and the package's e,
the mean speed over the 2 ms after the minimum gap over the 2 ms before it (bounces.Rebound).

    mpiexec -n 2 python benchmarks/oblique_resolved.py --angles 2 --out results/oblique-resolved-2 \
        --record oblique_resolved_2deg
    fem-bounce run li2011-case3 --model M --set run.bounces=1 --out runs/station-M      # M = ode, fd
    fem-bounce run li2011-case3 --model ale --set run.bounces=1 --out runs/station-ale \
        --set numerics.ale.adaptive_step=true --set numerics.ale.min_step_factor=0.05 \
        --set numerics.ale.max_step_factor=1 --set numerics.ale.cells_per_diameter=8 \
        --set numerics.ale.surface_refinement=5
    mpiexec -n 2 fem-bounce run li2011-case3 --model fd3d --set run.bounces=1 --out runs/station-fd3d
    fem-bounce run li2011-case3 --model fd --set run.bounces=1 --out runs/station-fd-c6sr3 \
        --set numerics.fd.cells_per_diameter=6 --set numerics.fd.surface_refinement=3   # fd3d's sizes
    python benchmarks/rebound_station.py results/oblique-resolved-2/fd3d-2 results/oblique-resolved-2/ode-2 \
        runs/station-ode runs/station-fd runs/station-ale runs/station-fd3d runs/station-fd-c6sr3
    python benchmarks/rebound_station.py --gaps 0.02,0.1,0.2,0.3 RUN...   # the rebound speed through the hold

docs/validation.md section 14 ("e_n, nearly head-on") has what they gave.
"""
from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from fem_bounce import output

MEAN_WINDOW = 0.002  # [s] bounces.Rebound's means


def station_restitution(trajectory: dict, height: float) -> tuple[float, float]:
    """(normal speed in, out) [m/s] where the gap passes `height` [m] before and after its minimum."""
    gap, velocity = trajectory["gap"], trajectory["velocity"]
    lowest = int(np.argmin(gap))
    falling, rising = np.flatnonzero(gap[:lowest] > height), np.flatnonzero(gap[lowest:] > height)
    if not (falling.size and rising.size):
        raise SystemExit(f"rebound_station: the gap does not pass {height:.4g} m both ways (its highest "
                         f"{gap[:lowest + 1].max():.4g} m before the impact, {gap[lowest:].max():.4g} m after)")
    before = falling[-1]  # the last row above it on the way in
    after = lowest + rising[0]  # the first on the way out
    speed_in = -np.interp(height, gap[[before + 1, before]], velocity[[before + 1, before]])
    speed_out = np.interp(height, gap[[after - 1, after]], velocity[[after - 1, after]])
    return float(speed_in), float(speed_out)


def mean_restitution(trajectory: dict) -> float:
    """The 2 ms means' ratio, from the gap's travel either side of its minimum."""
    t, gap = trajectory["t"], trajectory["gap"]
    lowest = float(t[int(np.argmin(gap))])
    before, bottom, after = np.interp([lowest - MEAN_WINDOW, lowest, lowest + MEAN_WINDOW], t, gap)
    return float((after - bottom) / (before - bottom))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", type=Path, help="finished run directories")
    parser.add_argument("--gaps", type=lambda text: [float(g) for g in text.split(",")],
                        help="also the normal speed on the way out at these gaps [D], comma-separated")
    args = parser.parse_args()
    for run in args.runs:
        summary = json.loads((run / "summary.json").read_text())
        diameter = summary["scene"]["sphere"]["diameter"]
        height = summary["scene"]["contact"]["delta_sl"] * diameter
        trajectory = output.read_trajectory(run)
        if args.gaps:
            speeds = [station_restitution(trajectory, g * diameter)[1] for g in args.gaps]
            print(f"{str(run):45s} out at gap/D " + ", ".join(f"{g:g}: {v:.4f}" for g, v in zip(args.gaps, speeds))
                  + " m/s")
        speed_in, speed_out = station_restitution(trajectory, height)
        print(f"{str(run):45s} {summary['model']:5s} at delta_sl D: in {speed_in:.4f} m/s, out {speed_out:.4f} m/s, "
              f"e {speed_out / speed_in:.4f};  2 ms means: e {mean_restitution(trajectory):.4f}")


if __name__ == "__main__":
    main()
