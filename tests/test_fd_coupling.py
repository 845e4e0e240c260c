"""The coupling algebra of one fd step (fem_bounce.models.fd.coupling): pure numbers, no mesh."""
import pytest

from fem_bounce.models.fd import coupling

RHO, C = 1200.0, 6000.0
INTEGRALS = coupling.InteriorIntegrals(volume=4.0e-7, predicted=-3.0e-8, forced=1.0e-8, unit=2.4e-7)


def test_rigid_amplitude_gives_the_sphere_mean_velocity():
    for velocity in (-0.3, 0.0, 0.2):
        s = coupling.rigid_amplitude(INTEGRALS, velocity)
        mean = (INTEGRALS.predicted + INTEGRALS.forced + s * INTEGRALS.unit) / INTEGRALS.volume
        assert mean == pytest.approx(velocity, abs=1e-15)


def test_force_is_affine_with_the_numerical_added_mass_as_slope():
    history = 0.1 * INTEGRALS.volume
    f = [coupling.fluid_force(INTEGRALS, u, RHO, C, history) for u in (-0.1, 0.0, 0.1)]
    slope = (f[2] - f[0]) / 0.2
    assert f[1] - f[0] == pytest.approx(f[2] - f[1], rel=1e-12)
    assert slope == pytest.approx(-C * coupling.added_mass(INTEGRALS, RHO), rel=1e-12)


def test_linearisation_reproduces_the_force_at_any_velocity():
    history, reference = 0.05 * INTEGRALS.volume, -0.12
    linear = coupling.linearise(INTEGRALS, RHO, C, history, reference)
    for u in (-0.4, -0.12, 0.3):
        exact = coupling.fluid_force(INTEGRALS, u, RHO, C, history)
        assert linear.explicit - linear.added_mass * C * (u - reference) == pytest.approx(exact, rel=1e-12)


def test_sharp_sphere_in_potential_flow_has_half_the_displaced_mass():
    """A uniform force density in a sharp sphere moves its interior at 2/3 of the force's velocity
    scale (the rest goes to the pressure), so I(y1) = 2 V / 3 and m_a = rho V / 2."""
    volume = 1.0e-6
    sharp = coupling.InteriorIntegrals(volume=volume, predicted=0.0, forced=0.0, unit=2.0 * volume / 3.0)
    assert coupling.added_mass(sharp, RHO) == pytest.approx(0.5 * RHO * volume)
