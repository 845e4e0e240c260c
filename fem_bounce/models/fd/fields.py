"""Flow fields of an fd run written for post-processing: XDMF/HDF5 through dolfinx's parallel writer.

Every `output_every` steps the velocity, pressure and azimuthal vorticity go to
DIR/fields-KKK.xdmf (+ .h5) as P1 nodal fields on the mesh vertices; KKK counts
the run's segments (000 for the first, one more per --restart), so a restart
never rewrites what an earlier segment wrote.  `fem_bounce.fields.read_snapshots`
reads them back.  The vorticity omega = du_r/dz - du_z/dr is the lumped-mass L2
projection of the P2 velocity's curl onto P1 (fem.vertex_fields).
"""
from __future__ import annotations

from pathlib import Path

from dolfinx import fem
from dolfinx.io import XDMFFile

from ...fem.vertex_fields import VertexFields


class FieldWriter:
    """Writes (velocity, pressure, vorticity) of a Taylor-Hood state to one XDMF time series."""

    def __init__(self, comm, mesh, W, path: Path):
        self.fields = VertexFields(W)
        self.file = XDMFFile(comm, str(path), "w")
        self.file.write_mesh(mesh)

    def write(self, state: fem.Function, t: float) -> None:
        self.fields.update(state)
        for function in self.fields.functions:
            self.file.write_function(function, t)

    def close(self) -> None:
        if self.file is not None:
            self.file.close()
            self.file = None
