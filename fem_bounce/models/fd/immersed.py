"""The sphere in the fixed mesh: a smoothed indicator and the forcing responses of one step.

    phi(x) = S((a_h - |x - X_p|) / w),   S(x) = x^2 (3 - 2 x) on [0, 1], 0 below, 1 above,

is 1 deep inside the sphere, falls smoothly (C^1) across a band of width w inside
the surface and is exactly 0 outside a_h.  The support matters: the immersed force
rho c phi (U - u~) acts, at steady state, like a Brinkman friction of strength
rho c phi, and c = 3 / (2 dt) is large, so any tail of phi outside the sphere
(a tanh profile has one) drags the fluid there along and inflates the body: with
a tanh half-level at a, eps one cell, Cd(Re = 100) came out 1.59 instead of 1.09.
With the support ending at a_h = a the effective surface sits just inside a_h,
where rho c phi first beats the local shear rate.

phi is evaluated exactly at the quadrature points (never interpolated), so moving
the sphere only changes a Constant.  The assembled vector
b_phi = assemble(phi e_z . v r dx) turns every weighted interior integral into a
dot product: I(w) = 2 pi b_phi . w.
"""
from __future__ import annotations

import math

import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_vector, create_vector
from mpi4py import MPI
from petsc4py import PETSc

from .coupling import InteriorIntegrals
from .fluid import FlowSolver

QUADRATURE_DEGREE = 6  # resolves a tanh profile a cell or two wide to ~1e-3


def indicator(x, center, radius: float, width: float):
    """The smoothed indicator of a sphere of `radius` centred on the axis at z = center,
    falling from 1 to 0 across the band radius - width < |x - X_p| < radius (a UFL expression)."""
    distance = ufl.sqrt(x[0] ** 2 + (x[1] - center) ** 2)
    depth = ufl.min_value(ufl.max_value((radius - distance) / width, 0.0), 1.0)
    return depth**2 * (3.0 - 2.0 * depth)


class ImmersedSphere:
    """Forcing responses of one sphere in `flow`; radius, width [m] of the indicator, center [m]."""

    def __init__(self, flow: FlowSolver, radius: float, width: float, center: float):
        mesh = flow.mesh
        self.flow = flow
        self.center = fem.Constant(mesh, PETSc.ScalarType(center))
        self.phi = indicator(ufl.SpatialCoordinate(mesh), self.center, radius, width)
        dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": QUADRATURE_DEGREE})
        v, r = flow.test_velocity, flow.r
        rho_c = flow.density * flow.c
        predicted_velocity = ufl.split(flow.predicted)[0]
        self.L_indicator = fem.form(self.phi * v[1] * r * dx)
        self.L_forcing = fem.form(-rho_c * self.phi * ufl.inner(predicted_velocity, v) * r * dx)
        self.volume_form = fem.form(2.0 * math.pi * self.phi * r * dx)
        self.b_phi = create_vector(self.L_indicator)
        self.force = self.b_phi.duplicate()
        self.forced = fem.Function(flow.W)  # y0
        self.unit = fem.Function(flow.W)  # y1
        self._unit_at: float | None = None  # where y1 was computed
        self.volume = 0.0

    def place(self, center: float) -> None:
        """Put the indicator's centre at z = center [m] and assemble b_phi and V_phi."""
        self.center.value = center
        with self.b_phi.localForm() as local:
            local.set(0.0)
        assemble_vector(self.b_phi, self.L_indicator)
        self.b_phi.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self.volume = self.flow.mesh.comm.allreduce(fem.assemble_scalar(self.volume_form), op=MPI.SUM)

    def interior(self, vector: PETSc.Vec) -> float:
        """I(w) = 2 pi int phi w_z r dx of a mixed-space vector [m^4/s for a velocity]."""
        return 2.0 * math.pi * self.b_phi.dot(vector)

    def respond(self, predicted: fem.Function) -> InteriorIntegrals:
        """Solve for y0 (forcing -rho c phi u~) and, if the sphere moved, y1 (forcing rho c phi e_z)."""
        flow = self.flow
        with self.force.localForm() as local:
            local.set(0.0)
        assemble_vector(self.force, self.L_forcing)
        flow.respond(self.force, self.forced)
        if self._unit_at != float(self.center.value):
            self.b_phi.copy(self.force)
            self.force.scale(flow.density * flow.c)
            # b_phi is already accumulated: respond() adds ghost contributions again, so clear them
            with self.force.localForm() as local:
                local.array[self.force.getLocalSize():] = 0.0
            flow.respond(self.force, self.unit)
            self._unit_at = float(self.center.value)
        return InteriorIntegrals(volume=self.volume, predicted=self.interior(predicted.vector),
                                 forced=self.interior(self.forced.vector), unit=self.interior(self.unit.vector))

    def destroy(self) -> None:
        self.b_phi.destroy()
        self.force.destroy()
