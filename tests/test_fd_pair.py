"""The fd model with two and three spheres on the axis (issues 14, 25), at toy size: one step's N x N
added mass, the indicators kept apart, and a held pair's steady drag against Stimson & Jeffery (1926).  The coupling
algebra for one, two and three spheres is in test_fd_coupling.py."""
import math
import warnings

import numpy as np
import pytest
from mpi4py import MPI

from fem_bounce import pair_theory, scene
from fem_bounce.kinematics import Prediction
from fem_bounce.models.fd.model import FictitiousDomainModel


class HoldingIntegrator:
    """What FictitiousDomainModel.build asks of the body integrator: its hold gaps [m] (the wall's, then
    each neighbouring pair's)."""

    def __init__(self, wall_hold: float, *pair_holds: float):
        self.hold_gaps = (wall_hold, *pair_holds)


def pair_scene(preset: str, changes: dict, gap: float, velocity: float, mode: str = "free") -> scene.Scene:
    base = scene.load(preset)
    sphere = base.sphere
    second = {"second_sphere.diameter": sphere.diameter, "second_sphere.density": sphere.density,
              "second_sphere.youngs_modulus": sphere.youngs_modulus,
              "second_sphere.poisson_ratio": sphere.poisson_ratio,
              "second_sphere.gap": gap, "second_sphere.velocity": velocity, "second_sphere.mode": mode,
              "contact.history": "off"}  # the pair's integrator has no history force
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return scene.load(preset, {**second, **changes})


# -- one step on a toy mesh -------------------------------------------------------------------------
# delta_sl 0.4: the pair's hold delta_sl 2a* = 1.9 mm keeps the 8-cell indicators apart (as HoldingIntegrator's)
TOY = {"numerics.fd.cells_per_diameter": 8, "initial_gap": 0.02, "contact.delta_sl": 0.4}


@pytest.fixture(scope="module", params=[(2, "penalty"), (3, "penalty"), (2, "implicit"), (3, "implicit")])
def falling_column(request):
    """li2011-case3's sphere 2 D above the wall, an equal sphere 1 D above it coming down at 0.1 m/s; or
    three-spheres-wall's column of three, 1 D apart, at the same toy size; with either constraint."""
    count, constraint = request.param
    changes = {**TOY, "numerics.fd.constraint": constraint}
    if count == 2:
        sc = pair_scene("li2011-case3", changes, gap=0.0095, velocity=-0.1)
    else:
        sc = scene.load("three-spheres-wall", changes)
    fd = FictitiousDomainModel(sc, MPI.COMM_WORLD)
    fd.build(HoldingIntegrator(0.0019, *[0.0019] * (count - 1)))
    yield fd
    fd.destroy()


@pytest.mark.mpi
def test_a_step_has_a_symmetric_positive_added_mass_matrix(falling_column):
    """The N x N numerical added mass of two and three spheres is symmetric (the step's matrix is),
    positive definite, its diagonal near half the displaced mass (0.5 for a sharp sphere, more for the
    8-cell diffuse band), and each neighbour's entry negative (accelerating one sphere toward another
    pushes the other away) and near the potential-flow dipole coupling -(3/2) (a/l)^3 m_l (Lamb; l the
    centre distance).  The step's field then moves each interior with its own sphere.  The implicit
    constraint's matrix also holds the viscous response within its longer step (cfl 0.8 against the
    penalty's 0.2; it falls with the step, 0.78-0.83 on the diagonal at cfl 0.05) and its 8-cell body is
    larger: measured diagonal 0.85-0.93, neighbour entries 1.5-1.7 times the dipole's; its interiors move
    with their spheres to the friction's slip."""
    fd = falling_column
    sc = fd.scene
    implicit = sc.numerics.fd.constraint == "implicit"
    count = len(sc.spheres)
    velocities = np.zeros(count)
    velocities[1] = -0.1
    prediction = Prediction(0.0, np.array(sc.initial_gaps), velocities, fd.dt, velocities)
    force = fd.linearised_force(prediction)
    matrix = force.added_mass / sc.displaced_mass
    assert force.explicit.shape == (count,) and matrix.shape == (count, count)
    assert np.abs(matrix - matrix.T).max() < 1e-6 * np.abs(matrix).max()
    assert np.all(np.linalg.eigvalsh(0.5 * (matrix + matrix.T)) > 0.0)
    assert np.all((0.5 < np.diag(matrix)) & (np.diag(matrix) < (1.0 if implicit else 0.9)))
    for k in range(count - 1):
        distance = (sc.initial_gaps[k + 1] - sc.initial_gaps[k]) / sc.sphere.radius
        assert -(2.0 if implicit else 1.4) * 1.5 / distance**3 < matrix[k, k + 1] < -0.6 * 1.5 / distance**3
    reached = np.linspace(-0.01, -0.09, count)
    fd.complete(reached, fd.dt)
    for sphere, velocity in zip(fd.immersed.spheres, reached):
        assert sphere.interior(fd.flow.now.x.petsc_vec) == pytest.approx(velocity * sphere.volume,
                                                                         rel=1e-3 if implicit else 1e-9)
    assert fd.history.velocity == pytest.approx(reached)


