"""Flow fields of an fd run written for post-processing: XDMF/HDF5 through dolfinx's parallel writer.

Every `output_every` steps the velocity, pressure and azimuthal vorticity go to
DIR/fields-KKK.xdmf (+ .h5) as P1 nodal fields on the mesh vertices; KKK counts
the run's segments (000 for the first, one more per --restart), so a restart
never rewrites what an earlier segment wrote.  `fem_bounce.fields.read_snapshots`
reads them back.  The vorticity omega = du_r/dz - du_z/dr is the lumped-mass L2
projection of the P2 velocity's curl onto P1: each vertex gets the area-weighted
mean of the curl around it, without the over- and undershoots a consistent
projection spreads from the thin boundary layers into the quiet far field.
"""
from __future__ import annotations

from pathlib import Path

import basix.ufl
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_vector
from dolfinx.io import XDMFFile
from petsc4py import PETSc

from ...fem import forms


class FieldWriter:
    """Writes (velocity, pressure, vorticity) of a Taylor-Hood state to one XDMF time series."""

    def __init__(self, comm, mesh, W, path: Path):
        vectors = basix.ufl.element("Lagrange", mesh.basix_cell(), 1, shape=(2,))
        self.velocity = fem.Function(fem.functionspace(mesh, vectors), name="velocity")
        scalars = fem.functionspace(mesh, ("Lagrange", 1))
        self.pressure = fem.Function(scalars, name="pressure")
        self.vorticity = fem.Function(scalars, name="vorticity")
        self.state = fem.Function(W)
        self._velocity_sub, self._pressure_sub = self.state.sub(0), self.state.sub(1)
        z = ufl.TestFunction(scalars)
        self._lumped_mass = fem.petsc.assemble_vector(fem.form(z * ufl.dx))
        self._lumped_mass.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self._curl = fem.form(forms.vorticity(ufl.split(self.state)[0]) * z * ufl.dx)
        self._rhs = fem.petsc.create_vector(scalars)
        self.file = XDMFFile(comm, str(path), "w")
        self.file.write_mesh(mesh)

    def write(self, state: fem.Function, t: float) -> None:
        self.state.x.array[:] = state.x.array
        self.velocity.interpolate(self._velocity_sub)
        self.pressure.interpolate(self._pressure_sub)
        with self._rhs.localForm() as local:
            local.set(0.0)
        assemble_vector(self._rhs, self._curl)
        self._rhs.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.vorticity.x.petsc_vec.pointwiseDivide(self._rhs, self._lumped_mass)
        self.vorticity.x.scatter_forward()
        for function in (self.velocity, self.pressure, self.vorticity):
            self.file.write_function(function, t)

    def close(self) -> None:
        if self.file is not None:
            self.file.close()
            self.file = None
        self._lumped_mass.destroy()
        self._rhs.destroy()
