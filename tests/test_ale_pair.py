"""The ale model for a head-on pair (issue 14): two sphere holes in one mesh with their own boundary
tags, the steady Stokes drag of two spheres against Stimson & Jeffery (1926) and Cooley & O'Neill (1969),
and the two-sphere mesh motion, linearisation and a free pair's run."""
import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from fem_bounce.fem.mesh import AXIS, BOUNDARY_NAMES, SPHERE, SPHERE_2, HalfPlane, SphereHole, create_mesh

D = 0.01
RADIUS = D / 2


def pair_spec(gap, fine=D / 6, upper_radius=RADIUS, center=3 * D, size=(3 * D, 8 * D)):
    """Two holes on the axis, the lower one of diameter D centred at `center`, `gap` between the surfaces."""
    lower = SphereHole(center=center, radius=RADIUS, surface_size=fine, gap_cells=2.0)
    upper = SphereHole(center=lower.top + gap + upper_radius, radius=upper_radius, surface_size=fine, gap_cells=2.0)
    return HalfPlane(radius=size[0], height=size[1], fine_size=fine, coarse_size=D, grading=0.3, holes=(lower, upper))


@pytest.mark.mpi
def test_two_holes_have_their_areas_and_a_boundary_tag_each():
    comm = MPI.COMM_WORLD
    spec = pair_spec(0.5 * D, upper_radius=0.7 * RADIUS)
    mesh, _, facet_tags = create_mesh(comm, spec, cache=False)
    one = fem.Constant(mesh, 1.0)
    area = comm.allreduce(fem.assemble_scalar(fem.form(one * ufl.dx(mesh))))
    half_discs = math.pi * (RADIUS**2 + (0.7 * RADIUS) ** 2) / 2
    assert area == pytest.approx(spec.radius * spec.height - half_discs, rel=2e-3)  # polygonal circles
    ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags)
    lengths = {name: comm.allreduce(fem.assemble_scalar(fem.form(one * ds(tag))))
               for tag, name in BOUNDARY_NAMES.items()}
    assert lengths["sphere"] == pytest.approx(math.pi * RADIUS, rel=1e-2)  # chords of size D / 6
    assert lengths["sphere_2"] == pytest.approx(math.pi * 0.7 * RADIUS, rel=1e-2)
    assert lengths["axis"] == pytest.approx(spec.height - 2 * RADIUS - 1.4 * RADIUS, rel=1e-12)
    # the two surfaces are distinct sets of facets
    assert not set(facet_tags.find(SPHERE)) & set(facet_tags.find(SPHERE_2))


def test_the_thin_gap_between_two_spheres_keeps_its_triangles_across():
    """fem.mesh.SphereHole's gap rule with a sphere below: at a gap of 0.01 D between the surfaces the
    axis there still has gap_cells edges or more, and the rule does not refine past the two centres."""
    gap = 0.01 * D
    spec = pair_spec(gap)
    mesh, _, facet_tags = create_mesh(MPI.COMM_WORLD, spec, cache=False)
    lower, upper = spec.holes
    points = mesh.geometry.x
    in_gap = (np.abs(points[:, 0]) < 1e-12) & (points[:, 1] >= lower.top - 1e-12) & (points[:, 1] <= upper.gap + 1e-12)
    assert MPI.COMM_WORLD.allreduce(int(in_gap.sum()), op=MPI.MAX) >= 3
    # the size law: gap / 2 on the axis between them, the surface size above the upper centre
    assert spec.size_at(0.0, lower.top + gap / 2) == pytest.approx(gap / 2)
    assert spec.size_at(0.0, upper.center + 0.1 * D) > 0.5 * D / 6
    assert len(facet_tags.find(AXIS)) > 0


def test_holes_that_overlap_or_come_with_hole_are_refused():
    lower, upper = pair_spec(0.1 * D).holes
    with pytest.raises(ValueError, match="overlap"):
        HalfPlane(radius=3 * D, height=8 * D, fine_size=D / 6, coarse_size=D, grading=0.3, holes=(upper, lower))
    with pytest.raises(ValueError, match="not both"):
        HalfPlane(radius=3 * D, height=8 * D, fine_size=D / 6, coarse_size=D, grading=0.3, hole=lower, holes=(upper,))
