"""The calls where dolfinx 0.10 and 0.11 differ (the import order the PyPI wheel needs is fem_bounce/__init__.py's).

The package is written against dolfinx 0.11 (PyPI's `dolfinx-solver-real`, conda-forge) and runs on
0.10 (conda-forge, Ubuntu 26.04) through these few functions; nothing else in it asks for a version.
"""
from __future__ import annotations

import numpy as np


def collapse(space):
    """(the collapsed sub-space, the parent space's dofs of its dofs as one array): 0.11 returns one
    array per cell type, 0.10 a single array."""
    collapsed, dofs = space.collapse()
    return collapsed, np.asarray(dofs[0] if isinstance(dofs, list) else dofs)


def geometry_cells(mesh) -> np.ndarray:
    """Each cell's geometry nodes, shape (cells, nodes per cell): `geometry.dofmaps[0]` in 0.11
    (`geometry.dofmap` is deprecated there), `geometry.dofmap` in 0.10."""
    geometry = mesh.geometry
    return geometry.dofmaps[0] if hasattr(type(geometry), "dofmaps") else geometry.dofmap
