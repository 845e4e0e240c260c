"""The elastohydrodynamic film's restitution against the Stokes number.

    PYTHONPATH=. python benchmarks/ehd_restitution.py               # 6-7 min on one core (timed under load)
    PYTHONPATH=. python benchmarks/ehd_restitution.py --quick       # 85 % glycerol only, ~2 min
    PYTHONPATH=. python benchmarks/ehd_restitution.py --plot-only   # redraw the figure from the record

The reduced setting of Davis, Serayssol & Hinch (1986): a sphere arrives at the handover gap h0 = 20 um
at V0 and meets the wall through the film alone (no outer drag, no added mass, no history; fem_bounce/ehd.py);
e = V_out / V0 where it is back at h0.  For the paper's Table 3 steel sets on Zerodur (65, 78, 85, 95 %
glycerol: li2011-table3-steel-*), St = m V0 / (6 pi mu a^2) (DSH's; for a sphere on a wall the package's
rho_p V0 D / (9 mu), checked below) from 3 to 1000 with V0 <= 2 m/s, and for each point:
- the film model (`ehd`), its elasticity parameter epsilon = 4 theta mu V0 a^1.5 / h0^2.5 (DSH's, with
  theta = 1 / (pi E*); the issue's 8 theta form is twice this and is recorded too), its smallest film
  thickness, largest and smallest pressure and how long the undeformed surfaces overlap;
- the same with a cavitation limit at minus one atmosphere (every set; ehd.FilmCollision's option);
- the package's lubricated-hertz law in the same reduced setting: Reynolds' 6 pi mu a^2 V / h down to
  h_c = max(roughness, x_d), then the Tsuji-damped Hertz contact with the film held at h_c and faded out
  (fem_bounce.contact.ContactLaw, read only), with e_d = 1 (like for like: the film model has no solid
  loss) and e_d = 0.97;
- composed with the rigid Reynolds film above h0 (from 0.2 D, where the package and the pendulum
  experiments measure: the speed lost there is 6 pi mu a^2 ln(0.2 D / h0) / m each way), beside the
  Legendre et al. (2006) fit e / e_d = exp(-35 / St*), St* = St (1 + rho_l / (2 rho_p)).
Also the critical Stokes number of each (bisection to 2 %, with and without the cavitation limit), and the
sensitivity of the 85 % glycerol curve to h0 (10 and 40 um).

Writes benchmarks/history/ehd_restitution.json and docs/figures/ehd_restitution.png.
"""
from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np
from scipy.integrate import solve_ivp

from fem_bounce import contact, ehd, materials, scene
from fem_bounce.studies.restitution import legendre_fit
from provenance import commit

ROOT = Path(__file__).resolve().parents[1]
PRESETS = ["li2011-table3-steel-65", "li2011-table3-steel-78", "li2011-table3-steel-85", "li2011-table3-steel-95"]
STOKES = [3, 4, 5, 6.5, 8.5, 11, 14, 18, 24, 32, 45, 65, 100, 150, 250, 400, 650, 1000]
H0 = 20e-6
MAX_SPEED = 2.0  # m/s: the pendulum experiments reach about 1 m/s
ATMOSPHERE = 101325.0
OUTER_GAP = 0.2  # in D: where the package's restitution study and the cameras measure
RECORD = ROOT / "benchmarks" / "history" / "ehd_restitution.json"
FIGURE = ROOT / "docs" / "figures" / "ehd_restitution.png"


