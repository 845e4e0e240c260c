"""The elastohydrodynamic film's verification: its two limits and its convergence.

    PYTHONPATH=. python benchmarks/ehd_verification.py   # ~2 min on one core

In DSH's groups (fem_bounce/ehd.py; docs/ehd.md sections 2-3), on the grids inner + outer cells:
- rigid limit (epsilon = 0): the film's force at a constant approach against Reynolds' force of the
  undeformed film on the same truncated domain (p = 0 at R_out = 8) and against 6 pi mu a^2 V / h
  (Brenner's lubrication limit) at X = 0.002, on three grids; a free sphere at St 2 and 4 never rebounds
  and stops where the film has taken its momentum (St = int_X^1 g dX);
- dry limit (St 300 and 1000 at a Hertz overlap x_m = 0.3 h0, epsilon from it): the undeformed surfaces
  overlap for Hertz's 2.94 x_m / V0 (Johnson 1985, eq. 11.24), e -> 1;
- convergence of e at St 20 and 200 (steel on Zerodur in 85 % glycerol, h0 = 20 um: epsilon 1.022e-4 at
  St 20, 1.022e-3 at St 200, the speed ten times larger) over three grids and three step tolerances.
The same checks at toy size are tests/test_ehd.py.  Writes benchmarks/history/ehd_verification.json.
"""
from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq

from fem_bounce import ehd
from provenance import commit

ROOT = Path(__file__).resolve().parents[1]
RECORD = ROOT / "benchmarks" / "history" / "ehd_verification.json"
GRIDS = [(60, 30), (120, 60), (240, 120)]
TOLERANCES = [1e-3, 2.5e-4, 6.25e-5]
EPSILON_ST20 = 1.022e-4  # steel-85 at St 20, h0 = 20 um (tests/test_ehd.py)


def truncated_reynolds_force(separation: float, outer: float = 8.0) -> float:
    """The undeformed film's force at X approaching at V0 with p = 0 at R_out (units mu V0 a^2 / h0)."""
    h_out = separation + 0.5 * outer**2
    return 6.0 * math.pi * (1.0 / separation - 1.0 / h_out) - 3.0 * math.pi * outer**2 / h_out**2


def rigid_limit() -> dict:
    out = {"force_error_at_X": {}, "free_sphere": []}
    for inner, outer in GRIDS:
        settings = ehd.FilmSettings(inner_cells=inner, outer_cells=outer, tolerance=1e-5)
        result = ehd.FilmCollision(0.0, 1.0, settings, prescribed_speed=True).run(end_separation=0.002)
        errors = {}
        for target in (0.5, 0.1, 0.01, 0.002):
            i = int(np.argmin(np.abs(result.separation - target)))
            errors[f"{target:g}"] = result.force[i] / truncated_reynolds_force(result.separation[i]) - 1.0
        errors["brenner_at_0.002"] = result.force[-1] * result.separation[-1] / (6.0 * math.pi) - 1.0
        out["force_error_at_X"][f"{inner}+{outer}"] = errors
    for stokes in (2.0, 4.0):
        settings = ehd.FilmSettings(inner_cells=80, outer_cells=160, tolerance=1e-5)
        result = ehd.FilmCollision(0.0, stokes, settings).run()
        def unspent(x_stop, stokes=stokes):  # St - int_X^1 g dX: zero where the film has taken the momentum
            return quad(lambda s: truncated_reynolds_force(s) / (6.0 * math.pi), x_stop, 1.0)[0] - stokes
        x_stop = brentq(unspent, 1e-6, 0.99)
        out["free_sphere"].append({"St": stokes, "outcome": result.outcome, "e": result.restitution,
                                   "largest_V": float(result.velocity.max()), "X_stop": float(result.separation[-1]),
                                   "X_stop_momentum": x_stop})
    return out


def dry_limit() -> list:
    points = []
    for stokes in (300.0, 1000.0):
        eps = 0.3**2.5 / (ehd.HERTZ_DEPTH_FACTOR * stokes)
        result = ehd.FilmCollision(eps, stokes, ehd.FilmSettings()).run()
        points.append({"St": stokes, "epsilon": eps, "outcome": result.outcome, "e": result.restitution,
                       "overlap_time": result.contact_time, "hertz_time": ehd.hertz_contact_time_scaled(stokes, eps)})
    return points


def convergence() -> dict:
    out = {}
    for stokes, eps in ((20.0, EPSILON_ST20), (200.0, 10.0 * EPSILON_ST20)):
        key = f"St {stokes:g}"
        out[key] = {"epsilon": eps, "grids": {}, "tolerances": {}}
        for inner, outer in GRIDS:
            start = time.perf_counter()
            r = ehd.FilmCollision(eps, stokes, ehd.FilmSettings(inner_cells=inner, outer_cells=outer)).run()
            out[key]["grids"][f"{inner}+{outer}"] = {"e": r.restitution, "min_gap": r.min_gap, "steps": r.steps,
                                                     "seconds": round(time.perf_counter() - start, 2)}
        for tol in TOLERANCES:
            r = ehd.FilmCollision(eps, stokes, ehd.FilmSettings(tolerance=tol)).run()
            out[key]["tolerances"][f"{tol:g}"] = {"e": r.restitution, "min_gap": r.min_gap, "steps": r.steps}
        print(key, {g: round(v["e"], 4) for g, v in out[key]["grids"].items()},
              {t: round(v["e"], 4) for t, v in out[key]["tolerances"].items()}, flush=True)
    return out


def main():
    started = time.perf_counter()
    record = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "commit": commit(),
              "command": "PYTHONPATH=. python benchmarks/ehd_verification.py",
              "default_grid": f"{ehd.FilmSettings().inner_cells}+{ehd.FilmSettings().outer_cells}",
              "default_tolerance": ehd.FilmSettings().tolerance}
    record["rigid"] = rigid_limit()
    print("rigid", json.dumps(record["rigid"]), flush=True)
    record["dry"] = dry_limit()
    print("dry", json.dumps(record["dry"]), flush=True)
    record["convergence"] = convergence()
    record["seconds"] = round(time.perf_counter() - started, 1)
    RECORD.write_text(json.dumps(record, indent=1) + "\n")
    print(f"wrote {RECORD} in {record['seconds']} s")


if __name__ == "__main__":
    main()
