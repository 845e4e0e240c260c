"""The restitution helpers of the ODE model (paper section 5.4)."""
import pytest

from fem_bounce import restitution, scene


def test_gap_for_stokes_hits_the_target():
    steel = scene.load("li2011-table3-steel-78")
    gap = restitution.gap_for_stokes(steel, 40.0)
    assert restitution.first_bounce(steel, gap, rebound=False)["St"] == pytest.approx(40.0, rel=0.01)


def test_gap_for_stokes_names_the_reachable_range():
    with pytest.raises(scene.SceneError, match="out of reach for li2011-table3-steel-95"):
        restitution.gap_for_stokes(scene.load("li2011-table3-steel-95"), 500.0)


def test_sweep_spans_the_sets_and_dense_spheres_approach_the_dry_value(tmp_path):
    results = restitution.sweep([3.0, 50.0, 200.0, 800.0])
    assert [r["scene"] for r in results] == ["li2011-table3-steel-85", "li2011-table3-steel-78",
                                             "li2011-table3-dense24-78", "li2011-table3-dense48-78"]
    for r in results:
        assert r["St"] == pytest.approx(r["target_St"], rel=0.1)
    assert results[-1]["restitution"] == pytest.approx(0.97, abs=0.03)  # paper: e -> e_d at St ~ 1000
    restitution.write(results, tmp_path)
    assert (tmp_path / "restitution.png").stat().st_size > 10_000
