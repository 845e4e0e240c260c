"""Flow fields of an ale run: DIR/fields-000.xdmf (+ .h5) through dolfinx's parallel XDMF writer.

The mesh moves and is remade, so every snapshot writes the mesh as it is then (a grid
named mesh-K) and its fields point to it; `fem_bounce.fields.read_snapshots` follows
those references, and ParaView reads the file as a time series on a moving mesh.  As in
the fd model's fixed mesh (models/fd/fields.py) the fields are P1 at the vertices: velocity, pressure
and the azimuthal vorticity omega = du_r/dz - du_z/dr, the lumped-mass projection of the P2 velocity's
curl on the mesh as it is (sampling the curl at the vertices took each vertex's value from one of its
triangles, another one on another rank: in the layers at the wall and the surface the files of a
serial and a parallel run differed by the vorticity's whole size).
"""
from __future__ import annotations

from pathlib import Path

import basix.ufl
import ufl
from dolfinx import fem, la
from dolfinx.io import XDMFFile

from ...fem import forms


class MovingFieldWriter:
    """Writes (velocity, pressure, vorticity) of Taylor-Hood states on a moving, remade mesh."""

    def __init__(self, comm, path: Path):
        self.file = XDMFFile(comm, str(path), "w")
        self.snapshots = 0
        self._mesh = None

    def _spaces(self, mesh, W) -> None:
        vectors = basix.ufl.element("Lagrange", mesh.basix_cell(), 1, shape=(2,))
        self.velocity = fem.Function(fem.functionspace(mesh, vectors), name="velocity")
        scalars = fem.functionspace(mesh, ("Lagrange", 1))
        self.pressure = fem.Function(scalars, name="pressure")
        self.vorticity = fem.Function(scalars, name="vorticity")
        self.state = fem.Function(W)
        z = ufl.TestFunction(scalars)
        self._forms = (fem.form(z * ufl.dx), fem.form(forms.vorticity(ufl.split(self.state)[0]) * z * ufl.dx))
        self._mesh = mesh

    def _project_vorticity(self) -> None:
        """omega at the vertices: int curl(u) z dx / int z dx on the mesh where it is now."""
        lumped, curl = (fem.assemble_vector(form) for form in self._forms)
        for vector in (lumped, curl):
            vector.scatter_reverse(la.InsertMode.add)
            vector.scatter_forward()
        self.vorticity.x.array[:] = curl.array / lumped.array

    def write(self, state: fem.Function, t: float) -> None:
        """One snapshot of the mixed (u, p) `state` at time t [s], on its mesh as it is now."""
        mesh = state.function_space.mesh
        if mesh is not self._mesh:
            self._spaces(mesh, state.function_space)
        self.state.x.array[:] = state.x.array
        self.velocity.interpolate(self.state.sub(0))
        self.pressure.interpolate(self.state.sub(1))
        self._project_vorticity()
        name = f"mesh-{self.snapshots}"
        mesh.name = name
        self.file.write_mesh(mesh)
        for function in (self.velocity, self.pressure, self.vorticity):
            self.file.write_function(function, t, mesh_xpath=f"/Xdmf/Domain/Grid[@Name='{name}']")
        self.snapshots += 1

    def close(self) -> None:
        if self.file is not None:
            self.file.close()
            self.file = None
