"""Flow fields of an ale run: DIR/fields-000.xdmf (+ .h5) through dolfinx's parallel XDMF writer.

The mesh moves and is remade, so every snapshot writes the mesh as it is then (a grid
named mesh-K) and its fields point to it; `fem_bounce.fields.read_snapshots` follows
those references, and ParaView reads the file as a time series on a moving mesh.  As in
the fd model's fixed mesh the fields are P1 at the vertices (fem.vertex_fields: velocity, pressure and
the vorticity's lumped projection, assembled on the mesh as it is).
"""
from __future__ import annotations

from pathlib import Path

from dolfinx import fem
from dolfinx.io import XDMFFile

from ...fem.vertex_fields import VertexFields


class MovingFieldWriter:
    """Writes (velocity, pressure, vorticity) of Taylor-Hood states on a moving, remade mesh."""

    def __init__(self, comm, path: Path):
        self.file = XDMFFile(comm, str(path), "w")
        self.snapshots = 0
        self.fields: VertexFields | None = None

    def write(self, state: fem.Function, t: float) -> None:
        """One snapshot of the mixed (u, p) `state` at time t [s], on its mesh as it is now."""
        mesh = state.function_space.mesh
        if self.fields is None or self.fields.state.function_space.mesh is not mesh:
            self.fields = VertexFields(state.function_space)
        self.fields.update(state)
        name = f"mesh-{self.snapshots}"
        mesh.name = name
        self.file.write_mesh(mesh)
        for function in self.fields.functions:
            self.file.write_function(function, t, mesh_xpath=f"/Xdmf/Domain/Grid[@Name='{name}']")
        self.snapshots += 1

    def close(self) -> None:
        if self.file is not None:
            self.file.close()
            self.file = None
