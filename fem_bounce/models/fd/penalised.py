"""The rigid-body constraint as an implicit volume penalisation in the step's own matrix (the fd default).

    rho (3 u^{n+1} - 4 u^n + u^{n-1}) / (2 dt) + rho (u* . grad) u^{n+1} - mu Lap u^{n+1} + grad p^{n+1}
        + rho c_B phi (u^{n+1} - U e_z) = 0,      div u^{n+1} = 0,      u* = 2 u^n - u^{n-1},

with phi = sum_i phi_i the spheres' smoothed indicators at their predicted positions (immersed.py) and
U the sphere's velocity at t_{n+1} (U_i in sphere i's band).  This is the penalisation of Angot, Bruneau &
Fabrie (1999, Numer. Math. 81, 497), implicit in the velocity: the friction rho c_B phi acts on the new
field, so the interior follows the sphere within the step however fast it decelerates, and its strength
c_B (domain.penalty_rate: a large multiple of nu / h^2, U / h and 1 / dt) is set by the mesh, not bounded
by dt.  The interior slips by about 1 / numerics.fd.penalty_strength of the speed; the effective surface sits
where c_B phi first beats the viscous rate, a few hundredths of a cell inside the indicator's outer edge,
so that edge is put on the sphere's surface (numerics.fd.radius_offset unset: 0 with this constraint).

The matrix changes every step (the indicator moves, and convection is linearised about u*, implicit as in
the ale model: no convective step bound either), so it is assembled and factorised every step (MUMPS; a
factorisation costs about 15 back-solves on this stack, docs/performance.md).  The flow is affine in the
spheres' velocities, u(U) = x_0 + sum_j U_j x_j with x_0 = A^-1 b(u^n, u^{n-1}) and x_j = A^-1 (rho c_B b_j), b_j the
assembled int phi_j e_z . v dV (dV: fem.geometry's weighted measure, as in every form of the step): one pass over
the factors per step for all of them.

The force of the liquid on sphere i is the reaction to its penalty plus the rate of change of the
momentum of the liquid in the region the penalty holds (Uhlmann 2005, J. Comput. Phys. 209, 448, eq. 12).
The friction is strong enough to move all of the ball |x - X_i| < a_h with the sphere, the band included
(its slip is 1 / penalty_strength of the speed), so that momentum is rho U_i B_i with B_i = 4/3 pi a_h^3, not
the phi-weighted rho U_i V_i, V_i = int phi_i dV: weighting it with phi left the band's liquid,
rho (B_i - V_i), on the sphere as extra mass (0.55 of the displaced mass at 8 cells/D).  With
I_i(u) = int phi_i u_z dV and the BDF rate c (U_i B_i - J_i) (J_i: the BDF history of the ball's momentum
/ rho, U_i B_i on the fixed mesh; on the moving mesh B_i times its liquid's mean velocity I_i(u^k) / V_i at each
past level, as the liquid was, not as the sphere moved: models/fd/moving.py):

    F_i(U) = rho c_B (I_i(u) - U_i V_i) + rho c (U_i B_i - J_i),

affine in U, so the body integrator solves for U implicitly with the numerical added mass
M = -dF/dU / c (stable for any density ratio, coupling.py).

The indicator enters the matrix through a quadrature function: phi at the same quadrature points where
immersed.BandAssembler evaluates it exactly, zero in every cell the bands do not meet.
"""
from __future__ import annotations

import time

import basix
import basix.ufl
import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_matrix

from ...fem.solver import FactorizedOperator
from .coupling import Linearised
from .fluid import FlowSolver
from .immersed import QUADRATURE_DEGREE


