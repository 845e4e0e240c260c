"""Finite-element functions saved by dof coordinates, so a checkpoint does not depend on the partition.

    data = gather_values(u)              # on rank 0: {component: (coordinates (n, gdim), values (n,))}
    scatter_values(u, data)              # on every rank, for the same mesh on any number of ranks

Each scalar component of a (mixed, vector) space is stored as the coordinates of
its owned dofs and their values; loading matches the local dofs to the stored
coordinates (a k-d tree, exact up to round-off), so a run checkpointed on two ranks
restarts on one.  Components are named by their sub-space path, e.g. "0.1" for u_z
of a Taylor-Hood (u, p) space.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .compat import collapse


class CheckpointMismatch(RuntimeError):
    """The stored dof coordinates do not match this mesh."""


def scalar_components(space, path: str = "") -> list[tuple[str, object]]:
    """[(name, sub-space)] for every scalar leaf of a (mixed, vector) function space."""
    count = space.num_sub_spaces
    if count == 0:
        return [(path or "0", space)]
    leaves = []
    for k in range(count):
        leaves += scalar_components(space.sub(k), f"{path}.{k}" if path else str(k))
    return leaves


def _local_dofs(sub):
    """(parent dof indices, coordinates) of the owned dofs of a scalar sub-space."""
    collapsed, parent = collapse(sub)
    owned = collapsed.dofmap.index_map.size_local
    coordinates = collapsed.tabulate_dof_coordinates()[:owned, :collapsed.mesh.geometry.dim]
    return parent[:owned], coordinates


def gather_values(function) -> dict | None:
    """Owned dof coordinates and values of every scalar component, gathered on rank 0 (None elsewhere)."""
    comm = function.function_space.mesh.comm
    data = {}
    for name, sub in scalar_components(function.function_space):
        parent, coordinates = _local_dofs(sub)
        values = function.x.array[parent]
        pieces = comm.gather((coordinates, values), root=0)
        if comm.rank == 0:
            data[name] = (np.concatenate([p[0] for p in pieces]), np.concatenate([p[1] for p in pieces]))
    return data if comm.rank == 0 else None


def scatter_values(function, data: dict, tolerance: float) -> None:
    """Set `function` from gathered data; every local dof must lie within `tolerance` [m] of a stored one."""
    for name, sub in scalar_components(function.function_space):
        if name not in data:
            raise CheckpointMismatch(f"component {name} is missing from the checkpoint")
        coordinates, values = data[name]
        collapsed, parent = collapse(sub)
        local = collapsed.tabulate_dof_coordinates()[:, :collapsed.mesh.geometry.dim]
        distance, index = cKDTree(coordinates).query(local)
        if local.size and distance.max() > tolerance:
            raise CheckpointMismatch(f"component {name}: a dof lies {distance.max():.3g} m from every stored one")
        function.x.array[parent] = values[index]
    function.x.scatter_forward()


def gather_history(functions: list) -> dict:
    """The time levels of a flow (u^n, u^{n-1}, ...) as arrays for a checkpoint's .npz, gathered on rank 0
    ({} elsewhere): x_LEVEL_COMPONENT (dof coordinates) and v_LEVEL_COMPONENT (values)."""
    arrays = {}
    for level, function in enumerate(functions):
        for name, (coordinates, values) in (gather_values(function) or {}).items():
            arrays[f"x_{level}_{name}"] = coordinates
            arrays[f"v_{level}_{name}"] = values
    return arrays


def scatter_history(functions: list, arrays, tolerance: float) -> None:
    """Set the time levels from gather_history's arrays (read on every rank): each local dof takes the
    stored value within `tolerance` [m] of it, so a run checkpointed on two ranks restarts on one."""
    for level, function in enumerate(functions):
        names = sorted(key[len(f"x_{level}_"):] for key in arrays if key.startswith(f"x_{level}_"))
        if not names:
            raise CheckpointMismatch(f"flow.npz has no flow at time level {level}")
        scatter_values(function, {name: (arrays[f"x_{level}_{name}"], arrays[f"v_{level}_{name}"])
                                  for name in names}, tolerance)
