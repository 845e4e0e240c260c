"""The fd model's validation cases, each run and compared with its published reference.

    brenner_drag(comm, out_dir, deltas=(1, 0.5, 0.25))   Stokes wall drag, Brenner (1961) lambda
    drag_coefficient(comm, out_dir, reynolds=100)        fixed sphere in a stream, Cd (Johnson & Patel 1999)
    settling(comm, out_dir)                              ten Cate et al. (2002) E4 peak speed
    bouncing(comm, out_dir, case=3)                      Li et al. (2011) Table 2 impact speed, Re_I, Re_II

Each function runs `fem_bounce.run.simulate` with `overrides` (dotted scene keys, e.g.
{"numerics.fd.cells_per_diameter": 32}) and returns a dict of measured numbers, the
reference and the relative error.  The demos (demos/*.py) call them at one size and
check the result; benchmarks/fd_validation.py calls them at full resolution and
records the numbers.  Only the run's files are read back, so results are the same
on every rank.
"""
from __future__ import annotations

import math
import sys
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import output, reference
from .. import scene as scenes
from ..run import simulate


@dataclass(frozen=True)
class Check:
    """One comparison with a reference: passed when |value / reference - 1| <= tolerance.  A target
    that is not `required` is reported (PASS or MISS with its number) without failing the caller."""

    name: str
    value: float
    reference: float
    tolerance: float
    required: bool = True

    @property
    def error(self) -> float:
        return self.value / self.reference - 1.0

    @property
    def passed(self) -> bool:
        return abs(self.error) <= self.tolerance


def report(checks: list[Check], stream=None) -> bool:
    """Print one line per check to `stream` (sys.stdout as it is at the call); True when every required check
    passed."""
    stream = sys.stdout if stream is None else stream
    for c in checks:
        verdict = "PASS" if c.passed else ("FAIL" if c.required else "MISS")
        kind = "check " if c.required else "target"
        print(f"{kind} {verdict}  {c.name}: {c.value:.5g} vs {c.reference:.5g} ({c.error:+.2%}, "
              f"tolerance {c.tolerance:.0%})", file=stream)
    return all(c.passed for c in checks if c.required)


def _run(comm, name: str, out_dir: Path, overrides: dict | None, model: str = "fd", **changes) -> tuple:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # Re warnings: these scenes are chosen deliberately
        scene = scenes.load(name, {**changes, **(overrides or {})})
    summary = simulate(scene, model, comm, out_dir, force=True, progress=False)
    return scene, summary, output.read_trajectory(out_dir)


def brenner_drag(comm, out_dir: Path, deltas=(1.0, 0.5, 0.25), overrides: dict | None = None) -> list[dict]:
    """lambda = F / (6 pi mu a V) of a held sphere approaching the wall at Re -> 0, one gap at a time
    (numerics.fd.steady_stokes: the step's exact steady state).  The gap is delta times the sphere's diameter,
    the preset's 0.01 m unless `overrides` sets sphere.diameter."""
    table = {row["delta"]: row["lambda_brenner"] for row in reference.table("brenner1961_wall_drag")}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        diameter = scenes.load("brenner-approach", overrides).sphere.diameter
    rows = []
    for delta in deltas:
        scene, summary, trajectory = _run(comm, "brenner-approach", Path(out_dir) / f"delta-{delta:g}", overrides,
                                          **{"initial_gap": delta * diameter, "numerics.fd.steady_stokes": True})
        stokes = 6.0 * math.pi * scene.liquid.viscosity * scene.sphere.radius * abs(scene.motion.velocity)
        measured = -trajectory["f_sim"][-1] * math.copysign(1.0, scene.motion.velocity) / stokes
        rows.append({"delta": delta, "lambda": measured, "reference": table[delta],
                     "error": measured / table[delta] - 1.0, "cells": summary["sizes"]["cells"],
                     "wall_time_s": summary["wall_time_s"]})
    return rows