class PenalisedFlow(FlowSolver):
    """BDF steps with the spheres' Brinkman friction rho c_B phi and implicit convection in the matrix.

    As fluid.FlowSolver, plus penalty_rate c_B [1/s]; `place` puts the spheres (an immersed.ImmersedBodies
    built on this flow), `linearise` solves the step, `field` gives u for the spheres' new velocities."""

    def __init__(self, mesh, facet_tags, sides, density, viscosity, dt, penalty_rate: float, **options):
        points, weights = basix.make_quadrature(basix.CellType.triangle, QUADRATURE_DEGREE)
        element = basix.ufl.quadrature_element(mesh.basix_cell(), points=points, weights=weights)
        self.indicator = fem.Function(fem.functionspace(mesh, element))  # phi at the band's quadrature points
        self.penalty_rate = penalty_rate
        self.dx_indicator = ufl.Measure("dx", domain=mesh, metadata={"quadrature_rule": "custom",
                                                                     "quadrature_points": points,
                                                                     "quadrature_weights": weights})
        super().__init__(mesh, facet_tags, sides, density, viscosity, dt, **options)
        self.x0 = fem.Function(self.W)
        self.bodies = None
        self.factorisations = 0
        self.assembly_s = self.factorise_s = self.solve_s = 0.0  # [s] in linearise

    def convecting(self, extrapolated):
        """The velocity that convects the new field: u* (on a moving mesh, u* less the mesh's velocity)."""
        return extrapolated

    def step_forms(self, u, p, v, q, extrapolated, history):
        """Convection linearised about u* and the friction rho c_B phi u . v in the matrix."""
        geometry, rho = self.geometry, self.density
        a = (geometry.stokes_operator(u, p, v, q, rho * self.rates[0], self.viscosity)
             + rho * geometry.convection(self.convecting(extrapolated), u, v)
             + self.friction(rho * self.penalty_rate, u, v))
        return a, geometry.source(history, v)

    def friction(self, coefficient, u, v) -> ufl.Form:
        """int coefficient phi u . v dV at the band's quadrature points (coefficient [kg/(m^3 s)], rho c_B)."""
        return self.geometry.weighted(coefficient * self.indicator * ufl.inner(u, v), self.dx_indicator)

    def place(self, bodies, centers) -> None:
        """Put the spheres (immersed.ImmersedBodies) at z = centers [m] and phi into the matrix's indicator."""
        self.bodies = bodies
        bodies.place(centers)
        values = self.indicator.x.array
        values[:] = 0.0
        dofs = self.indicator.function_space.dofmap.list
        for sphere in bodies.spheres:
            band = sphere.band
            values[dofs[band.cells]] += band.phi
        self.indicator.x.scatter_forward()

    def _responses(self, operator, history) -> tuple[np.ndarray, np.ndarray]:
        """x_0 (from the step's history; 0 without it) and each x_j through `operator`; return the spheres'
        interior integrals I_i(x_0) [m^4/s] and slopes I_i(x_j) [m^3]."""
        spheres = self.bodies.spheres
        units = [sphere.unit_forcing(self.penalty_rate) for sphere in spheres]  # rho c_B b_j
        if history:
            operator.solve_many([self.predictor_rhs(), *units], [self.x0.x.petsc_vec,
                                                                 *(sphere.unit.x.petsc_vec for sphere in spheres)])
        else:
            self.x0.x.array[:] = 0.0
            operator.solve_many(units, [sphere.unit.x.petsc_vec for sphere in spheres])
        for function in (self.x0, *(sphere.unit for sphere in spheres)):
            function.x.scatter_forward()
        interiors = self.bodies.interiors(self.x0.x.petsc_vec)
        slopes = np.array([[sphere.interior(other.unit.x.petsc_vec) for other in spheres] for sphere in spheres])
        return interiors, slopes

    def linearise(self, momentum_history: np.ndarray, reference: np.ndarray) -> Linearised:
        """Assemble and factorise the step's matrix, solve for x_0 and each x_j; F(U) as
        explicit - M c (U - reference) (coupling.Linearised) [N, kg, m/s]."""
        start = time.perf_counter()
        self.assembler.assemble()
        assembled = time.perf_counter()
        self.operator.refactor()
        self.factorisations += 1
        factorised = time.perf_counter()
        interiors, slopes = self._responses(self.operator, history=True)
        self.assembly_s += assembled - start
        self.factorise_s += factorised - assembled
        self.solve_s += time.perf_counter() - factorised
        rho, c, c_b = self.density, self.c, self.penalty_rate
        # F(U) = rho c_B (I(u(U)) - U V) + rho c (U B - J), I(u(U)) = I(x_0) + slopes U
        derivative = rho * c_b * (slopes - np.diag(self.bodies.volumes)) + rho * c * np.diag(self.bodies.ball_volumes)
        reference = np.asarray(reference, dtype=float)
        explicit = rho * c_b * interiors + derivative @ reference - rho * c * momentum_history
        return Linearised(explicit=explicit, added_mass=-derivative / c, reference=reference)

    def steady(self, velocities) -> np.ndarray:
        """The steady Stokes state of held spheres whose interiors move at `velocities` [m/s] (no time
        derivative, no convection: mu K + rho c_B Phi, one factorisation); every history level is set to it.
        Returns the forces F_i = rho c_B (I_i(u) - U_i V_i) [N]."""
        (u, p), (v, q) = ufl.TrialFunctions(self.W), ufl.TestFunctions(self.W)
        form = fem.form(self.geometry.stokes_operator(u, p, v, q, 0.0, self.viscosity)
                        + self.friction(self.density * self.penalty_rate, u, v))
        A = assemble_matrix(form, bcs=self.bcs, diag=self.geometry.dirichlet_diagonal)
        A.assemble()
        operator = FactorizedOperator(A, "fd_steady_")
        try:
            interiors, slopes = self._responses(operator, history=False)
        finally:
            operator.destroy()
            A.destroy()
        velocities = np.asarray(velocities, dtype=float)
        state = self.field(velocities, self.work)
        for level in self.states:
            state.copy(level.x.petsc_vec)
            level.x.scatter_forward()
        return self.density * self.penalty_rate * (slopes @ velocities - velocities * self.bodies.volumes)

    def field(self, velocities, out):
        """u = x_0 + sum_j U_j x_j [a W-vector] for the spheres' velocities U [m/s]."""
        self.x0.x.petsc_vec.copy(out)
        for sphere, velocity in zip(self.bodies.spheres, velocities):
            out.axpy(float(velocity), sphere.unit.x.petsc_vec)
        return out
