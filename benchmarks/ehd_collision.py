"""The film during case 3's first collision (contact.model = "ehd"): its pressure,
thickness and the surfaces' deformation at five instants, and its gaps, force and speed against time.

    PYTHONPATH=. python benchmarks/ehd_collision.py              # 10-26 s on one core (two ODE runs, four films)
    PYTHONPATH=. python benchmarks/ehd_collision.py --plot-only  # redraw from the record

The collision is the one a run solves: `fem-bounce run li2011-case3 --model ode --set contact.model=ehd`
(and with `--set contact.cavitation_pressure=-101325`) is run in memory to its first film collision, and the
arguments the run hands to contact.ContactLaw.collide (V_in at h0, the inertia m_p + C_M(h0) m_l, minus
the net weight; integrator.BodyIntegrator._film_jump) are recorded by wrapping that method: nothing is
typed in.  The film is then solved again by fem_bounce.ehd.collide with the same arguments, first to find
the instants, then keeping the film there (`snapshot_times`; the same steps, so the same numbers: checked
against the run's film restitution).  Instants (T in h0 / V_in): approach (the undeformed surfaces'
separation X = 0.1 h0, inbound), maximum load, the overlap's end (X = 0 outbound: the undeformed surfaces
part), the film's largest tension (the most negative force), separation (X = 0.1 h0 outbound).

Writes benchmarks/history/ehd_collision.json (SI: um, MPa, us, N, m/s) and docs/figures/ehd_case3_film.png
(no cavitation limit), docs/figures/ehd_case3_film_cavitation.png (p >= -101325 Pa); the figures read only
the record.
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

import fem_bounce as fb
from fem_bounce import contact, ehd
from provenance import commit

ROOT = Path(__file__).resolve().parents[1]
RECORD = ROOT / "benchmarks" / "history" / "ehd_collision.json"
FIGURES = {"off": ROOT / "docs" / "figures" / "ehd_case3_film.png",
           "-101325 Pa": ROOT / "docs" / "figures" / "ehd_case3_film_cavitation.png"}
CAVITATION = {"off": "off", "-101325 Pa": -101325.0}
INSTANTS = ("approach", "maximum load", "overlap ends", "largest tension", "separation")
SIGNIFICANT = 6  # digits kept in the record


def _rounded(values) -> list:
    return [float(f"{v:.{SIGNIFICANT}g}") for v in np.asarray(values, dtype=float)]


def first_collision(cavitation: str) -> tuple[dict, fb.Scene]:
    """The arguments case 3's run hands to ContactLaw.collide at its first film collision, and the scene."""
    changes = {"contact.model": "ehd", "run.bounces": 1}
    changes["contact.cavitation_pressure"] = CAVITATION[cavitation]
    scene = fb.load("li2011-case3").replace(**changes)
    seen = []
    solve = contact.ContactLaw.collide

    def spy(law, speed, mass, force=0.0):
        result = solve(law, speed, mass, force)
        seen.append(dict(radius=law.radius, mass=mass, e_star=law.e_star, viscosity=law.viscosity, speed=speed,
                         handover_gap=law.handover, cavitation_pressure=law.cavitation, external_force=force,
                         restitution=result.restitution))
        return result
    contact.ContactLaw.collide = spy
    try:
        run = fb.simulate(scene, "ode")
    finally:
        contact.ContactLaw.collide = solve
    if not seen:
        raise RuntimeError("case 3 with contact.model = ehd reached no film collision")
    first = seen[0]
    if not math.isclose(run.impacts[0].contact_speed, first["speed"], rel_tol=1e-12):
        raise RuntimeError("the recorded collision is not the run's first impact")
    return first, scene


def instants(result: ehd.FilmResult) -> dict:
    """T (h0 / V_in) of the five instants of the module docstring, from a film's time series."""
    t, x, f = result.time, result.separation, result.force
    peak = int(np.argmax(f))
    inbound = np.flatnonzero(x[:peak] <= 0.1)
    after = np.arange(peak, t.size)
    ends = after[x[after] >= 0.0]
    separates = after[x[after] >= 0.1]
    found = {"approach": t[inbound[0]] if inbound.size else None, "maximum load": t[peak],
             "overlap ends": t[ends[0]] if ends.size else None, "largest tension": t[int(np.argmin(f))],
             "separation": t[separates[0]] if separates.size else None}
    return {name: float(value) for name, value in found.items() if value is not None}