class Setting:
    """One preset's sphere, wall and liquid in SI."""

    def __init__(self, name: str):
        sc = scene.load(name)
        self.name = name
        self.radius, self.mass = sc.sphere.radius, sc.sphere.mass
        self.diameter = sc.sphere.diameter
        self.density, self.viscosity = sc.sphere.density, sc.liquid.viscosity
        self.density_ratio = sc.density_ratio
        self.e_star = materials.reduced_modulus(sc.sphere.youngs_modulus, sc.sphere.poisson_ratio,
                                              sc.wall.youngs_modulus, sc.wall.poisson_ratio)
        self.roughness = sc.sphere.roughness + sc.wall.roughness
        self.scene = sc

    def speed(self, stokes: float) -> float:
        return 9.0 * self.viscosity * stokes / (self.density * self.diameter)

    def film(self, stokes: float, h0: float = H0, cavitation: float | None = None) -> dict:
        speed = self.speed(stokes)
        start = time.perf_counter()
        r = ehd.collide(self.radius, self.mass, self.e_star, self.viscosity, speed, h0, cavitation_pressure=cavitation)
        pressure_scale = self.viscosity * speed * self.radius / h0**2
        return {"St": stokes, "V0": speed, "epsilon": r.epsilon, "epsilon_8theta": 2.0 * r.epsilon,
                "St_package": self.scene.stokes(speed), "e": r.restitution, "outcome": r.outcome,
                "min_gap_um": r.min_gap * h0 * 1e6, "max_pressure_MPa": r.max_pressure * pressure_scale / 1e6,
                "min_pressure_MPa": r.min_pressure * pressure_scale / 1e6,
                "overlap_time_us": None if r.contact_time is None else r.contact_time * h0 / speed * 1e6,
                "hertz_time_us": contact.hertz_contact_time(self.radius, self.mass, self.e_star, speed) * 1e6,
                "x_d_um": materials.elastohydrodynamic_gap(self.radius, self.e_star, self.viscosity, speed) * 1e6,
                "steps": r.steps, "seconds": round(time.perf_counter() - start, 2)}

    def lubricated_hertz(self, stokes: float, dry_restitution: float, h0: float = H0) -> float:
        """e of the lubricated-hertz law from h0 at V0 back to h0, Reynolds' film only (module docstring)."""
        law = contact.ContactLaw(scene.Contact(dry_restitution=dry_restitution), self.radius, self.mass,
                                 self.e_star, self.viscosity, self.roughness, self.diameter)
        drag = 6.0 * math.pi * self.viscosity * self.radius**2
        v0 = self.speed(stokes)

        def film_only(t, y):
            return [y[1], -drag * y[1] / y[0] / self.mass]

        def reaches_contact(t, y):
            return y[0] - law.boundary(abs(y[1]))
        reaches_contact.terminal, reaches_contact.direction = True, -1

        def stops(t, y):
            return y[1] + 1e-6 * v0
        stops.terminal, stops.direction = True, 1
        horizon = 1e3 * h0 / v0
        first = solve_ivp(film_only, (0, horizon), [h0, -v0], events=[reaches_contact, stops], method="Radau",
                          rtol=1e-9, atol=[1e-12 * h0, 1e-12 * v0])
        if not first.t_events[0].size:
            return 0.0  # stopped in the film
        gap, rate = first.y_events[0][0]
        h_c = law.engage(abs(rate))

        def in_contact(t, y):
            film_gap, share = law.film(y[0], h_c)
            return [y[1], (-drag * y[1] / film_gap * share + law.force(y[0], y[1], h_c)) / self.mass]

        def leaves(t, y):
            return y[0] - h_c if y[1] > 0 else -1.0
        leaves.terminal, leaves.direction = True, 1
        # a contact that has not let go after 100 of Hertz's contact times at its arrival speed holds
        held = 100.0 * contact.hertz_contact_time(self.radius, self.mass, self.e_star, abs(rate))
        second = solve_ivp(in_contact, (0, held), [gap, rate], events=[leaves], method="Radau",
                           rtol=1e-9, atol=[1e-12 * h0, 1e-12 * v0], first_step=1e-3 * h_c / abs(rate))
        if not second.t_events[0].size:
            return 0.0

        def back(t, y):
            return y[0] - h0
        back.terminal, back.direction = True, 1

        def turns(t, y):
            return y[1]
        turns.terminal, turns.direction = True, -1
        third = solve_ivp(film_only, (0, horizon), second.y_events[0][0], events=[back, turns], method="Radau",
                          rtol=1e-9, atol=[1e-12 * h0, 1e-12 * v0])
        return float(third.y_events[0][0][1] / v0) if third.t_events[0].size else 0.0

    def composed(self, stokes: float, restitution: float, h0: float = H0) -> tuple[float, float]:
        """(St, e) measured at 0.2 D with the rigid Reynolds film between 0.2 D and h0 each way."""
        v0 = self.speed(stokes)
        lost = 6.0 * math.pi * self.viscosity * self.radius**2 * math.log(OUTER_GAP * self.diameter / h0) / self.mass
        launch = v0 + lost
        return self.scene.stokes(launch), max(restitution * v0 - lost, 0.0) / launch


