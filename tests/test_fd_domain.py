"""From scenes to fd problems: domain, boundary kinds, time step; and the validation check table."""
import io

import pytest

from fem_bounce import scene
from fem_bounce.studies import validation
from fem_bounce.fem.mesh import OUTER, TOP, WALL
from fem_bounce.models.fd import domain


FIXED = {"numerics.fd.mesh": "fixed", "numerics.fd.cells_per_diameter": 24}  # the fixed mesh, as these tests meant


def test_unbounded_fall_closes_with_slip_and_refines_the_path():
    sc = scene.load("li2011-case3", FIXED)
    d = domain.domain_for(sc)
    D = sc.sphere.diameter
    assert d.sides == {WALL: "no-slip", OUTER: "slip", TOP: "slip"}
    assert d.spec.radius == pytest.approx(10 * D)
    assert d.spec.height == pytest.approx(sc.initial_gap + D + 2 * D + 10 * D)  # path, wake, far field
    box = d.spec.refined[0]
    assert box.z_min == 0.0 and box.z_max == pytest.approx(sc.initial_gap + 3 * D)
    assert box.r_max == pytest.approx(sc.numerics.fd.refined_radius * D)
    assert d.fine_size == pytest.approx(D / 24) and d.center == pytest.approx(sc.initial_gap + D / 2)


def test_container_is_no_slip_all_round_and_a_stream_flows_through():
    box = domain.domain_for(scene.load("tencate2002-e4"))
    assert set(box.sides.values()) == {"no-slip"} and box.spec.radius == 0.0564 and box.spec.height == 0.16
    stream = domain.domain_for(scene.load("sphere-drag-re100"))
    assert stream.sides == {WALL: "inflow", OUTER: "slip", TOP: "outflow"} and stream.inflow_speed == 0.1
    refined = stream.spec.refined[0]
    assert refined.z_min < stream.center - 0.005 and refined.z_max == pytest.approx(stream.center + 0.005 + 0.02)


def test_time_step_takes_the_tighter_of_the_convective_and_forcing_bounds():
    """The one-shot penalty's step: its explicit convection's bound or its forcing number's; the implicit
    constraint's: the convective one alone, at its own cfl 0.4."""
    penalty = {**FIXED, "numerics.fd.constraint": "penalty"}
    sc = scene.load("sphere-drag-re200", penalty)  # fast and not very viscous: convection binds
    h = sc.sphere.diameter / 24
    assert domain.time_step(sc) == pytest.approx(0.2 * h / (1.5 * 0.1))
    slow = scene.load("brenner-approach", penalty)  # Re = 0.01: the forcing number binds
    h = slow.sphere.diameter / 24
    assert domain.time_step(slow) == pytest.approx(0.025 * h**2 / slow.liquid.kinematic_viscosity)
    implicit = scene.load("brenner-approach", FIXED)
    assert domain.time_step(implicit) == pytest.approx(0.4 * h / (1.5 * abs(implicit.motion.velocity)))


def test_a_held_sphere_needs_a_speed_to_set_the_time_step():
    sc = scene.load("brenner-approach", {"motion.velocity": 0.0})
    with pytest.raises(scene.SceneError, match="nonzero motion.velocity"):
        domain.time_step(sc)


def test_check_table_separates_required_checks_from_targets():
    stream = io.StringIO()
    ok = validation.report([validation.Check("a", 1.02, 1.0, 0.03),
                            validation.Check("b", 0.80, 1.0, 0.05, required=False)], stream)
    assert ok and "check  PASS  a" in stream.getvalue() and "target MISS  b" in stream.getvalue()
    assert not validation.report([validation.Check("c", 1.2, 1.0, 0.1)], io.StringIO())


def test_a_neutrally_buoyant_free_sphere_is_refused_clearly():
    # the scene check refuses it for every model (tests/test_scene_refusals.py), before any model's time step
    with pytest.raises(scene.SceneError, match="neutrally buoyant"):
        scene.load("li2011-case3", {"sphere.density": 1203.0})


def test_the_wall_box_refines_the_gap_under_the_path_only():
    from fem_bounce.models.fd.domain import domain_for

    sc = scene.load("li2011-case3", {**FIXED, "numerics.fd.wall_cells_per_diameter": 48})
    plain = domain_for(scene.load("li2011-case3", FIXED)).spec
    spec = domain_for(sc).spec
    D = sc.sphere.diameter
    assert spec.size_at(0.3 * D, 0.1 * D) == pytest.approx(D / 48)
    assert plain.size_at(0.3 * D, 0.1 * D) == pytest.approx(D / 24)
    # above the layer and far out the sizes are the plain mesh's
    for r, z in ((0.3 * D, 1.5 * D), (5 * D, 3 * D)):
        assert spec.size_at(r, z) == pytest.approx(plain.size_at(r, z))
    assert spec.key() != plain.key()
