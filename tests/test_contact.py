"""The contact model's functions: end points, midpoints and the Hertz scale (physics.md section 2)."""
import math

import pytest

from fem_bounce import contact, scene


def test_elastic_shape_end_points():
    assert contact.elastic_shape(0.0) == pytest.approx(1.0)
    assert contact.elastic_shape(1.0) == 0.0
    assert contact.elastic_shape(1.5) == 0.0
    assert 0.0 < contact.elastic_shape(0.5) < 1.0


def test_blend_is_one_half_at_delta_sl_and_one_at_contact():
    assert contact.blend(0.2, 0.2) == pytest.approx(0.5)
    assert contact.blend(0.0, 0.2) == pytest.approx(1.0, abs=1e-4)
    assert contact.blend(1.0, 0.2) < 1e-15


def test_steel_on_zerodur_hertz_scale():
    # physics.md: E* ~ 67 GPa, W_o ~ 100 N at V_I = 0.4 m/s for D = 9.5 mm steel on Zerodur
    e_star = 1.0 / ((1 - 0.33**2) / 200e9 + (1 - 0.24**2) / 91e9)
    model = contact.ContactModel(scene.load("li2011-case3"))
    assert model.e_star == pytest.approx(e_star, rel=1e-12)
    assert model.e_star == pytest.approx(67.5e9, rel=2e-3)
    # eq. 4.7 by hand: (4/3) a^2 E* (5 pi rho V^2 / (4 E*))^(3/5)
    a, rho, v = 0.00475, 7780.0, 0.4
    by_hand = 4 / 3 * a**2 * e_star * math.exp(0.6 * math.log(5 * math.pi * rho * v**2 / (4 * e_star)))
    assert model.hertz_force(0.4) == pytest.approx(by_hand, rel=1e-12)
    assert 95.0 < model.hertz_force(0.4) < 115.0


def test_elastic_force_uses_dry_restitution_and_gap():
    model = contact.ContactModel(scene.load("li2011-case3"))
    assert model.elastic(0.0, 100.0) == pytest.approx(97.0)
    assert model.elastic(model.contact_gap, 100.0) == 0.0
