# ---
# jupyter:
#   jupytext:
#     formats: py:percent
#     text_representation:
#       extension: .py
#       format_name: percent
#   kernelspec:
#     display_name: Python 3
#     language: python
#     name: python3
# ---

# %% [markdown]
# # fem_bounce from Python: a tutorial
#
# A steel sphere falls through glycerol-water onto a glass wall and bounces: Li, Hunt & Colonius (2011)
# case 3 (density ratio 6.5, released from rest 1.6 D above the wall).  This tutorial drives fem_bounce
# from Python the way a study does: it loads the scene, runs it with the reduced ODE model and with a
# resolved model (the fictitious-domain fd model, which a run without `--model` takes for this scene, at a
# coarse 6 cells per diameter), compares both with the paper's Table 2, changes one contact parameter, and
# sweeps the coefficient of restitution e over a few impact Stokes numbers St.
#
# Run it as a script (about half a minute on one core; the restitution sweep's planning is most of it):
#
#     python demos/tutorial.py --out runs/tutorial
#     mpiexec -n 2 python demos/tutorial.py --out runs/tutorial
#
# or open it as a notebook (`jupytext --to notebook demos/tutorial.py`, or Jupyter with jupytext
# installed opens it directly).  Every name used here is in `help(fem_bounce)` and docs/usage.md.

# %%
import argparse
import json
import math
import sys
from pathlib import Path

import matplotlib

if "ipykernel" not in sys.modules:  # a script (also under mpiexec): files only
    matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from mpi4py import MPI

import fem_bounce as fb

parser = argparse.ArgumentParser(description="fem_bounce from Python: a tutorial")
parser.add_argument("--out", type=Path, default=Path("runs/tutorial"), help="where the figures and runs go")
parser.add_argument("--toy", action="store_true", help="accepted for the test suite: the tutorial is toy-sized")
args, _ = parser.parse_known_args()  # a notebook kernel passes arguments of its own
out = args.out
root = MPI.COMM_WORLD.rank == 0  # under mpiexec every rank runs this; rank 0 prints and draws
say = print if root else (lambda *a, **k: None)
if root:
    out.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## 1. The scene
#
# `fb.load` takes a preset name (`fb.presets()` lists them) or a TOML file, and overrides as dotted keys,
# checked as `fem-bounce run --set` checks them.  We stop each run at the apex after the second impact:
# Table 2 gives the first impact speed and the Reynolds numbers of the first two impacts.

# %%
scene = fb.load("li2011-case3", {"run.bounces": 2})
table2 = scene.reference
say(f"{scene.description}\ndensity ratio {scene.density_ratio:.2f}, D = {scene.sphere.diameter * 1e3:g} mm, "
    f"Table 2: V_i = {table2.impact_speed} m/s, Re_I = {table2.re_first:g}, Re_II = {table2.re_second:g}")

# %% [markdown]
# ## 2. Two models on it
#
# `fb.simulate(scene, model)` runs one model.  Without `out` the run is kept in memory (nothing is left on
# the disk); with `out=DIR` it writes the run directory the command line writes.  Numerical settings of the
# model go by name: `cells_per_diameter=6` is `numerics.fd.cells_per_diameter = 6`.

# %%
ode = fb.simulate(scene, "ode")
fd = fb.simulate(scene, "fd", out=out / "case3-fd", force=True, cells_per_diameter=6)
for result in (ode, fd):
    say(f"{result.model}: {result.status} in {result.wall_time:.1f} s; " + "; ".join(
        f"impact {k}: V_i = {i.impact_speed:.4f} m/s, Re = {i.Re:.1f}, e = {r.restitution:.3f}"
        for k, (i, r) in enumerate(zip(result.impacts, result.rebounds), 1)))

# %% [markdown]
# ## 3. Against Table 2
#
# The impact speed is the mean over the 2 ms before the minimum gap, as the paper measured it; the
# trajectory is a dict of NumPy arrays (`result.to_pandas()` gives a DataFrame when pandas is installed).

# %%
def versus_table2(result: fb.Result) -> dict:
    """V_i, Re_I and Re_II of a run and their relative differences from Table 2."""
    impacts = result.impacts
    found = {"impact_speed": impacts[0].impact_speed, "Re_I": impacts[0].Re,
             "Re_II": impacts[1].Re if len(impacts) > 1 else math.nan}
    measured = {"impact_speed": table2.impact_speed, "Re_I": table2.re_first, "Re_II": table2.re_second}
    return {**found, **{f"{k}_error": found[k] / measured[k] - 1.0 for k in found}}


