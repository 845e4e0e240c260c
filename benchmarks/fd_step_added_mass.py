"""The numerical added mass of one fd step against the step's length (docs/validation.md section 12).

    python benchmarks/fd_step_added_mass.py            # 16 cells/D, a few seconds

Case 3's sphere at rest at the contact model's hold gap (0.2 D) and at 1 D from the wall; one implicit step
(numerics.fd.constraint = "implicit") of 1, 0.25 and 0.05 times the cfl step, and its added mass M = -dF/dU / c
(penalised.PenalisedFlow.linearise) over the displaced liquid's mass.  M is the liquid the step moves with the
sphere: the inviscid added mass plus the viscous layer grown over the step, so it grows with dt, and a contact
that reverses the sphere inside the step reverses all of it.
"""
from __future__ import annotations

import argparse

from mpi4py import MPI

from fem_bounce import scene
from fem_bounce.integrator import BodyIntegrator
from fem_bounce.models.fd.model import FictitiousDomainModel

FACTORS = (1.0, 0.25, 0.05)


def added_masses(cells: float, gap_over_diameter: float) -> list[float]:
    """M / m_f of one step at each of FACTORS times the cfl step, the sphere gap_over_diameter D from the wall."""
    base = scene.load("li2011-case3")
    sc = scene.load("li2011-case3", {"numerics.fd.cells_per_diameter": cells, "numerics.fd.constraint": "implicit",
                                     "initial_gap": gap_over_diameter * base.sphere.diameter})
    model = FictitiousDomainModel(sc, MPI.COMM_WORLD)
    model.build(BodyIntegrator(sc, resolved=True))
    try:
        masses = []
        for factor in FACTORS:
            model.flow.set_time_step(factor * model.cfl_step)
            model.history.bdf = model.flow.bdf
            linear = model.flow.linearise(model.history.momentum_history, model.history.reference_velocity)
            masses.append(float(linear.added_mass[0, 0]) / model.bodies[0].displaced_mass)
        return masses
    finally:
        model.destroy()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--cells", type=float, default=16.0, help="numerics.fd.cells_per_diameter (default 16)")
    args = parser.parse_args()
    for gap in (0.2, 1.0):
        masses = added_masses(args.cells, gap)
        steps = ", ".join(f"dt = {f:g} x cfl step: M / m_f = {m:.3f}" for f, m in zip(FACTORS, masses))
        print(f"gap {gap:g} D: {steps}")


if __name__ == "__main__":
    main()
