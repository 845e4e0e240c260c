"""The gmsh half-plane: geometry, named boundaries, the size field and the cache."""
import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from fem_bounce.fem import mesh as halfplane
from fem_bounce.fem.compat import geometry_cells

SPEC = halfplane.HalfPlane(radius=0.05, height=0.08, fine_size=0.002, coarse_size=0.01, grading=0.2,
                           refined=(halfplane.Box(r_max=0.01, z_min=0.0, z_max=0.03),))


@pytest.fixture
def cache(tmp_path, monkeypatch):
    folder = MPI.COMM_WORLD.bcast(str(tmp_path), root=0)
    monkeypatch.setenv("FEM_BOUNCE_CACHE", folder)
    return type(tmp_path)(folder) / "meshes"


@pytest.mark.mpi
def test_half_plane_area_boundaries_and_sizes(cache):
    comm = MPI.COMM_WORLD
    mesh, _, facets = halfplane.create_mesh(comm, SPEC)
    one = fem.Constant(mesh, 1.0)
    area = comm.allreduce(fem.assemble_scalar(fem.form(one * ufl.dx(mesh))))
    assert area == pytest.approx(SPEC.radius * SPEC.height, rel=1e-12)
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facets)
    lengths = {}
    for tag, name in halfplane.BOUNDARY_NAMES.items():
        lengths[name] = comm.allreduce(fem.assemble_scalar(fem.form(one * ds(tag))))
    assert lengths["wall"] == pytest.approx(SPEC.radius) and lengths["outer"] == pytest.approx(SPEC.height)
    assert lengths["axis"] == pytest.approx(SPEC.height) and lengths["top"] == pytest.approx(SPEC.radius)
    # triangle sizes follow the field: fine inside the box, graded, capped far away
    x = mesh.geometry.x[:, :2]
    cells = geometry_cells(mesh)
    edges = np.linalg.norm(x[cells] - x[np.roll(cells, 1, axis=1)], axis=2).max(axis=1)
    centroid = x[cells].mean(axis=1)
    target = SPEC.size_at(centroid[:, 0], centroid[:, 1])
    ratio = edges / target
    assert 0.7 < np.median(ratio) < 1.4 and ratio.max() < 2.5


def test_cache_is_keyed_by_every_parameter(cache):
    comm = MPI.COMM_SELF
    first, _, _ = halfplane.create_mesh(comm, SPEC)
    files = list(cache.glob("halfplane-*.msh"))
    assert len(files) == 1 and SPEC.key() in files[0].name
    stamp = files[0].stat().st_mtime_ns
    again, _, _ = halfplane.create_mesh(comm, SPEC)
    assert files[0].stat().st_mtime_ns == stamp  # read back, not remeshed
    assert np.array_equal(first.geometry.x, again.geometry.x)
    finer = halfplane.HalfPlane(**{**SPEC.__dict__, "fine_size": 0.0015})
    assert finer.key() != SPEC.key()
    halfplane.create_mesh(comm, finer)
    assert len(list(cache.glob("halfplane-*.msh"))) == 2


def test_inconsistent_spec_is_refused():
    with pytest.raises(ValueError, match="inconsistent mesh spec"):
        halfplane.HalfPlane(radius=0.05, height=0.08, fine_size=0.02, coarse_size=0.01, grading=0.2)