def drag_coefficient(comm, out_dir: Path, reynolds: int = 100, overrides: dict | None = None) -> dict:
    """Cd = F / (rho U^2 pi a^2 / 2) of a held sphere in a uniform stream, marched to steady state;
    `settling` is the relative change of Cd over the last 10 % of the run (how steady it got)."""
    rows = {int(r["Re"]): r for r in reference.table("sphere_drag_reference")}
    scene, summary, trajectory = _run(comm, f"sphere-drag-re{reynolds}", out_dir, overrides)
    speed = scene.motion.stream_velocity
    cd = scene.drag_coefficient(trajectory["f_sim"], speed)
    late = trajectory["t"] >= 0.9 * trajectory["t"][-1]
    target = rows[reynolds]["Cd_reference"]
    return {"Re": scene.reynolds(speed), "Cd": float(cd[-1]), "reference": target, "error": cd[-1] / target - 1.0,
            "settling": float(abs(cd[late][0] / cd[-1] - 1.0)), "cells": summary["sizes"]["cells"],
            "steps": summary["steps"], "wall_time_s": summary["wall_time_s"]}


def settling(comm, out_dir: Path, overrides: dict | None = None) -> dict:
    """ten Cate E4: the largest settling speed against the measured 0.1226 m/s, and the RMS distance to
    the digitised velocity curve while the sphere approaches (until the measured speed falls below
    95 % of its peak: the digitised curve's integral overshoots the 120 mm fall by 3 %, so its timing
    near the floor is not reliable)."""
    scene, summary, trajectory = _run(comm, "tencate2002-e4", out_dir, overrides)
    peak = float(-trajectory["velocity"].min())
    target = scene.reference.peak_speed
    t_exp, u_exp = reference.velocity_curve(scene.reference.velocity_curve)
    slowing = (t_exp > t_exp[np.argmin(u_exp)]) & (-u_exp < 0.95 * (-u_exp.min()))
    end = t_exp[slowing][0] if slowing.any() else t_exp[-1]
    inside = (t_exp < end) & (t_exp <= trajectory["t"][-1])
    model = np.interp(t_exp[inside], trajectory["t"], trajectory["velocity"])
    return {"peak_speed": peak, "reference": target, "error": peak / target - 1.0,
            "curve_rms": float(np.sqrt(np.mean((model - u_exp[inside]) ** 2))), "cells": summary["sizes"]["cells"],
            "steps": summary["steps"], "wall_time_s": summary["wall_time_s"], "status": summary["status"]}


def bouncing(comm, out_dir: Path, case: int = 3, overrides: dict | None = None) -> dict:
    """Li et al. (2011) case 1-7: impact speeds and Reynolds numbers of the first two impacts, the
    rebounds, against Table 2 (V_i is the mean speed over the 2 ms before the minimum gap)."""
    row = next(r for r in reference.table("li2011_table2_experiments") if int(r["case"]) == case)
    scene, summary, _ = _run(comm, f"li2011-case{case}", out_dir, overrides)
    impacts, rebounds = summary["impacts"], summary["rebounds"]
    result = {"case": case, "impact_speed": impacts[0]["impact_speed"] if impacts else None,
              "impact_speed_reference": row["V_i_m_per_s"], "Re_I": impacts[0]["Re"] if impacts else None,
              "Re_I_reference": row["Re_I"], "Re_II": impacts[1]["Re"] if len(impacts) > 1 else None,
              "Re_II_reference": row["Re_II"], "St_I": impacts[0]["St"] if impacts else None,
              "rebounds": sum(r["apex_gap"] is not None for r in rebounds),
              "apex_gaps": [r["apex_gap"] for r in rebounds], "cells": summary["sizes"]["cells"],
              "steps": summary["steps"], "wall_time_s": summary["wall_time_s"], "status": summary["status"]}
    if result["impact_speed"] is not None:
        result["impact_speed_error"] = result["impact_speed"] / row["V_i_m_per_s"] - 1.0
    if result["Re_II"] is not None:
        result["Re_II_error"] = result["Re_II"] / row["Re_II"] - 1.0
    return result