def critical(rebounds, lo: float, hi: float, rel: float = 0.02) -> float:
    """The St between lo (no rebound) and hi (rebound) where e becomes positive (bisection in ln St)."""
    while hi / lo > 1.0 + rel:
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if not rebounds(mid) else (lo, mid)
    return math.sqrt(lo * hi)


def bracket(points):
    """(last St without rebound, first with) in a sweep, or None."""
    for a, b in zip(points, points[1:]):
        if a["e"] <= 0.0 < b["e"]:
            return a["St"], b["St"]
    return None


def main(quick: bool = False):
    started = time.perf_counter()
    record = {"date": time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime()), "commit": commit(),
              "command": "PYTHONPATH=. python benchmarks/ehd_restitution.py" + (" --quick" if quick else ""),
              "h0_um": H0 * 1e6, "settings": vars(ehd.FilmSettings()), "sets": {}}
    names = ["li2011-table3-steel-85"] if quick else PRESETS
    for name in names:
        s = Setting(name)
        stokes = [st for st in STOKES if s.speed(st) <= MAX_SPEED]
        points = []
        for st in stokes:
            p = s.film(st)
            p["e_lubricated_hertz_ed1"] = s.lubricated_hertz(st, 1.0)
            p["e_lubricated_hertz_ed097"] = s.lubricated_hertz(st, 0.97)
            p["St_at_0.2D"], p["e_at_0.2D"] = s.composed(st, p["e"])
            _, p["e_lubricated_hertz_ed097_at_0.2D"] = s.composed(st, p["e_lubricated_hertz_ed097"])
            p["legendre_e_over_ed"] = legendre_fit(st, s.density_ratio, 1.0)
            p["legendre_e_over_ed_at_0.2D"] = legendre_fit(p["St_at_0.2D"], s.density_ratio, 1.0)
            points.append(p)
            print(f"{name} St {st:g} V0 {p['V0']:.3g} eps {p['epsilon']:.2e} e {p['e']:.3f} ({p['outcome']}) "
                  f"LH {p['e_lubricated_hertz_ed1']:.3f} h_min {p['min_gap_um']:.3f} um {p['seconds']} s", flush=True)
        entry = {"density_ratio": s.density_ratio, "viscosity": s.viscosity, "points": points}
        found = bracket(points)
        if found:
            entry["critical_St"] = critical(lambda st, s=s: s.film(st)["e"] > 0.0, *found)
            entry["critical_epsilon"] = ehd.elasticity_parameter(s.radius, s.e_star, s.viscosity,
                                                                 s.speed(entry["critical_St"]), H0)
        lh = [{"St": p["St"], "e": p["e_lubricated_hertz_ed1"]} for p in points]
        found = bracket(lh)
        if found:
            entry["critical_St_lubricated_hertz"] = critical(lambda st, s=s: s.lubricated_hertz(st, 1.0) > 0.0,
                                                             *found)
        # the film's tension limited at minus one atmosphere (cavitation at zero absolute pressure)
        cav = []
        for st in stokes:
            p = s.film(st, cavitation=-ATMOSPHERE)
            p["St_at_0.2D"], p["e_at_0.2D"] = s.composed(st, p["e"])
            cav.append(p)
            print(f"{name} cavitated St {st:g} e {p['e']:.3f} ({p['outcome']}) {p['seconds']} s", flush=True)
        entry["cavitation"] = {"p_cav_Pa": -ATMOSPHERE, "points": cav}
        found = bracket(cav)
        if found:
            entry["cavitation"]["critical_St"] = critical(
                lambda st, s=s: s.film(st, cavitation=-ATMOSPHERE)["e"] > 0.0, *found)
        record["sets"][name] = entry
    # h0, on the 85 % glycerol set
    s = Setting("li2011-table3-steel-85")
    stokes = [st for st in STOKES if s.speed(st) <= MAX_SPEED]
    record["h0_sensitivity_85"] = {}
    for h0 in (10e-6, 40e-6):
        pts = [{"St": st, "e": s.film(st, h0=h0)["e"], "e_lubricated_hertz_ed1": s.lubricated_hertz(st, 1.0, h0)}
               for st in stokes if 8 <= st <= 250]
        record["h0_sensitivity_85"][f"{h0 * 1e6:g} um"] = pts
        print("h0", h0, [(p["St"], round(p["e"], 3)) for p in pts], flush=True)
    record["seconds"] = round(time.perf_counter() - started, 1)
    RECORD.write_text(json.dumps(record, indent=1) + "\n")
    plot(record, FIGURE)
    print(f"wrote {RECORD} in {record['seconds']} s")