def test_the_flow_keeps_a_moving_sphere_off_a_held_one():
    """Sphere 1 rising toward a held sphere 2 stops at the pair's hold gap below it (the wall's hold
    under sphere 1 as usual), and the indicators never overlap."""
    sc = pair_scene("li2011-case3", {**TOY, "motion.mode": "prescribed", "motion.velocity": 0.1}, gap=0.0095,
                    velocity=0.0, mode="fixed")
    fd = FictitiousDomainModel(sc, MPI.COMM_WORLD)
    try:
        fd.build(HoldingIntegrator(0.0019, 0.0019))
        gaps = np.array([sc.initial_gaps[0] + 0.009, sc.initial_gaps[1] + 0.003])
        centers = fd.predicted_centers(Prediction(0.0, gaps, np.zeros(2), 1e-3, np.zeros(2)))
    finally:
        fd.destroy()
    a = sc.sphere.radius
    assert centers[1] == pytest.approx(sc.initial_gaps[1] + a)
    assert centers[1] - centers[0] - 2 * a == pytest.approx(0.0019)


def test_a_hold_that_lets_the_indicators_overlap_is_refused():
    """At 8 cells/D the indicators reach D/16 beyond each surface: a pair hold (delta_sl 2a*, here D/10)
    below D/8 is refused when the model is made, before the run writes anything, with the settings to
    change."""
    sc = pair_scene("li2011-case3", {**TOY, "contact.delta_sl": 0.2, "numerics.fd.constraint": "penalty"},
                    gap=0.0095, velocity=-0.1)
    with pytest.raises(scene.SceneError, match="indicators overlap.*cells_per_diameter or contact.delta_sl"):
        FictitiousDomainModel(sc, MPI.COMM_WORLD)


# -- a held pair's steady Stokes drag ---------------------------------------------------------------
def steady_force(sc):
    fd = FictitiousDomainModel(sc, MPI.COMM_WORLD)
    try:
        fd.build(HoldingIntegrator(0.0, 0.0))
        return fd.steady_forces()
    finally:
        fd.destroy()


@pytest.mark.mpi
@pytest.mark.parametrize("constraint", ["penalty", "implicit"])
def test_held_pair_drag_follows_stimson_and_jeffery(constraint):
    """Two equal spheres 2 D apart (centres) moving together at Re = 0.01, 6 cells/D, no wall, slip
    sides 20 D away: each sphere's drag over the same mesh's isolated sphere is Stimson & Jeffery's
    lambda = 0.7423 within 4 % (measured +2.5 %; benchmarks/pair_stokes.py gives +1.2 % at 8 cells/D,
    far field 50 D; without the interaction it would be +35 %), equal on both spheres within 1 %
    (measured 0.2 %, the domain is not symmetric about the pair).  The isolated sphere's own drag is
    6 pi mu a U within 5 % (measured +2.0 %, mostly the slip sides 20 D away).  The implicit penalty's
    sharper surface depends more on where the cells cut it: 12 cells/D (+2.3 to +2.7 % on lambda, up to 1.1 %
    between the spheres, +4.4 % on the isolated drag; at 6 and 8 cells/D the spheres differ by 1.7 and 1.5 %)."""
    changes = {"numerics.fd.cells_per_diameter": 6 if constraint == "penalty" else 12, "numerics.fd.far_field": 20.0,
               "numerics.fd.steady_stokes": True, "wall.present": False, "initial_gap": 0.2,
               "numerics.fd.constraint": constraint}
    single = scene.load("brenner-approach", changes)
    pair = pair_scene("brenner-approach", changes, gap=0.01, velocity=single.motion.velocity, mode="fixed")
    alone = steady_force(single)
    forces = steady_force(pair)
    a = single.sphere.radius
    ratio = forces / alone
    # the implicit penalty's two spheres differ by how the cells cut each surface, and gmsh's mesh changes with the
    # last bits of its input (a gap 1e-15 larger or smaller gives anywhere between -1.1 % and +1.1 % at 12 cells/D):
    # 2.5 % covers that and still fails a sphere treated unlike the other (the interaction alone is 35 %)
    assert ratio[0] == pytest.approx(ratio[1], rel=0.01 if constraint == "penalty" else 0.025)
    assert np.mean(ratio) == pytest.approx(pair_theory.stimson_jeffery(a, 2 * a), rel=0.04)
    stokes = 6 * math.pi * single.liquid.viscosity * a * abs(single.motion.velocity)
    assert alone / stokes == pytest.approx(1.0, rel=0.05)
