"""The near-wall force in a resolved model: with the held flow and its correction (docs/physics.md 3.3)
the impact speed does not depend on where the hand-over happens.  A toy version of
`python benchmarks/near_wall.py insensitivity`: the ALE model (which resolves the gap at any delta_sl) on a
short case-3 fall, delta_sl = 0.1 against 0.3."""
import pytest
from mpi4py import MPI

from fem_bounce import scene as scenes
from fem_bounce.run import simulate


def impact_speed(delta_sl: float, near_wall: str) -> float:
    sc = scenes.load("li2011-case3", {"initial_gap": 0.6 * 0.0095, "run.bounces": 1,
                                      "contact.delta_sl": delta_sl, "contact.near_wall": near_wall,
                                      "numerics.ale.cells_per_diameter": 6})
    summary = simulate(sc, "ale", MPI.COMM_SELF, progress=False, plots=False)
    return summary["impacts"][0]["impact_speed"]


@pytest.mark.slow
def test_impact_speed_does_not_depend_on_delta_sl_under_the_correction():
    """Measured: 0.2368 / 0.2372 m/s (0.2 %).  The paper's blend with the earlier f_thr (Brenner times
    Schiller-Naumann) gives 0.2223 / 0.2130 m/s here (4.3 %), so the issue-11 target (1 %) can fail."""
    held = {d: impact_speed(d, "correction") for d in (0.1, 0.3)}
    assert held[0.3] == pytest.approx(held[0.1], rel=0.01)
