"""motion.py: the questions about sphere 1's motion (scene [motion]) that the models, their domains and the
studies ask instead of reading motion.mode, and the speeds and grids that follow from the answers."""
from __future__ import annotations

import pytest

from fem_bounce import motion
from fem_bounce import scene as scenes
from fem_bounce.fem.domain import speed_scale
from fem_bounce.models.ib.domain import boundaries, path_range
from fem_bounce.models.ib.grid import INFLOW, WALL


@pytest.fixture
def kinds(tmp_path):
    """A free, a held, a held-in-a-stream and a series-prescribed sphere."""
    series = tmp_path / "approach.csv"
    series.write_text("t,velocity\n0,-0.001\n0.1,-0.003\n0.2,0.002\n")
    return {"free": scenes.load("li2011-case3"), "held": scenes.load("brenner-approach"),
            "stream": scenes.load("sphere-drag-re200"),
            "series": scenes.load("brenner-approach", {"motion.mode": "prescribed", "motion.series": str(series)})}


def test_each_motion_answers_its_questions(kinds):
    def answers(question):
        return [question(kinds[k]) for k in ("free", "held", "stream", "series")]

    assert answers(motion.is_free) == [True, False, False, False]
    assert answers(motion.is_held) == [False, True, True, False]
    assert answers(motion.is_stream) == [False, False, True, False]
    assert answers(motion.follows_series) == [False, False, False, True]
    assert answers(motion.series_speed) == pytest.approx([0.0, 0.0, 0.0, 0.003], rel=1e-12)


def test_the_imposed_motion_sets_the_velocity_the_grid_and_the_speed_scale(kinds):
    held, stream, series = kinds["held"], kinds["stream"], kinds["series"]
    assert motion.prescribed_velocity(held)(0.15) == (-0.001, 0.0)  # constant, not interpolated
    assert motion.prescribed_velocity(series)(0.1)[0] == pytest.approx(-0.003, rel=1e-12)  # a knot of the spline
    # ib: a held sphere's path is its place; a series' widens by its largest speed over the run
    d, h0, end = held.sphere.diameter, held.initial_gap, held.run.end_time
    assert path_range(held) == pytest.approx((h0, h0 + d))
    assert path_range(series) == pytest.approx((h0 - 0.003 * end, h0 + d + 0.003 * end))
    assert boundaries(held).bottom == WALL and boundaries(stream).bottom == INFLOW
    assert boundaries(stream).inflow_velocity == pytest.approx(0.1)
    # fd and ale: the held sphere's surface speed, the stream's speed, the series' sampled peak
    assert speed_scale(held) == pytest.approx(0.001) and speed_scale(stream) == pytest.approx(0.1)
    assert speed_scale(series) >= motion.series_speed(series)