compared = {result.model: versus_table2(result) for result in (ode, fd)}
say(f"{'':10s} {'V_i [m/s]':>16s} {'Re_I':>14s} {'Re_II':>14s}")
say(f"{'Table 2':10s} {table2.impact_speed:16.3f} {table2.re_first:14.1f} {table2.re_second:14.1f}")
for name, c in compared.items():
    say(f"{name:10s} {c['impact_speed']:8.4f} ({c['impact_speed_error']:+.1%}) {c['Re_I']:6.1f} "
        f"({c['Re_I_error']:+.1%}) {c['Re_II']:6.1f} ({c['Re_II_error']:+.1%})")

if root:
    fig, ax = plt.subplots(figsize=(7, 4))
    for result in (ode, fd):
        ax.plot(result.trajectory["t"], result.trajectory["velocity"], label=f"{result.model} model")
    liquid = scene.liquid
    measured_second = table2.re_second * liquid.viscosity / (liquid.density * scene.sphere.diameter)
    for impact, speed, label in zip(ode.impacts, (table2.impact_speed, measured_second),
                                    ("Table 2: $V_i$", r"Table 2: $Re_{II}$ as a speed")):
        ax.plot(impact.time, -speed, "ks", mfc="none", ms=8, label=label)
    ax.set(xlabel="t [s]", ylabel="V [m/s] (up +)", title="Li et al. (2011) case 3")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "table2.png", dpi=110)

# %% [markdown]
# ## 4. One contact parameter changed
#
# `scene.replace(**{"dotted.key": value})` is a checked variant (a bad value raises `fb.SceneError` naming
# the key, as `--set` does).  The dry coefficient of restitution e_d is what the solids alone would give
# (0.97 for steel on Zerodur); lowering it to 0.6 takes energy from every contact.

# %%
lossy = fb.simulate(scene.replace(**{"contact.dry_restitution": 0.6}), "ode")
say(f"e of the first impact: {ode.rebounds[0].restitution:.3f} with e_d = 0.97, "
    f"{lossy.rebounds[0].restitution:.3f} with e_d = 0.6")
try:
    scene.replace(**{"contact.dry_restitution": 1.5})
except fb.SceneError as err:
    say(f"refused: {err}")

# %% [markdown]
# ## 5. e against the Stokes number
#
# `fb.restitution` is `fem-bounce restitution`: the Table 3 material sets launched at the wall without
# gravity (as on Joseph et al.'s pendulum), e and St taken where the gap passes 0.2 D.  It returns a table,
# a row per run, and its `summary` compares the runs with the Legendre et al. (2006) fit
# e = e_d exp(-35 / St*).  Runs go through a cache, so a second call only reads them back.

# %%
sweep = fb.restitution("ode", points=3, st_range=(10.0, 300.0), cache=out / "cache", out=out / "restitution")
for row in sweep:
    if row["failed"]:
        say(f"{row['scene']:28s} St ~ {row['target_St']:6.2f}  {row['status']}")
    else:
        say(f"{row['scene']:28s} St = {row['St']:6.2f}  e = {row['restitution']:.3f}  (fit {row['fit']:.3f})")
say(f"rms from the fit {sweep.summary['rms_to_fit']:.3f} over {sweep.summary['compared_runs']} runs")
st, e, fit = sweep.column("St"), sweep.column("restitution"), sweep.column("fit")  # NaN for a failed run

if root:
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.semilogx(st, e, "o", label="ode model")
    ax.semilogx(st, fit, "k+", ms=9, label="Legendre et al. (2006) fit at each run's St")
    ax.set(xlabel="impact Stokes number St", ylabel="e (speeds at 0.2 D)", ylim=(-0.03, 1.0))
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "restitution_tutorial.png", dpi=110)

# %% [markdown]
# ## Checks
#
# What the tutorial must show (a script exits with 1 otherwise): both models' first impact speed within
# 15 % of Table 2 (a coarse fd mesh and the ODE model; docs/validation.md has the converged numbers), a
# lossier contact gives a smaller e, and the sweep finds no rebound at its smallest St and one at its
# largest.

# %%
checks = {
    "ode V_i within 15 % of Table 2": abs(compared["ode"]["impact_speed_error"]) <= 0.15,
    "fd V_i within 15 % of Table 2": abs(compared["fd"]["impact_speed_error"]) <= 0.15,
    "e_d = 0.6 rebounds less than e_d = 0.97": lossy.rebounds[0].restitution < ode.rebounds[0].restitution,
    "no rebound at the smallest St, one at the largest": e[np.nanargmin(st)] < 0.01 and e[np.nanargmax(st)] > 0.5,
}
for name, passed in checks.items():
    say(f"check {'PASS' if passed else 'FAIL'}  {name}")
if root:
    (out / "result.json").write_text(json.dumps({"ode": compared["ode"], "fd": compared["fd"],
                                                  "lossy_restitution": lossy.rebounds[0].restitution,
                                                  "sweep": sweep.summary}, indent=1, default=float))
passed = MPI.COMM_WORLD.bcast(all(checks.values()), root=0)
if __name__ == "__main__" and "ipykernel" not in sys.modules:
    sys.exit(0 if passed else 1)