def compute() -> dict:
    started = time.perf_counter()
    record = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "commit": commit(),
              "command": "PYTHONPATH=. python benchmarks/ehd_collision.py", "scene": "li2011-case3",
              "instants": "T at the first accepted step at or after: approach (X = 0.1 h0 inbound), maximum load, "
                          "overlap ends (X = 0 outbound), largest tension (min force), separation (X = 0.1 h0 "
                          "outbound)", "cavitation": {}}
    for name, p_cav in CAVITATION.items():
        args, scene = first_collision(name)
        run_restitution = args.pop("restitution")
        h0, speed = args["handover_gap"], args["speed"]
        added = args["mass"] - scene.sphere.mass
        # the run's inertia: m_p + C_M(h0) m_l (integrator.py _film_jump), checked against the theory's C_M
        c_m = contact.ContactModel(scene).theory.added_mass(h0)[0]
        if not math.isclose(added, c_m, rel_tol=1e-10):
            raise RuntimeError(f"the run's added mass {added:g} kg is not C_M(h0) m_l = {c_m:g} kg")
        first = ehd.collide(**args)
        result = ehd.collide(**args, snapshot_times=sorted(instants(first).values()))
        if not math.isclose(result.restitution, run_restitution, rel_tol=1e-12, abs_tol=1e-15):
            raise RuntimeError(f"the film's e {result.restitution} differs from the run's {run_restitution}")
        time_unit = h0 / speed
        pressure_unit = args["viscosity"] * speed * args["radius"] / h0**2
        force_unit = args["viscosity"] * speed * args["radius"] ** 2 / h0
        radial_unit = math.sqrt(args["radius"] * h0)
        when = instants(first)
        snapshots = {}
        for (label, _), (t, pressure, gap) in zip(sorted(when.items(), key=lambda kv: kv[1]), result.snapshots):
            step = int(np.flatnonzero(result.time == t)[0])
            separation = result.separation[step]
            deformation = gap - separation - 0.5 * result.radius**2
            snapshots[label] = {"t_us": t * time_unit * 1e6, "X_um": separation * h0 * 1e6,
                                "force_N": result.force[step] * force_unit,
                                "p_MPa": _rounded(np.append(pressure, 0.0) * pressure_unit / 1e6),
                                "h_um": _rounded(gap * h0 * 1e6), "w_um": _rounded(deformation * h0 * 1e6)}
        record["cavitation"][name] = {
            "p_cav_Pa": p_cav, "V_in_m_s": speed, "h0_um": h0 * 1e6, "radius_m": args["radius"],
            "sphere_mass_kg": scene.sphere.mass, "added_mass_kg": added, "net_weight_N": -args["external_force"],
            "e_star_Pa": args["e_star"], "viscosity_Pa_s": args["viscosity"], "epsilon": result.epsilon,
            "film_St": result.stokes, "restitution": result.restitution, "outcome": result.outcome,
            "film_time_us": result.end_time * time_unit * 1e6, "steps": result.steps,
            "overlap_time_us": None if result.contact_time is None else result.contact_time * time_unit * 1e6,
            "hertz_time_us": contact.hertz_contact_time(args["radius"], args["mass"], args["e_star"], speed) * 1e6,
            "hertz_radius_um": math.sqrt(args["radius"] * contact.hertz_depth(args["radius"], args["mass"],
                                                                                args["e_star"], speed)) * 1e6,
            "min_gap_um": result.min_gap * h0 * 1e6, "max_pressure_MPa": result.max_pressure * pressure_unit / 1e6,
            "min_pressure_MPa": result.min_pressure * pressure_unit / 1e6,
            "radius_um": _rounded(result.radius * radial_unit * 1e6), "snapshots": snapshots,
            "series": {"t_us": _rounded(result.time * time_unit * 1e6), "X_um": _rounded(result.separation * h0 * 1e6),
                       "V_m_s": _rounded(result.velocity * speed), "force_N": _rounded(result.force * force_unit),
                       "central_gap_um": _rounded(result.central_gap * h0 * 1e6),
                       "min_gap_um": _rounded(result.smallest_gap * h0 * 1e6)}}
        print(f"cavitation {name}: V_in {speed:.6g} m/s, m {args['mass']:.6g} kg (added {added:.4g}), "
              f"weight {-args['external_force']:.4g} N, eps {result.epsilon:.3g}, St {result.stokes:.4g}: "
              f"e {result.restitution:.4f} ({result.outcome}), t_c {result.end_time * time_unit * 1e6:.1f} us, "
              f"h_min {result.min_gap * h0 * 1e6:.3f} um, p {result.min_pressure * pressure_unit / 1e6:.0f} to "
              f"{result.max_pressure * pressure_unit / 1e6:.0f} MPa, {result.steps} steps", flush=True)
    record["seconds"] = round(time.perf_counter() - started, 1)
    return record


