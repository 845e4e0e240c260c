"""The sphere's indicator in the mesh: the fast band assembly against the plain UFL forms, and exact integrals."""
import math

import numpy as np
import pytest
from dolfinx import fem
from dolfinx.fem.petsc import assemble_vector
from mpi4py import MPI
from petsc4py import PETSc
from scipy.integrate import quad

from fem_bounce import scene
from fem_bounce.models.fd import immersed
from fem_bounce.models.fd.model import FictitiousDomainModel
from fem_bounce.integrator import BodyIntegrator


@pytest.fixture(scope="module")
def model():
    sc = scene.load("li2011-case3", {"numerics.fd.cells_per_diameter": 8})
    fd = FictitiousDomainModel(sc, MPI.COMM_WORLD)
    fd.build(BodyIntegrator(sc, resolved=True))
    yield fd
    fd.destroy()


def accumulated(vector):
    vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    return vector


@pytest.mark.mpi
@pytest.mark.parametrize("center", [0.0123, 0.00475 + 1e-4])  # in the open, and almost touching the wall
def test_band_assembly_equals_the_ufl_forms(model, center):
    flow, sphere = model.flow, model.immersed.spheres[0]
    flow.predicted.sub(0).interpolate(lambda x: np.vstack([np.sin(300 * x[0]), np.cos(200 * x[1])]))
    flow.predicted.x.scatter_forward()
    reference = immersed.reference_forms(flow, fem.Constant(model.mesh, PETSc.ScalarType(center)),
                                         sphere.band.radius, sphere.band.width)
    sphere.place(center)
    b_phi = accumulated(assemble_vector(reference["indicator"]))
    assert (b_phi - sphere.b_phi).norm() <= 1e-13 * b_phi.norm()
    volume = MPI.COMM_WORLD.allreduce(fem.assemble_scalar(reference["volume"]), op=MPI.SUM)
    assert sphere.volume == pytest.approx(volume, rel=1e-13)
    forcing = accumulated(assemble_vector(reference["forcing"]))
    fast = model.immersed.forcing(flow.predicted)  # also zeroes Dirichlet rows: compare the others
    from dolfinx.fem.petsc import set_bc

    set_bc(forcing, flow.bcs, alpha=0.0)
    assert (forcing - fast).norm() <= 1e-13 * forcing.norm()


def test_indicator_volume_and_interior_integral_are_exact(model):
    """V_phi = int S((a_h - rho) / w) 4 pi rho^2 d rho, and I(u) = V_phi for u = e_z."""
    sphere, flow = model.immersed.spheres[0], model.flow
    a_h, w = sphere.band.radius, sphere.band.width
    center = 0.0123
    sphere.place(center)
    exact = 4.0 / 3.0 * math.pi * (a_h - w) ** 3 + quad(
        lambda rho: float(immersed.smooth_step(np.array((a_h - rho) / w))) * 4.0 * math.pi * rho**2, a_h - w, a_h)[0]
    assert sphere.volume == pytest.approx(exact, rel=2e-4)
    uniform = fem.Function(flow.W)
    uniform.sub(0).interpolate(lambda x: np.vstack([np.zeros(x.shape[1]), np.ones(x.shape[1])]))
    uniform.x.scatter_forward()
    assert sphere.interior(uniform.x.petsc_vec) == pytest.approx(sphere.volume, rel=1e-12)
