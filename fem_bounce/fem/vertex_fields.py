"""A Taylor-Hood state as P1 fields at the mesh's vertices, for the field files of the fd, ale and fd3d models.

    fields = VertexFields(W)
    fields.update(state)          # velocity, pressure and vorticity of the (u, p) `state`, on the mesh as it is
    fields.functions              # (velocity, pressure, vorticity): what an XDMF file writes

The vorticity (by default the axisymmetric one, omega = du_r/dz - du_z/dr; the 3-D model passes the component
normal to its plane of motion) is the lumped-mass L2 projection of the P2 velocity's curl: each vertex gets the
area- (volume-) weighted mean of the curl around it, assembled on the mesh where it is (a moving mesh too), without
the over- and undershoots a consistent projection spreads from the thin boundary layers into the quiet far field,
and the same on any number of ranks (sampling the curl at the vertices took each vertex's value from one of its
cells, another one on another rank).
"""
from __future__ import annotations

import basix.ufl
import ufl
from dolfinx import fem, la

from .geometry import Axisymmetric


class VertexFields:
    """P1 velocity, pressure and vorticity of states of the Taylor-Hood space W; `vorticity`: the scalar vorticity of
    a velocity (a UFL expression; None: the axisymmetric one), written under `vorticity_name`."""

    def __init__(self, W, vorticity=None, vorticity_name: str = "vorticity"):
        mesh = W.mesh
        vectors = basix.ufl.element("Lagrange", mesh.basix_cell(), 1, shape=(mesh.geometry.dim,))
        self.velocity = fem.Function(fem.functionspace(mesh, vectors), name="velocity")
        scalars = fem.functionspace(mesh, ("Lagrange", 1))
        self.pressure = fem.Function(scalars, name="pressure")
        self.vorticity = fem.Function(scalars, name=vorticity_name)
        self.state = fem.Function(W)
        z = ufl.TestFunction(scalars)
        curl = (vorticity or Axisymmetric(mesh).vorticity)(ufl.split(self.state)[0])
        # plain dx, not the weighted measure: each vertex's value is the area-weighted mean of the curl around it
        self._forms = (fem.form(z * ufl.dx), fem.form(curl * z * ufl.dx))

    @property
    def functions(self) -> tuple:
        return self.velocity, self.pressure, self.vorticity

    def update(self, state: fem.Function) -> None:
        """The fields of the mixed (u, p) `state`."""
        self.state.x.array[:] = state.x.array
        self.velocity.interpolate(self.state.sub(0))
        self.pressure.interpolate(self.state.sub(1))
        lumped, curl = (fem.assemble_vector(form) for form in self._forms)
        for vector in (lumped, curl):
            vector.scatter_reverse(la.InsertMode.add)
            vector.scatter_forward()
        self.vorticity.x.array[:] = curl.array / lumped.array
