"""Axisymmetric incompressible flow on a fixed mesh, BDF2 in time, convection extrapolated.

    rho (3 u^{n+1} - 4 u^n + u^{n-1}) / (2 dt) + rho N(u*) - mu Lap u^{n+1} + grad p^{n+1} = f,
    div u^{n+1} = 0,      u* = 2 u^n - u^{n-1}  (EXT2),

with N the convective term (fem.geometry's convection, advective form).  Only the
right-hand side changes from step to step, so the Taylor-Hood P2/P1 saddle
point A = [rho c M + mu K, -B^T; -B, 0] (c = 3 / (2 dt), the geometry's weighted forms) is
assembled and factorised once; a step, or the response to a body force, is one
back-solve (Karniadakis, Israeli & Orszag 1991 for the BDF2/EXT2 pair).
Gravity is not in the fluid: the hydrostatic pressure does no work on a rigid
sphere beyond the buoyancy, which the sphere equation carries.

Boundaries are named by the mesh's facet tags (fem.taylor_hood: the side conditions the fd and
ale models share).
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import create_vector, set_bc
from petsc4py import PETSc

from ...fem.compat import collapse
from ...fem.geometry import Axisymmetric
from ...fem.matrix import FormMatrix
from ...fem.mesh import AXIS
from ...fem.solver import FactorizedOperator, FieldSplitOperator
from ...fem.taylor_hood import (SIDE_KINDS, field_indices, lifted_rhs, pressure_pin, set_velocity, side_constraints,
                                step_coefficients, taylor_hood_space)


class FlowSolver:
    """BDF2/EXT2 steps of the axisymmetric Navier-Stokes equations with one factorised matrix.

    density [kg/m3], viscosity [Pa s], dt [s]; `sides` maps WALL/OUTER/TOP to a kind in
    SIDE_KINDS; `inflow_speed` [m/s] is u_z on "inflow" sides."""

    def __init__(self, mesh, facet_tags, sides: dict[int, str], density: float, viscosity: float, dt: float,
                 inflow_speed: float = 0.0, order: int = 2, prefix: str = "fd_flow_", solver: str = "direct"):
        for kind in sides.values():
            if kind not in SIDE_KINDS:
                raise ValueError(f"boundary kind {kind!r} is not one of {SIDE_KINDS}")
        self.mesh, self.density, self.viscosity = mesh, density, viscosity
        self.order = order
        # the step's coefficients as constants of the forms (set_time_step): c, then -alpha_j / dt for the
        # history levels; the extrapolation's weights
        self.rates = fem.Constant(mesh, np.zeros(order + 1))
        self.weights = fem.Constant(mesh, np.zeros(order))
        self.set_time_step(dt)
        self.W = taylor_hood_space(mesh)
        self.states = [fem.Function(self.W) for _ in range(order)]  # u^n, u^{n-1}, ... (with p)
        self.now = self.states[0]
        self.predicted = fem.Function(self.W)
        self.inflow_speed = inflow_speed
        self.bcs = self._boundary_conditions(facet_tags, sides)

        self.geometry = Axisymmetric(mesh)
        (u, p), (v, q) = ufl.TrialFunctions(self.W), ufl.TestFunctions(self.W)
        self.test_velocity = v
        past = [ufl.split(state)[0] for state in self.states]
        extrapolated = sum(self.weights[j] * u_j for j, u_j in enumerate(past))
        history = density * sum(self.rates[j + 1] * u_j for j, u_j in enumerate(past))
        a, L = self.step_forms(u, p, v, q, extrapolated, history)
        self.a, self.L_history = fem.form(a), fem.form(L)
        self.assembler = FormMatrix(self.a, self.bcs, self.geometry.dirichlet_diagonal)
        A = self.matrix = self.assembler.petsc
        if solver == "fieldsplit":
            velocity, pressure = (field_indices(self.W, k) for k in (0, 1))
            # its own options prefix: the direct solver's defaults (ksp preonly, pc lu) live under `prefix`
            self.operator = FieldSplitOperator(A, prefix.rstrip("_") + "_fieldsplit_", velocity, pressure)
            velocity.destroy()
            pressure.destroy()
        else:
            self.operator = FactorizedOperator(A, prefix)
        self.rhs = create_vector(self.W)
        self.work = self.rhs.duplicate()

    def set_time_step(self, dt: float, previous: float | None = None, order: int | None = None) -> None:
        """The coming step's length dt [s] and the one before it (default dt): the BDF and extrapolation
        coefficients of the step (fem.taylor_hood.step_coefficients; variable-step BDF2 when they differ),
        of a lower `order` than the flow's for a cold start (the older levels then weigh 0), and order 2 for a
        step of another length than the one before at time_order 3 (a run's shortened last step).
        The matrix holds c: a solver that keeps its factors (this one) takes one step length only; the
        penalised flow assembles every step."""
        self.dt = dt
        ratio = dt / previous if previous else 1.0
        order = order or (self.order if ratio == 1.0 else min(self.order, 2))
        bdf, ext = step_coefficients(order, ratio)
        padding = (0.0,) * (self.order - order)
        self.bdf, self.ext = bdf + padding, ext + padding
        self.c = self.bdf[0] / dt  # du/dt ~ c (u^{n+1} - reference(u^n, u^{n-1}, ...))
        self.rates.value[:] = [self.c, *(-alpha / dt for alpha in self.bdf[1:])]
        self.weights.value[:] = self.ext

    def step_forms(self, u, p, v, q, extrapolated, history):
        """The step's bilinear and linear forms (UFL): convection extrapolated, so the matrix is fixed."""
        geometry, rho = self.geometry, self.density
        return (geometry.stokes_operator(u, p, v, q, rho * self.rates[0], self.viscosity),
                geometry.source(history, v) - rho * geometry.convection(extrapolated, extrapolated, v))

    # -- boundary conditions ---------------------------------------------------------------
    def _boundary_conditions(self, facet_tags, sides):
        W, fdim = self.W, self.mesh.topology.dim - 1
        bcs = []

        def component_bc(component: int, facets, value: float = 0.0):
            sub = W.sub(0).sub(component)
            space, _ = collapse(sub)
            g = fem.Function(space)
            g.x.array[:] = value
            dofs = fem.locate_dofs_topological((sub, space), fdim, facets)
            bcs.append(fem.dirichletbc(g, dofs, sub))

        component_bc(0, facet_tags.find(AXIS))
        fixed, pinned = side_constraints(facet_tags, sides)
        for component, facets, inflow in fixed:
            component_bc(component, facets, self.inflow_speed if inflow else 0.0)
        if pinned:
            bcs.append(pressure_pin(W, self.mesh))
        return bcs

    # -- the state ---------------------------------------------------------------------------
    def set_uniform(self, velocity: tuple[float, float]) -> None:
        """u^n = u^{n-1} = ... = velocity everywhere (an impulsive start from a uniform state)."""
        for state in self.states:
            set_velocity(state, velocity)

    def predictor_rhs(self) -> PETSc.Vec:
        """b(u^n, u^{n-1}, ...): history and extrapolated convection, boundary values set."""
        return lifted_rhs(self.rhs, self.L_history, self.a, self.bcs, self.geometry.dirichlet_diagonal)

    def force_rhs(self, force: PETSc.Vec) -> PETSc.Vec:
        """An assembled body-force vector made ready for a response with homogeneous boundary
        values: ghost contributions accumulated, Dirichlet rows zeroed (in place)."""
        force.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        set_bc(force, self.bcs, alpha=0.0)
        return force

    def solve(self, rhs: list, solutions: list) -> None:
        """A x = b for each pair, in one pass over the factors."""
        self.operator.solve_many(rhs, [x.x.petsc_vec for x in solutions])
        for x in solutions:
            x.x.scatter_forward()

    def commit(self, new: PETSc.Vec) -> None:
        """u^{n-1} <- u^n <- new (a mixed-space vector), and so on down the history."""
        for older, newer in zip(self.states[::-1], self.states[-2::-1]):
            older.x.array[:] = newer.x.array  # ghosts included
        self.now.x.petsc_vec.array[:] = new.array_r
        self.now.x.scatter_forward()

    @property
    def unknowns(self) -> int:
        return self.W.dofmap.index_map.size_global * self.W.dofmap.index_map_bs

    def destroy(self) -> None:
        self.operator.destroy()
        self.assembler.destroy()
        self.rhs.destroy()
        self.work.destroy()

