"""Flow-field snapshots: XDMF + HDF5 in the run directory, and a reader.

    DIR/fields.xdmf, DIR/fields.h5     velocity (r, z components) [m/s], pressure [Pa],
                                       azimuthal vorticity du/dz - dw/dr [1/s]

Fields live at the grid nodes (R_i, Z_j), the points are (r, z) and each grid cell
is split into two triangles, so any triangle-mesh plotting tool reads them.
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

FIELDS_FILE = "fields.xdmf"


class Snapshot(NamedTuple):
    time: float  # [s]
    points: np.ndarray  # (N, 2): r, z [m]
    triangles: np.ndarray  # (M, 3) point indices
    fields: dict  # 'velocity' (N, 2), 'pressure' (N,), 'vorticity' (N,)


def node_mesh(r_nodes: np.ndarray, z_nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points (row-major over r then z, matching arrays of shape (nr+1, nz+1)) and split quads."""
    rr, zz = np.meshgrid(r_nodes, z_nodes, indexing="ij")
    points = np.column_stack([rr.ravel(), zz.ravel()])
    nz1 = len(z_nodes)
    index = np.arange(points.shape[0]).reshape(len(r_nodes), nz1)
    a, b = index[:-1, :-1].ravel(), index[1:, :-1].ravel()
    c, d = index[1:, 1:].ravel(), index[:-1, 1:].ravel()
    triangles = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return points, triangles


class SnapshotWriter:
    """Writes one time series; open on rank 0 only."""

    def __init__(self, run_dir: Path, r_nodes: np.ndarray, z_nodes: np.ndarray):
        import meshio

        self.points, self.triangles = node_mesh(r_nodes, z_nodes)
        self._writer = meshio.xdmf.TimeSeriesWriter(str(Path(run_dir) / FIELDS_FILE))
        self._writer.__enter__()
        self._writer.write_points_cells(self.points, [("triangle", self.triangles)])
        self.count = 0

    def write(self, time: float, velocity_r: np.ndarray, velocity_z: np.ndarray, pressure: np.ndarray,
              vorticity: np.ndarray) -> None:
        """Nodal arrays of shape (nr+1, nz+1)."""
        self._writer.write_data(time, point_data={
            "velocity": np.column_stack([velocity_r.ravel(), velocity_z.ravel()]),
            "pressure": pressure.ravel(),
            "vorticity": vorticity.ravel(),
        })
        self.count += 1

    def close(self) -> None:
        if self._writer is not None:
            self._writer.__exit__(None, None, None)
            self._writer = None


def read_snapshots(run_dir: Path) -> list[Snapshot]:
    """Every snapshot a run wrote, oldest first."""
    import meshio

    path = Path(run_dir) / FIELDS_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{path}: this run wrote no field snapshots (set numerics.ib.output_every)")
    with meshio.xdmf.TimeSeriesReader(str(path)) as reader:
        points, cells = reader.read_points_cells()
        triangles = next(block.data for block in cells if block.type == "triangle")
        out = []
        for k in range(reader.num_steps):
            time, point_data, _ = reader.read_data(k)
            fields = {name: np.asarray(point_data[name]) for name in ("velocity", "pressure", "vorticity")}
            out.append(Snapshot(float(time), np.asarray(points)[:, :2], np.asarray(triangles), fields))
    return out
