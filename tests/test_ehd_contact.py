"""contact.model = "ehd": the film collision of fem_bounce.ehd inside a run (docs/ehd.md section 5).

Toy cost: one ODE run of li2011-case3 with the film model (three film collisions, ~10 s under load) shared
by the tests, one lubricated-hertz run to the handover, one film collision recomputed by hand."""
import math

import pytest

from fem_bounce import contact, ehd, materials, scene
from fem_bounce.integrator import BodyIntegrator


def case3(**changes):
    return scene.load("li2011-case3", {"contact.model": "ehd", **changes})


class Recorded(BodyIntegrator):
    """Keeps (t, V) where each film collision began and the state the integrator resumed from."""

    def _film_jump(self):
        start = self._film_pending
        super()._film_jump()
        self.jumps = getattr(self, "jumps", []) + [(start, self.time, self.gaps[0], self.velocities[0])]


@pytest.fixture(scope="module")
def run():
    """Case 3 with the film holding any tension (its last collision then stops the sphere in the film)."""
    integrator = Recorded(case3(**{"contact.cavitation_pressure": "off"}))
    integrator.advance(integrator.scene.run.end_time)
    integrator.finish()
    yield integrator
    integrator.destroy()


def test_case3_completes_with_physical_restitution(run):
    assert run.done and len(run.impacts) >= 2
    assert len(run.rebounds) == len(run.impacts)
    h0 = run.scene.contact.ehd_handover
    for impact, rebound in zip(run.impacts, run.rebounds):
        # the film model has no solid loss (e_d = 1 inside it): e must lie in [0, 1)
        assert 0.0 <= impact.film_restitution < 1.0
        assert 0.0 <= rebound.restitution < 1.0
        assert impact.film_time > 0.0 and impact.contact_gap == h0
        # the film's smallest thickness: open (no solid contact) and far below the handover gap
        assert 0.0 < impact.min_gap < 0.1 * h0
        assert impact.impact_speed > 0.0 and impact.St > 0.0
    # the first collision rebounds (case 3, St ~ 63: above every critical St of docs/ehd.md)
    assert run.impacts[0].film_outcome == "rebound" and run.rebounds[0].rebounded
    assert 0.3 < run.rebounds[0].restitution < 0.95


def test_rebound_resumes_at_the_handover_with_e_times_v_in(run):
    h0 = run.scene.contact.ehd_handover
    rebounds = [j for j, impact in zip(run.jumps, run.impacts) if impact.film_outcome == "rebound"]
    assert rebounds
    for ((t0, v0), t1, gap, velocity), impact in zip(run.jumps, run.impacts):
        assert t1 == pytest.approx(t0 + impact.film_time, rel=1e-12)
        if impact.film_outcome != "rebound":
            continue
        assert gap == pytest.approx(h0, rel=1e-9)
        assert velocity == pytest.approx(impact.film_restitution * -v0, rel=1e-9)
    # the film's e recomputed from the scene: the inertia is the sphere's mass plus its added mass at h0
    (t0, v0), *_ = run.jumps[0]
    s = run.scene
    e_star = materials.reduced_modulus(s.sphere.youngs_modulus, s.sphere.poisson_ratio, s.wall.youngs_modulus,
                                     s.wall.poisson_ratio)
    mass = s.sphere.mass + run.theories[0].added_mass(h0)[0]
    assert mass > s.sphere.mass + 0.5 * s.displaced_mass  # C_M near the wall exceeds 1/2
    weight = (s.sphere.mass - s.displaced_mass) * s.gravity  # pressing the sphere into the film
    again = ehd.collide(s.sphere.radius, mass, e_star, s.liquid.viscosity, -v0, h0, external_force=-weight)
    assert again.restitution == pytest.approx(run.impacts[0].film_restitution, rel=1e-9)
    without_added_mass = ehd.collide(s.sphere.radius, s.sphere.mass, e_star, s.liquid.viscosity, -v0, h0,
                                     external_force=-weight)
    assert abs(without_added_mass.restitution - again.restitution) > 1e-3
    weightless = ehd.collide(s.sphere.radius, mass, e_star, s.liquid.viscosity, -v0, h0)
    assert weightless.restitution > again.restitution  # the weight takes a little of the rebound