def write(record: dict) -> None:
    """One key a line at the top two levels: the record stays small and diffs stay readable."""
    lines = ["{"]
    items = list(record.items())
    for i, (key, value) in enumerate(items):
        end = "," if i < len(items) - 1 else ""
        if key == "cavitation":
            inner = [f'  {json.dumps(k)}: {json.dumps(v)}' for k, v in value.items()]
            lines.append(' "cavitation": {\n' + ",\n".join(inner) + f"\n }}{end}")
        else:
            lines.append(f" {json.dumps(key)}: {json.dumps(value)}{end}")
    RECORD.write_text("\n".join(lines) + "\n}\n")


def plot(record: dict) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colours = dict(zip(INSTANTS, ["C0", "C1", "C2", "C3", "C4"]))
    for name, film in record["cavitation"].items():
        fig, axes = plt.subplots(2, 3, figsize=(15, 8.5))
        (pressure, thickness, deformation), (gaps, force, speed) = axes
        r = np.array(film["radius_um"])
        shown = r <= 2.5 * film["hertz_radius_um"]
        for label, snap in film["snapshots"].items():
            tag = f"{label}, t = {snap['t_us']:.1f} us"
            style = dict(color=colours[label], lw=1.2, label=tag)
            pressure.plot(r[shown], np.array(snap["p_MPa"])[shown], **style)
            thickness.semilogy(r[shown], np.array(snap["h_um"])[shown], **style)
            deformation.plot(r[shown], np.array(snap["w_um"])[shown], **style)
        for ax in (pressure, thickness, deformation):
            ax.axvline(film["hertz_radius_um"], color="grey", lw=0.6, ls=":")
            ax.set_xlabel("r [um] (dotted: Hertz's contact radius at V_in)")
            ax.grid(alpha=0.3)
        if film["p_cav_Pa"] is not None:
            pressure.axhline(film["p_cav_Pa"] / 1e6, color="k", lw=0.6, ls="--")
        pressure.set_ylabel("film pressure p [MPa]")
        thickness.set_ylabel("film thickness h [um]")
        deformation.set_ylabel("the two surfaces' deformation w [um]")
        pressure.legend(fontsize=7)
        series = {k: np.array(v) for k, v in film["series"].items()}
        gaps.semilogy(series["t_us"], series["central_gap_um"], "C0-", label="central gap h(0)")
        gaps.semilogy(series["t_us"], series["min_gap_um"], "C3-", label="smallest gap min_r h")
        gaps.set_ylabel("gap [um]")
        force.plot(series["t_us"], series["force_N"], "k-", label="film force")
        force.set_ylabel("film force on the sphere [N]")
        speed.plot(series["t_us"], series["V_m_s"], "k-", label="V (negative: towards the wall)")
        speed.set_ylabel("sphere velocity [m/s]")
        for ax in (gaps, force, speed):
            for label, snap in film["snapshots"].items():
                ax.axvline(snap["t_us"], color=colours[label], lw=0.8, ls="--")
            ax.set_xlabel("t from the handover [us]")
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
        cav = "no cavitation limit" if film["p_cav_Pa"] is None else f"cavitation at p = {film['p_cav_Pa']:g} Pa"
        fig.suptitle(f"li2011-case3, first film collision ({cav}): V_in = {film['V_in_m_s']:.4g} m/s at "
                     f"h0 = {film['h0_um']:g} um, St = {film['film_St']:.3g}, epsilon = {film['epsilon']:.2e}; "
                     f"e = {film['restitution']:.3f}, t_c = {film['film_time_us']:.0f} us, "
                     f"smallest gap {film['min_gap_um']:.3f} um, p {film['min_pressure_MPa']:.4g} to "
                     f"{film['max_pressure_MPa']:.0f} MPa", fontsize=9)
        fig.tight_layout()
        FIGURES[name].parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(FIGURES[name], dpi=100)
        plt.close(fig)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--plot-only", action="store_true", help="redraw the figures from the record")
    if not parser.parse_args().plot_only:
        record = compute()
        write(record)
        print(f"wrote {RECORD} in {record['seconds']} s")
    plot(json.loads(RECORD.read_text()))
