"""Flow fields of an fd or ale run written for post-processing: DIR/fields-KKK.xdmf (+ .h5) through dolfinx's
parallel XDMF writer, on a fixed mesh or on one that moves and is remade.

Every `output_every` steps the velocity, pressure and azimuthal vorticity go out as P1 nodal fields on the mesh
vertices (fem.vertex_fields: the vorticity omega = du_r/dz - du_z/dr is the lumped-mass L2 projection of the P2
velocity's curl onto P1, assembled on the mesh as it is).  KKK counts the run's segments (000 for the first, one
more per --restart or new fixed mesh), so a restart never rewrites what an earlier segment wrote.

A fixed mesh is written once, when the file opens.  A moving mesh is written with every snapshot as it is then
(a grid named mesh-K) and its fields point to it; `fem_bounce.fields.read_snapshots` follows those references,
and ParaView reads the file as a time series on a moving mesh.
"""
from __future__ import annotations

from pathlib import Path

from dolfinx import fem
from dolfinx.io import XDMFFile

from .vertex_fields import VertexFields


class FieldWriter:
    """Writes (velocity, pressure, vorticity) of Taylor-Hood states to one XDMF time series: on the fixed `mesh`
    (written now), or without one on the mesh each state lives on as it is at each snapshot (moving, remade)."""

    def __init__(self, comm, path: Path, mesh=None):
        self.file = XDMFFile(comm, str(path), "w")
        self.moving = mesh is None
        self.snapshots = 0
        self.fields: VertexFields | None = None
        if mesh is not None:
            self.file.write_mesh(mesh)

    def write(self, state: fem.Function, t: float) -> None:
        """One snapshot of the mixed (u, p) `state` at time t [s]."""
        mesh = state.function_space.mesh
        if self.fields is None or self.fields.state.function_space.mesh is not mesh:
            self.fields = VertexFields(state.function_space)
        self.fields.update(state)
        if self.moving:
            name = f"mesh-{self.snapshots}"
            mesh.name = name
            self.file.write_mesh(mesh)
            for function in self.fields.functions:
                self.file.write_function(function, t, mesh_xpath=f"/Xdmf/Domain/Grid[@Name='{name}']")
        else:
            for function in self.fields.functions:
                self.file.write_function(function, t)
        self.snapshots += 1

    def close(self) -> None:
        if self.file is not None:
            self.file.close()
            self.file = None