def test_a_collision_without_rebound_leaves_the_sphere_at_rest(run):
    last = run.impacts[-1]
    assert last.film_outcome in ("stopped", "held") and last.film_restitution == 0.0
    assert run.rebounds[-1].restitution == 0.0 and run.rebounds[-1].apex_gap is None
    assert "came to rest on the wall in the film" in run.stop_reason
    assert run.velocities[0] == 0.0 and 0.0 < run.time < run.scene.run.end_time
    assert run.wall.record.resting


def test_above_the_handover_the_run_is_lubricated_hertz(run):
    """Down to h0 the forces are lubricated-hertz's (its Hertz contact begins only at ~0.4 um)."""
    (t0, v0), *_ = run.jumps[0]
    reference = BodyIntegrator(scene.load("li2011-case3"))
    try:
        reference.advance(t0)
        assert reference.impacts == []
        assert reference.velocities[0] == pytest.approx(v0, rel=1e-4)
        assert reference.gaps[0] == pytest.approx(run.scene.contact.ehd_handover, rel=2e-2)
    finally:
        reference.destroy()


def test_a_pair_is_refused():
    with pytest.raises(scene.SceneError, match=r"contact\.model = \"ehd\" is not implemented for a pair"):
        scene.load("yang-hunt2006-pair", {"contact.model": "ehd"})


@pytest.mark.parametrize("handover", [1e-3, 1e-7])
def test_a_bad_handover_is_refused_naming_the_field(handover):
    # 1 mm: thicker than 0.1 a; 1e-7 m: below ten elastohydrodynamic gaps (x_d ~ 0.4 um for case 3)
    with pytest.raises(scene.SceneError, match=r"contact\.ehd_handover = .* is out of range: allowed in \("):
        case3(**{"contact.ehd_handover": handover})


def test_a_handover_inside_the_range_is_kept():
    assert case3(**{"contact.ehd_handover": 40e-6}).contact.ehd_handover == 40e-6
    assert scene.load("li2011-case3").contact.ehd_handover == 20e-6  # unchecked unless the model is ehd


@pytest.mark.parametrize("value", ["on", 5.0, -1e9, math.inf])
def test_a_bad_cavitation_pressure_is_refused(value):
    with pytest.raises(scene.SceneError, match=r"contact\.cavitation_pressure = "):
        case3(**{"contact.cavitation_pressure": value})


def test_the_cavitation_pressure_reaches_the_film_model():
    # from the liquid by default: its vapour pressure (1380 Pa) less one atmosphere
    assert contact.ContactModel(case3()).law.cavitation == pytest.approx(1380.0 - 101325.0)
    assert contact.ContactModel(case3(**{"contact.cavitation_pressure": "off"})).law.cavitation is None
    law = contact.ContactModel(case3(**{"contact.cavitation_pressure": -101325})).law
    assert law.cavitation == -101325.0 and law.ehd and law.force(1e-6, -0.1, 0.0) == 0.0
    assert law.boundary(0.4) == pytest.approx(20e-6)


def test_a_checkpoint_after_a_film_collision_restarts_to_the_same_bounces(run):
    """The state after a jump (time, gap, velocity, history states, the record's phase) is all a restart needs."""
    t_after = run.jumps[0][1] + 0.01
    first = BodyIntegrator(case3())
    second = BodyIntegrator(case3())
    try:
        first.advance(t_after)
        second.load_state_dict(first.state_dict())
        end = run.scene.run.end_time
        first.advance(end)
        second.advance(end)
        assert len(second.impacts) == len(first.impacts) == len(run.impacts)
        for a, b in zip(first.impacts, second.impacts):
            assert b.film_restitution == pytest.approx(a.film_restitution, rel=1e-6)
            assert b.time == pytest.approx(a.time, rel=1e-6)
        assert second.stop_reason == first.stop_reason
    finally:
        first.destroy()
        second.destroy()


def test_a_film_collision_that_cannot_be_solved_ends_the_run_as_diverged(monkeypatch):
    from fem_bounce import errors

    integrator = BodyIntegrator(case3())

    def fails(speed, mass, force=0.0):
        raise ehd.FilmError("Newton did not converge")
    monkeypatch.setattr(integrator.contact.law, "collide", fails)
    try:
        with pytest.raises(errors.RunDiverged, match=r"the film collision \(contact\.model = \"ehd\"\) at t = .*"
                                                      r"Newton did not converge"):
            integrator.advance(integrator.scene.run.end_time)
    finally:
        integrator.destroy()
