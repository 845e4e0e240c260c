"""A flow carried from one 3-D mesh to another of the same box (the fd3d model's new patch meshes).

Each part of the mixed (u, p) state (the P2 velocity, the P1 pressure) is interpolated at the new mesh's
degrees of freedom from the old mesh by dolfinx's non-matching interpolation (`create_interpolation_data`,
`Function.interpolate_nonmatching`: the points are located in the old mesh across the ranks, so both meshes may
be distributed differently).  Both meshes fill the same box (gmsh meshes its planar faces, so no point of the new
mesh lies outside the old one beyond round-off, which the bounding boxes' padding takes), or the new box has moved
along the wall with the sphere (model.py): the new mesh's points beyond the old box, far from the sphere and beside
a slip side, take the liquid at rest (the interpolation sets a point it does not find to zero).  The 2-D
models' transfer (fem/transfer.py) gathers the old mesh on every rank instead, which a 3-D mesh is too large for.

The interpolated velocity is not discretely divergence-free on the new mesh: model.py projects it as the 2-D
models do (fem.transfer.DivergenceFreeProjection with the Cartesian geometry).
"""
from __future__ import annotations

import numpy as np
from dolfinx import fem

from ...fem.compat import collapse


def interpolate_states(sources: list, targets: list, padding: float) -> None:
    """Set each mixed (u, p) function of `targets` to the one of `sources` beside it (the same element on another
    mesh of the same domain, every source on one mesh and every target on another: the BDF levels); `padding` [m]:
    how far outside a cell's bounding box a point may lie and still be found (round-off).  The points are located
    once per part, for all the levels (the search is most of the cost: docs/performance.md, "A new mesh's cost")."""
    space, old = targets[0].function_space, sources[0].function_space
    mesh = space.mesh
    cells = np.arange(mesh.topology.index_map(mesh.topology.dim).size_local, dtype=np.int32)
    for k in range(space.num_sub_spaces):
        space_to, dofs_to = collapse(space.sub(k))
        space_from, dofs_from = collapse(old.sub(k))
        data = fem.create_interpolation_data(space_to, space_from, cells, padding=padding)
        part_from, part_to = fem.Function(space_from), fem.Function(space_to)
        for source, target in zip(sources, targets, strict=True):
            part_from.x.array[:] = source.x.array[dofs_from]
            part_to.interpolate_nonmatching(part_from, cells, data)
            part_to.x.scatter_forward()
            target.x.array[dofs_to] = part_to.x.array
    for target in targets:
        target.x.scatter_forward()
