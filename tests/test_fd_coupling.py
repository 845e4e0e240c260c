"""The coupling algebra of one fd step (fem_bounce.models.fd.coupling): pure numbers, no mesh, for one,
two and three spheres on the axis."""
import numpy as np
import pytest

from fem_bounce.models.fd import coupling

RHO, C = 1200.0, 6000.0
VOLUMES = np.array([4.0e-7, 5.0e-7, 3.0e-7])
# G_ij = I_i(y1_j): symmetric positive definite, the diagonal near 2/3 of each volume, weak neighbour terms
UNIT = np.array([[2.4e-7, -1.0e-8, -1.0e-9], [-1.0e-8, 3.1e-7, -6.0e-9], [-1.0e-9, -6.0e-9, 1.9e-7]])


def integrals(count: int) -> coupling.InteriorIntegrals:
    return coupling.InteriorIntegrals(volume=VOLUMES[:count], predicted=np.array([-3.0e-8, 1.0e-8, 4.0e-9])[:count],
                                      forced=np.array([1.0e-8, -2.0e-9, 3.0e-9])[:count],
                                      unit=UNIT[:count, :count])


VELOCITY_SETS = ([-0.4, 0.1, 0.2], [-0.12, 0.3, -0.05], [0.3, -0.2, 0.0])


@pytest.mark.parametrize("count", [1, 2, 3])
def test_rigid_amplitudes_give_each_sphere_its_mean_velocity(count):
    i = integrals(count)
    for velocities in VELOCITY_SETS:
        s = coupling.rigid_amplitudes(i, velocities[:count])
        interior = i.predicted + i.forced + i.unit @ s
        assert interior / i.volume == pytest.approx(np.array(velocities[:count]), abs=1e-15)


@pytest.mark.parametrize("count", [1, 2, 3])
def test_forces_are_affine_with_the_numerical_added_mass_as_slope(count):
    """dF_i/dU_j = -c M_ij, and M is symmetric (G is)."""
    i, history = integrals(count), 0.1 * VOLUMES[:count]
    matrix = coupling.added_mass(i, RHO)
    base = np.zeros(count)
    for j in range(count):
        step = np.eye(count)[j] * 0.1
        f = [coupling.fluid_forces(i, base + k * step, RHO, C, history) for k in (-1, 0, 1)]
        assert f[1] - f[0] == pytest.approx(f[2] - f[1], rel=1e-12, abs=1e-12 * np.abs(f[1]).max())
        assert (f[2] - f[0]) / 0.2 == pytest.approx(-C * matrix[:, j], rel=1e-10, abs=1e-10 * C * matrix.max())
    assert matrix == pytest.approx(matrix.T, rel=1e-12)


@pytest.mark.parametrize("count", [1, 2, 3])
def test_the_linearisation_reproduces_the_forces_at_any_velocities(count):
    i, history = integrals(count), 0.05 * VOLUMES[:count]
    reference = np.array([-0.12, 0.3, 0.1])[:count]
    linear = coupling.linearise(i, RHO, C, history, reference)
    for velocities in VELOCITY_SETS:
        exact = coupling.fluid_forces(i, velocities[:count], RHO, C, history)
        predicted = linear.explicit - C * linear.added_mass @ (np.array(velocities[:count]) - reference)
        assert predicted == pytest.approx(exact, rel=1e-12)


@pytest.mark.parametrize("count", [2, 3])
def test_uncoupled_spheres_reduce_to_one_sphere_each(count):
    """With G diagonal (spheres far apart) each row is that sphere's own one-sphere algebra."""
    i = integrals(count)
    uncoupled = coupling.InteriorIntegrals(i.volume, i.predicted, i.forced, np.diag(np.diag(i.unit)))
    velocities, history = np.array([0.1, -0.2, 0.05])[:count], 0.05 * i.volume
    matrix = coupling.added_mass(uncoupled, RHO)
    forces = coupling.fluid_forces(uncoupled, velocities, RHO, C, history)
    for k in range(count):
        alone = coupling.InteriorIntegrals(i.volume[k:k + 1], i.predicted[k:k + 1], i.forced[k:k + 1],
                                           i.unit[k:k + 1, k:k + 1])
        assert matrix[k, k] == pytest.approx(coupling.added_mass(alone, RHO)[0, 0], rel=1e-12)
        assert np.count_nonzero(matrix[k]) == 1
        assert forces[k] == pytest.approx(coupling.fluid_forces(alone, velocities[k:k + 1], RHO, C,
                                                                history[k:k + 1])[0], rel=1e-12)


def test_sharp_sphere_in_potential_flow_has_half_the_displaced_mass():
    """A uniform force density in a sharp sphere moves its interior at 2/3 of the force's velocity
    scale (the rest goes to the pressure), so I(y1) = 2 V / 3 and m_a = rho V / 2."""
    volume = np.array([1.0e-6])
    sharp = coupling.InteriorIntegrals(volume=volume, predicted=np.zeros(1), forced=np.zeros(1),
                                       unit=np.diag(2.0 * volume / 3.0))
    assert coupling.added_mass(sharp, RHO)[0, 0] == pytest.approx(0.5 * RHO * volume[0])
