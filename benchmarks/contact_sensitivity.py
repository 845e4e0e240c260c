"""How the lubricated Hertz contact's results move with its inputs: reported, not tuned.

    python benchmarks/contact_sensitivity.py          # ODE model, about 3 minutes on one core

For the default contact and each variant (the contact gap h_c halved and doubled with
contact.contact_gap_factor; the surfaces' roughness at 0.01 and 0.1 um each instead of 0.02 um; the
paper's model as written), the ODE model's case 1 (V_i, Re_II, e_1) and its e(St) sweep against the
Legendre et al. (2006) fit (studies/restitution.py: rms and largest difference over St 10-1000, the
critical St).  Writes benchmarks/history/contact_sensitivity.json.
"""
from __future__ import annotations

import json
import warnings
from pathlib import Path

from fem_bounce import scene
from fem_bounce.integrator import BodyIntegrator
from fem_bounce.studies import restitution, restitution_planning

VARIANTS = {
    "default (lubricated-hertz)": {},
    "h_c halved": {"contact.contact_gap_factor": 0.5},
    "h_c doubled": {"contact.contact_gap_factor": 2.0},
    "roughness 0.01 um each": {"sphere.roughness": 1e-8, "wall.roughness": 1e-8},
    "roughness 0.1 um each": {"sphere.roughness": 1e-7, "wall.roughness": 1e-7},
    "li2011 (the paper's model)": {"contact.model": "li2011"},
}


def case1(overrides: dict) -> dict:
    sc = scene.load("li2011-case1", {"run.bounces": 2, **overrides})
    integrator = BodyIntegrator(sc)
    integrator.advance(sc.run.end_time)
    integrator.finish()
    first, second = integrator.impacts[:2]
    return {"V_i": first.impact_speed, "Re_II": second.Re, "e_1": integrator.rebounds[0].restitution,
            "contact_gap_um": first.contact_gap * 1e6}


def main() -> None:
    results = {}
    for name, overrides in VARIANTS.items():
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sweep = restitution_planning.sweep(40, overrides=overrides)
        found = {"overrides": overrides, "case1": case1(overrides), "e_St": restitution.compare(sweep)}
        results[name] = found
        c, e = found["case1"], found["e_St"]
        print(f"{name:28s} case 1: V_i {c['V_i']:.4f} m/s, Re_II {c['Re_II']:.1f} (measured 29), e_1 {c['e_1']:.3f}, "
              f"h_c {c['contact_gap_um']:.3g} um | e(St): rms {e['rms_to_fit']:.3f}, "
              f"largest {e['max_abs_to_fit']:.3f}, "
              f"no rebound below St {e['critical_St'][0]:.3g} (first rebound at {e['critical_St'][1]:.3g})", flush=True)
    path = Path(__file__).parent / "history" / "contact_sensitivity.json"
    path.write_text(json.dumps(results, indent=1) + "\n")
    print(f"-> {path}")


if __name__ == "__main__":
    main()