def plot(record: dict, path: Path):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 4.8), sharey=True)
    colours = dict(zip(PRESETS, ["C0", "C1", "C2", "C3"]))
    st_line = np.geomspace(3, 1000, 200)
    for name, entry in record["sets"].items():
        pts = entry["points"]
        label = name.replace("li2011-table3-", "")
        st = [p["St"] for p in pts]
        left.semilogx(st, [p["e"] for p in pts], "o-", color=colours[name], ms=4, label=f"EHD film, {label}")
        left.semilogx(st, [p["e_lubricated_hertz_ed1"] for p in pts], "x--", color=colours[name], ms=4, lw=0.8)
        right.semilogx([p["St_at_0.2D"] for p in pts], [p["e_at_0.2D"] for p in pts], "o-", color=colours[name],
                       ms=4, label=f"EHD film + Reynolds above h0, {label}")
        right.semilogx([p["St_at_0.2D"] for p in pts], [p["e_lubricated_hertz_ed097_at_0.2D"] / 0.97 for p in pts],
                       "x--", color=colours[name], ms=4, lw=0.8)
    for name, entry in record["sets"].items():
        cav = entry.get("cavitation")
        if cav:
            label = name.replace("li2011-table3-", "")
            left.semilogx([p["St"] for p in cav["points"]], [p["e"] for p in cav["points"]], "s:",
                          color=colours[name], ms=3, label=f"EHD film, {label}, cavitation at -1 atm")
            right.semilogx([p["St_at_0.2D"] for p in cav["points"]], [p["e_at_0.2D"] for p in cav["points"]], "s:",
                           color=colours[name], ms=3)
    right.plot([], [], "ks:", ms=3, label="EHD film cavitated at -1 atm + Reynolds above h0")
    ratio = record["sets"].get("li2011-table3-steel-85", next(iter(record["sets"].values())))["density_ratio"]
    for ax in (left, right):
        ax.semilogx(st_line, [legendre_fit(s, ratio, 1.0) for s in st_line], "k-", lw=1.5,
                    label=r"Legendre et al. (2006): $e/e_d = e^{-35/St^*}$")
        ax.axvline(10.0, color="grey", lw=0.6, ls=":")
        ax.set_xlabel(r"St = $m V / (6 \pi \mu a^2) = \rho_p V D / (9 \mu)$")
        ax.grid(alpha=0.3)
    left.plot([], [], "kx--", lw=0.8, label="lubricated-hertz law (e_d = 1), same reduced setting")
    right.plot([], [], "kx--", lw=0.8, label="lubricated-hertz (e_d = 0.97) + Reynolds, / e_d")
    left.set_title(f"from h0 = {record['h0_um']:g} um back to h0 (no outer drag)")
    right.set_title("composed with Reynolds' film from 0.2 D (St, e at 0.2 D)")
    left.set_ylabel(r"$e$ (or $e/e_d$)")
    left.legend(fontsize=7, loc="lower right")
    right.legend(fontsize=7, loc="lower right")
    left.set_ylim(-0.02, 1.02)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="the 85 %% glycerol set only")
    parser.add_argument("--plot-only", action="store_true", help="redraw the figure from the record")
    args = parser.parse_args()
    if args.plot_only:
        plot(json.loads(RECORD.read_text()), FIGURE)
    else:
        main(args.quick)
