"""Oblique impacts: a sweep of incidence angles at one launch speed, the sphere's rebound angle, its normal and
tangential restitution and its spin against the rigid-body theory of Coulomb friction.

    fem-bounce study oblique foerster1994-glass --jobs 2          # dry glass, psi_in 0 to 1.4
    fem-bounce study oblique joseph-hunt2004-steel --angles 5,15,30,45,60
    fem-bounce study oblique yang-hunt2006-pair --set contact.friction=0.02 --angles 5,15,30,45,60   # a pair
    mpiexec -n 2 fem-bounce study oblique li2011-case3 --model fd3d --angles 30,60 --set gravity=0 ...  # resolved

The scene's sphere is launched at the wall (initial_velocity < 0, the launch speed V) and each run of the sweep
sends it at the angle theta to the normal: initial_velocity = -V cos(theta), tangential_velocity = V sin(theta)
(no spin).  A pair's second sphere (second_sphere.velocity < 0) is aimed past the first's centre by (a_1 + a_2)
sin(theta), so that its straight path would meet the first at theta to the line of centres (the liquid bends it:
psi_in is the one measured), and its impacts are read from its own view (pair_oblique.PairTangentialMotion.record).
With --model fd3d the 3-D resolved flow runs them, its launched sphere starting in liquid at rest (it gives the
liquid its added mass's momentum at once, where the ode model's starts with its added mass moving with it: the two
are compared on a fall from rest onto an inclined wall instead, docs/validation.md section 14).  Each impact is
read where the sphere crosses delta_sl D (a pair's gap delta_sl 2a*) on the way in and out (the collision with its
layer of liquid, where the package's restitution is taken) and at the contact gap (the solids' collision within
the film): psi = v_t / v_n,in of the contact point, as Joseph & Hunt (2004) plot theirs.  The rigid theory
(tangential_contact.oblique_rigid_theory) is drawn with the scene's friction and the mean normal restitution at
the contact.  Writes oblique.csv, oblique.json and oblique.png.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import scene as scenes
from ..output import read_summary
from ..tangential_contact import oblique_rigid_theory
from .common import StudyDirectory
from .runner import Runner

ANGLES = tuple(float(a) for a in np.linspace(2.0, 80.0, 40))  # degrees from the normal


def launch_speed(base: scenes.Scene) -> float:
    """The speed the sweep launches at: the sphere's at the wall, or the second sphere's at the first."""
    return abs(base.second_sphere.velocity if base.second_sphere is not None else base.initial_velocity)


def check(base: scenes.Scene, angles) -> None:
    """Refuse a sweep that cannot run before anything is written."""
    if base.second_sphere is not None and base.second_sphere.velocity >= 0.0:
        raise scenes.SceneError(f"the oblique study of a pair launches the second sphere at the first: "
                                f"second_sphere.velocity = {base.second_sphere.velocity:g} m/s must be < 0 (its size "
                                "is the launch speed)")
    if base.second_sphere is None and base.initial_velocity >= 0.0:
        raise scenes.SceneError(f"the oblique study launches the sphere at the wall: initial_velocity = "
                                f"{base.initial_velocity:g} m/s must be < 0 (its size is the launch speed)")
    if base.contact.friction is None:
        raise scenes.SceneError("the oblique study needs contact.friction, the material pair's Coulomb coefficient")
    bad = [a for a in angles if not (math.isfinite(a) and 0.0 < a < 90.0)]
    if bad or not angles:
        raise scenes.SceneError(f"--angles: expected degrees in (0, 90) from the wall's normal, got "
                                f"{', '.join(f'{a:g}' for a in bad) or 'none'}")
    twice = sorted({a for a in angles if angles.count(a) > 1})
    if twice:
        raise scenes.SceneError(f"--angles names {', '.join(f'{a:g}' for a in twice)} more than once")


def scene_at(base: scenes.Scene, angle: float) -> scenes.Scene:
    """The sweep's run at `angle` degrees: the sphere launched at the wall at that angle to its normal; a pair's
    second sphere aimed past the first's centre by (a_1 + a_2) sin(angle) (the impact parameter whose straight path
    meets it at that angle to the line of centres), from where it starts (the line of centres along z)."""
    speed, theta, name = launch_speed(base), math.radians(angle), f"{base.name}-oblique-{angle:g}"
    second = base.second_sphere
    if second is None:
        return base.replace(initial_velocity=-speed * math.cos(theta), tangential_velocity=speed * math.sin(theta),
                            spin=0.0, name=name)
    contact = base.sphere.radius + second.radius
    aim = math.asin(contact * math.sin(theta) / (contact + second.gap))  # to the line of centres at the start
    return base.replace(**{"second_sphere.velocity": -speed * math.cos(aim),
                           "second_sphere.tangential_velocity": speed * math.sin(aim), "second_sphere.spin": 0.0},
                        name=name)


def run(base: scenes.Scene, comm, out: Path, angles=ANGLES, runner: Runner | None = None,
        model: str = "ode") -> list[dict]:
    angles = [float(a) for a in angles]
    check(base, angles)
    study = StudyDirectory(out, comm)
    runner = runner or Runner(comm)
    trials = [scene_at(base, angle).replace(**{"run.bounces": 1}) for angle in angles]
    study.log(f"{len(trials)} oblique runs of {base.name} with the {model} model, {runner.describe()} (finished runs "
              "come from the cache)")
    rows: list = [None] * len(trials)
    for k, run_dir in runner.run([(trial, model) for trial in trials]):
        summary = read_summary(run_dir)
        row = {"angle_deg": angles[k], "status": summary["status"], "run_dir": str(run_dir)}
        found = summary.get("oblique_impacts") or []
        for station in ("outer", "contact"):
            seen = found[0][station] if found else None
            for key in ("psi_in", "psi_out", "normal_restitution", "tangential_restitution", "effective_friction",
                        "spin_out", "incidence_deg"):
                value = None if seen is None else seen[key]
                row[f"{key}_{station}"] = value[-1] if isinstance(value, list) else value  # a pair's: sphere 2's spin
        rows[k] = row
        station = "outer" if row["psi_in_outer"] is not None else "contact"
        seen = (f"psi_in {row[f'psi_in_{station}']:.4g}, psi_out {row[f'psi_out_{station}']:.4g} at the {station} "
                "station" if row[f"psi_in_{station}"] is not None else "no contact")
        study.log(f"{angles[k]:g} deg: {summary['status']}, {seen}")
    study.write_csv("oblique.csv", rows)
    contact_e = [r["normal_restitution_contact"] for r in rows if r["normal_restitution_contact"] is not None]
    theory = {"friction": base.contact.friction, "normal_restitution": float(np.mean(contact_e)) if contact_e else None}
    if contact_e:
        study.log(rigid_agreement(rows, theory))
    study.write_json("oblique.json", {"scene": base.name, "model": model, "launch_speed": launch_speed(base),
                                      "rigid_theory": theory, "runs": rows})
    if comm.rank == 0:
        figure(rows, theory, f"{base.name} ({model})", out / "oblique.png",
               "delta_sl 2a*" if base.second_sphere is not None else "delta_sl D")
    return rows


def rigid_agreement(rows: list[dict], theory: dict) -> str:
    """One line: the contact station against the rigid theory with each run's own e_n, the largest relative
    difference in psi_out of the runs it says slide and the largest |psi_out| / psi_in of those it says roll (0
    in the theory; Mindlin's spring reverses the contact point there, a stiff one stops it: docs/validation.md
    section 13)."""
    worst = {True: None, False: None}
    for row in rows:
        psi_in, psi_out = row["psi_in_contact"], row["psi_out_contact"]
        if psi_in is None or psi_in == 0.0:
            continue
        rigid = oblique_rigid_theory(psi_in, row["normal_restitution_contact"], theory["friction"])
        error = abs(psi_out - rigid.psi_out) / abs(rigid.psi_out if rigid.sliding else psi_in)
        worst[rigid.sliding] = max(error, worst[rigid.sliding] or 0.0)
    said = [text.format(worst[key]) for key, text in ((True, "sliding, psi_out within {:.2g} of it (relative)"),
                                                     (False, "rolling, |psi_out| within {:.2g} psi_in of 0"))
            if worst[key] is not None]
    return f"against the rigid theory (mu {theory['friction']:g}) at the contact: " + (", ".join(said) or "no runs")


def figure(rows: list[dict], theory: dict, scene_name: str, path: Path, outer: str = "delta_sl D") -> None:
    """psi_out against psi_in (both stations, `outer` the outer one's gap) with the rigid theory, and e_n, e_t against
    psi_in."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    for station, marker, label in (("outer", "o", f"at {outer} (with its liquid)"),
                                   ("contact", "s", "at the contact (the solids, within the film)")):
        pairs = [(r[f"psi_in_{station}"], r[f"psi_out_{station}"]) for r in rows if r[f"psi_in_{station}"] is not None]
        if pairs:
            x, y = np.array(pairs).T
            left.plot(x, y, marker, ms=4, mfc="none", label=label)
            et = [(r[f"psi_in_{station}"], r[f"tangential_restitution_{station}"], r[f"normal_restitution_{station}"])
                  for r in rows if r[f"tangential_restitution_{station}"] is not None]
            if et:
                px, pt, pn = np.array(et).T
                right.plot(px, pt, marker, ms=4, mfc="none", label=f"e_t {label.split(' (')[0]}")
                right.plot(px, pn, marker, ms=4, label=f"e_n {label.split(' (')[0]}")
    if theory["normal_restitution"] is not None:
        top = max([r["psi_in_contact"] or 0.0 for r in rows] + [0.1])
        grid = np.linspace(0.0, top, 200)
        rigid = [oblique_rigid_theory(p, theory["normal_restitution"], theory["friction"]).psi_out for p in grid]
        left.plot(grid, rigid, "k-", lw=1,
                  label=f"rigid theory, mu {theory['friction']:g}, e_n {theory['normal_restitution']:.3f}")
    left.axhline(0.0, color="0.7", lw=0.6)
    left.set(xlabel="psi_in = v_t,in / v_n,in (contact point)", ylabel="psi_out = v_t,out / v_n,in",
             title=f"{scene_name}: oblique impacts")
    right.set(xlabel="psi_in", ylabel="restitution", ylim=(-1.05, 1.05), title="normal and tangential restitution")
    left.legend(fontsize=8)
    right.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)
