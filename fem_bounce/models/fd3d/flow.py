"""Taylor-Hood P2/P1 flow in a 3-D box with a sphere held by an implicit volume penalty.

Steady Stokes (`steady`) and the BDF2 step (`step`) of

    rho (3 u^{n+1} - 4 u^n + u^{n-1}) / (2 dt) + rho (u* . grad) u^{n+1} - mu Lap u^{n+1} + grad p^{n+1}
        + rho c_B phi (u^{n+1} - U_rigid) = f,      div u^{n+1} = 0,      u* = 2 u^n - u^{n-1},

U_rigid = U + omega x (x - X) = sum_j s_j m_j the sphere's rigid motion over the geometry's modes m_j
(fem.geometry.Cartesian: six in space, three in the half box symmetric about y = 0), phi the sphere's
indicator (indicator.py).  This is the axisymmetric fd model's implicit penalisation (models/fd/penalised.py;
Angot, Bruneau & Fabrie 1999, Numer. Math. 81, 497) in three dimensions: the friction acts on the new field,
so the held ball follows the sphere within the step, and its slip is about 1 / (c_B / max(nu / h^2, U / h, c))
of the speed.  Convection is linearised about the extrapolated u*, implicit in the matrix as in the
axisymmetric model (no convective step bound from it).

The step is affine in the amplitudes s: u(s) = x_0 + sum_j s_j x_j with x_0 = A^-1 b (the history, the body
force and the boundary values) and x_j = A^-1 (rho c_B b_j), b_j = int phi m_j . v: one factorisation and one
pass over the factors for all right-hand sides.  The penalty's reaction on the sphere, as a generalised force
on mode i (the force component for a translation, the torque about X for a rotation),

    F_i(s) = rho c_B int phi (u(s) - U_rigid) . m_i = rho c_B (I_i(x_0) + sum_j (I_i(x_j) - G_ij) s_j),

I_i(w) = b_i . w, G_ij = int phi m_i . m_j, is then affine in s too (`response.RigidResponse`); the body
integrator adds the rate of the held ball's momentum (its `ball_mass`) to have the liquid's whole force.
Every integral is the geometry's (its weight doubles the half box's), so the forces are the whole sphere's.

A mesh velocity may carry a part that moves with one rigid amplitude, w = w_0 + s_k w_k (`carried` = (the mode's
name, w_k), switched on by `carrying`): its convection -rho s_k ((w_k . grad) u) is taken about u*, a term linear in
s_k, so it joins mode k's forcing, x_k = A^-1 (rho c_B b_k + rho int ((w_k . grad) u*) . v), and the step stays affine
in s with the mesh velocity's part implicit in the force (the fd3d model's oblique hold, model.py).

Sides (by the mesh's facet groups, mesh.py): "no-slip" (u = 0), "slip" (zero normal velocity), "inflow"
(u = `inflow`, a vector or a function of x), "outflow" (do nothing); the half box's symmetry plane always has
u_y = 0.  Without an outflow side the pressure is pinned at the box's top far corner.  Each PETSc solver has
its own options prefix: `{prefix}steady_`, `{prefix}step_` (-fd3d_step_pc_factor_mat_solver_type ...) and, for the
kept factors, `{prefix}reuse_` (-fd3d_reuse_ksp_gmres_restart ...).
"""
from __future__ import annotations

import time

import basix.ufl
import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_matrix, assemble_vector, create_vector, set_bc
from mpi4py import MPI
from petsc4py import PETSc

from ...fem.compat import collapse
from ...fem.matrix import FormMatrix
from ...fem.solver import FactorizedOperator, ReusedFactorOperator
from ...fem.taylor_hood import lifted_rhs, owned_dirichlet_rows, step_coefficients
from .indicator import SphereIndicator
from .mesh import NORMAL_COMPONENT, SYMMETRY
from .response import RigidResponse

SIDE_KINDS = ("no-slip", "slip", "inflow", "outflow")
# "direct": every step factorises its matrix; "reuse": the first step's factors precondition FGMRES with the later
# steps' matrices (fem.solver.ReusedFactorOperator), for a sphere held still in the mesh's frame (the penalty's place
# in the matrix fixed, only the convection changing)
STEP_SOLVERS = ("direct", "reuse")


def taylor_hood_space(mesh) -> fem.FunctionSpace:
    """The mixed space of (u, p) on a 3-D mesh: continuous P2 velocity (3 components), P1 pressure."""
    cell = mesh.basix_cell()
    velocity = basix.ufl.element("Lagrange", cell, 2, shape=(3,))
    return fem.functionspace(mesh, basix.ufl.mixed_element([velocity, basix.ufl.element("Lagrange", cell, 1)]))


class PenalisedFlow3D:
    """The penalised flow around one sphere (indicator.SphereIndicator) in a box (mesh.create_box_mesh).

    geometry: fem.geometry.Cartesian of the mesh (mirrored for the half box); sides: facet group -> kind;
    density [kg/m^3], viscosity [Pa s], penalty_rate c_B [1/s]; inflow [m/s]: the velocity on "inflow" sides;
    moving: the names of the modes the sphere moves in (None: all), the only responses solved for."""

    def __init__(self, geometry, facet_tags, sides: dict[int, str], density: float, viscosity: float,
                 sphere: SphereIndicator, penalty_rate: float, inflow=(0.0, 0.0, 0.0), prefix: str = "fd3d_",
                 step_solver: str = "direct", moving: tuple[str, ...] | None = None, mesh_velocity=None,
                 carried=None):
        if step_solver not in STEP_SOLVERS:
            raise ValueError(f"step_solver must be one of {STEP_SOLVERS}, not {step_solver!r}")
        for kind in sides.values():
            if kind not in SIDE_KINDS:
                raise ValueError(f"boundary kind {kind!r} is not one of {SIDE_KINDS}")
        if geometry.mirrored and SYMMETRY in sides:
            raise ValueError("the half box's symmetry plane takes no side kind: it always has u_y = 0")
        self.geometry, self.mesh = geometry, geometry.mesh
        self.density, self.viscosity, self.penalty_rate = density, viscosity, penalty_rate
        self.sphere, self.prefix, self.step_solver = sphere, prefix, step_solver
        # "reuse": a factorisation's cost in Krylov iterations (fem.solver.ReusedFactorOperator's renewal rule)
        self.factorisation_cost = 40.0
        self.mesh_velocity = mesh_velocity  # w of a moving mesh (UFL; motion.MeshMotion3D), None on a fixed one
        self.carried, self.carrying = carried, False  # (mode name, w_k) of the module docstring; on when set
        self.W = taylor_hood_space(self.mesh)
        self.bcs = self._boundary_conditions(facet_tags, sides, inflow)
        (self.u, self.p), (self.v, self.q) = ufl.TrialFunctions(self.W), ufl.TestFunctions(self.W)
        self.modes = geometry.rigid_modes(sphere.center)
        names = geometry.mode_names if moving is None else moving
        unknown = set(names) - set(geometry.mode_names)
        if unknown:
            raise ValueError(f"moving modes {sorted(unknown)} are not among {geometry.mode_names}")
        # the modes whose responses x_j each step solves for (the others' amplitudes stay 0, their slopes NaN)
        self.moving = [geometry.mode_names.index(name) for name in names]
        # b_i = int phi m_i . v, the interior integrals' vectors (not lifted, no boundary rows: the ball is inside)
        self._mode_forms = [fem.form(geometry.weighted(sphere.phi * ufl.inner(m, self.v), sphere.dx))
                            for m in self.modes]
        self._mode_mass_forms = [[fem.form(geometry.weighted(sphere.phi * ufl.inner(m_i, m_j), sphere.dx))
                                  for m_j in self.modes] for m_i in self.modes]
        self.mode_vectors = [create_vector(self.W) for _ in self.modes]
        self.units = [create_vector(self.W) for _ in self.modes]  # rho c_B b_j with the boundary rows zeroed
        self.rhs = create_vector(self.W)
        self.x0 = fem.Function(self.W, name="x0")
        self.responses = [fem.Function(self.W, name=f"x_{name}") for name in geometry.mode_names]
        self.states = [fem.Function(self.W, name=f"u{k}") for k in ("n", "n-1")]  # u^n, u^{n-1} (with p)
        self.rates = fem.Constant(self.mesh, np.zeros(3))  # c and -alpha_j / dt of BDF2 (set_time_step)
        self.weights = fem.Constant(self.mesh, np.zeros(2))  # the extrapolation's
        self.c = 0.0
        self._step = None  # (FormMatrix, its solver, the compiled bilinear and linear forms), made at the first step
        self._carried = None  # (mode index, compiled load, its vector, the forcing's vector), made at the first step
        self.factorisations = 0
        self.assembly_s = self.factorise_s = self.solve_s = 0.0  # [s] of the steps
        self._modes_at = None
        self.steady_costs: dict = {}  # the last steady solve's times [s], back-solves and MUMPS memory [bytes]

    # -- boundary conditions -------------------------------------------------------------------
    def _boundary_conditions(self, facet_tags, sides, inflow):
        W, fdim = self.W, self.mesh.topology.dim - 1
        V, _ = collapse(W.sub(0))
        bcs = []
        boundary_velocity = fem.Function(V)
        if callable(inflow):
            boundary_velocity.interpolate(inflow)
        else:
            boundary_velocity.interpolate(lambda x: np.outer(np.asarray(inflow, dtype=float), np.ones(x.shape[1])))

        def component(k: int, facets):
            sub = W.sub(0).sub(k)
            space, _ = collapse(sub)
            dofs = fem.locate_dofs_topological((sub, space), fdim, facets)
            bcs.append(fem.dirichletbc(fem.Function(space), dofs, sub))

        pinned = True
        for side, kind in sides.items():
            facets = facet_tags.find(side)
            if kind in ("no-slip", "inflow"):
                value = boundary_velocity if kind == "inflow" else fem.Function(V)
                dofs = fem.locate_dofs_topological((W.sub(0), V), fdim, facets)
                bcs.append(fem.dirichletbc(value, dofs, W.sub(0)))
            elif kind == "slip":
                component(NORMAL_COMPONENT[side], facets)
            else:
                pinned = False
        if self.geometry.mirrored:
            component(NORMAL_COMPONENT[SYMMETRY], facet_tags.find(SYMMETRY))
        if pinned:
            bcs.append(self._pressure_pin())
        return bcs

    def _pressure_pin(self):
        """p = 0 at the box's top far corner (largest x, y and z), for a pressure fixed only up to a constant."""
        Q, _ = collapse(self.W.sub(1))
        x = self.mesh.geometry.x
        corner = x.max(axis=0) if x.size else np.full(3, -np.inf)
        corner = np.array([self.mesh.comm.allreduce(corner[k], op=MPI.MAX) for k in range(3)])
        dofs = fem.locate_dofs_geometrical((self.W.sub(1), Q), lambda y: np.all(np.isclose(y.T, corner), axis=1))
        return fem.dirichletbc(fem.Function(Q), dofs, self.W.sub(1))

    # -- the forms -----------------------------------------------------------------------------
    def penalty(self, u, v) -> ufl.Form:
        """rho c_B int phi u . v: the friction that holds the ball."""
        return self.density * self.penalty_rate * self.geometry.weighted(self.sphere.phi * ufl.inner(u, v),
                                                                         self.sphere.dx)

    def steady_form(self) -> ufl.Form:
        """mu K + B + B^T + rho c_B Phi."""
        return (self.geometry.stokes_operator(self.u, self.p, self.v, self.q, 0.0, self.viscosity)
                + self.penalty(self.u, self.v))

    def step_forms(self):
        """The BDF2 step's matrix (convection linearised about u*, the penalty) and its history's form."""
        g, rho = self.geometry, self.density
        past = [ufl.split(state)[0] for state in self.states]
        extrapolated = self.extrapolated()
        history = rho * (self.rates[1] * past[0] + self.rates[2] * past[1])
        a = (g.stokes_operator(self.u, self.p, self.v, self.q, rho * self.rates[0], self.viscosity)
             + rho * g.convection(self.convecting(extrapolated), self.u, self.v) + self.penalty(self.u, self.v))
        return a, g.source(history, self.v)

    def extrapolated(self):
        """u* = 2 u^n - u^{n-1} (the variable step's weights), the velocity the step's convection is taken about."""
        past = [ufl.split(state)[0] for state in self.states]
        return self.weights[0] * past[0] + self.weights[1] * past[1]

    def _carried_forcing(self):
        """(mode index, the load rho int ((w_k . grad) u*) . v compiled, its vector, mode k's whole forcing vector)."""
        name, w = self.carried
        load = fem.form(self.density * self.geometry.convection(w, self.extrapolated(), self.v))
        return self.geometry.mode_names.index(name), load, create_vector(self.W), create_vector(self.W)

    def _forcing(self, j: int) -> PETSc.Vec:
        """Mode j's forcing of the step: rho c_B b_j, with the carried mesh velocity's load when it is on."""
        if not self.carrying or self._carried is None or self._carried[0] != j:
            return self.units[j]
        _, load, vector, forcing = self._carried
        with vector.localForm() as local:
            local.set(0.0)
        assemble_vector(vector, load)
        vector.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        set_bc(vector, self.bcs, alpha=0.0)
        self.units[j].copy(forcing)
        forcing.axpy(1.0, vector)
        return forcing

    def convecting(self, extrapolated):
        """The velocity that convects: u* on a fixed mesh, u* - w on a moving one (the non-conservative ALE form)."""
        return extrapolated if self.mesh_velocity is None else extrapolated - self.mesh_velocity

    # -- the rigid modes' vectors ----------------------------------------------------------------
    def _place_modes(self) -> None:
        """b_j and the unit forcings rho c_B b_j (boundary rows zeroed) at the sphere's present place."""
        where = (tuple(self.sphere.center.value), self.sphere.phi.x.array.sum())
        if where == self._modes_at:
            return
        for form, b, unit in zip(self._mode_forms, self.mode_vectors, self.units):
            with b.localForm() as local:
                local.set(0.0)
            assemble_vector(b, form)
            b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            b.copy(unit)
            unit.scale(self.density * self.penalty_rate)
            set_bc(unit, self.bcs, alpha=0.0)
        self._modes_at = where

    def mode_mass(self) -> np.ndarray:
        """G_ij = int phi m_i . m_j [m^3, m^4, m^5]: the phi-weighted volume and moments of the ball."""
        return np.array([[self.geometry.integrate(form) for form in row] for row in self._mode_mass_forms])

    def interiors(self, vector: PETSc.Vec) -> np.ndarray:
        """I_i(w) = int phi w . m_i of a mixed-space vector, one per mode."""
        return np.array([b.dot(vector) for b in self.mode_vectors])

    def _solve(self, operator, rhs: PETSc.Vec, responses: bool = True) -> RigidResponse:
        """x_0 = A^-1 rhs and (`responses`) x_j = A^-1 (rho c_B b_j) in one pass over the factors; the penalty's
        force (without the responses its slopes are NaN: only the held sphere's force, s = 0, is known)."""
        active = self.moving if responses else []
        solved = [self.responses[j] for j in active]
        operator.solve_many([rhs, *(self._forcing(j) for j in active)],
                            [self.x0.x.petsc_vec, *(x.x.petsc_vec for x in solved)])
        for x in (self.x0, *solved):
            x.x.scatter_forward()
        m = len(self.modes)
        slopes = np.full((m, m), np.nan)
        for j, x in zip(active, solved):
            slopes[:, j] = self.interiors(x.x.petsc_vec)
        return RigidResponse(names=self.geometry.mode_names, penalty=self.density * self.penalty_rate,
                             constant=self.interiors(self.x0.x.petsc_vec), slopes=slopes,
                             mode_mass=self.mode_mass(), ball_mass=self.ball_mass())

    def ball_mass(self) -> np.ndarray:
        """int_ball m_i . m_j over the sharp ball the penalty holds [m^3, m^5]: 4/3 pi a^3 for a translation,
        8/15 pi a^5 for a rotation about the centre, no coupling."""
        a = self.sphere.radius
        diagonal = [4.0 / 3.0 * np.pi * a**3 if name.startswith("U_") else 8.0 / 15.0 * np.pi * a**5
                    for name in self.geometry.mode_names]
        return np.diag(diagonal)

    # -- steady Stokes -------------------------------------------------------------------------
    def steady(self, load: ufl.Form | None = None) -> RigidResponse:
        """The steady penalised Stokes flow's response (one factorisation, prefix `{prefix}steady_`): afterwards
        `field(s)` is the flow with the sphere moving at amplitudes s.  `load`: a linear form in the test velocity
        `self.v` (a body force, e.g. geometry.source(f, flow.v)) [N/m^3 tested]."""
        start = time.perf_counter()
        a, L = fem.form(self.steady_form()), load
        A = assemble_matrix(a, bcs=self.bcs)
        A.assemble()
        assembled = time.perf_counter()
        operator = FactorizedOperator(A, f"{self.prefix}steady_")
        factorised = time.perf_counter()
        try:
            self._place_modes()
            response = self._solve(operator, lifted_rhs(self.rhs, None if L is None else fem.form(L), a, self.bcs))
            self.steady_costs = {"assembly_s": assembled - start, "factorise_s": factorised - assembled,
                                 "solve_s": time.perf_counter() - factorised, "back_solves": operator.back_solves,
                                 "factor_memory_bytes": operator.factor_memory()}
            return response
        finally:
            operator.destroy()
            A.destroy()

    # -- the BDF2 step -------------------------------------------------------------------------
    def set_time_step(self, dt: float, order: int = 2, ratio: float = 1.0) -> None:
        """The coming step's length dt [s], BDF2 (order 1 for a cold start from one level); `ratio`: dt over the
        step before (the variable-step BDF2, fem.taylor_hood.step_coefficients).  `bdf` keeps the coefficients."""
        bdf, ext = step_coefficients(order, ratio)
        bdf, ext = bdf + (0.0,) * (3 - len(bdf)), ext + (0.0,) * (2 - len(ext))
        self.bdf = bdf
        self.dt, self.c = dt, bdf[0] / dt
        self.rates.value[:] = [self.c, -bdf[1] / dt, -bdf[2] / dt]
        self.weights.value[:] = ext

    def step(self, responses: bool = True) -> RigidResponse:
        """Assemble and factorise the step's matrix (prefix `{prefix}step_`), solve for x_0 and (`responses`; not
        needed for a sphere held at rest, s = 0) each x_j.  With
        step_solver "reuse" the factors are kept while they precondition FGMRES well enough
        (`step_operator.iterations`; fem.solver.ReusedFactorOperator's renewal rule with `factorisation_cost`,
        and at once when FGMRES fails in 200 iterations)."""
        start = time.perf_counter()
        if self._step is None:
            a, L = self.step_forms()
            a, L = fem.form(a), fem.form(L)
            matrix = FormMatrix(a, self.bcs)
            assembled = time.perf_counter()
            if self.step_solver == "reuse":
                operator = ReusedFactorOperator(matrix.petsc, f"{self.prefix}reuse_", rtol=1e-10,
                                                factorisation_cost=self.factorisation_cost,
                                                max_iterations=10**6, limit=200,
                                                fixed_rows=owned_dirichlet_rows(self.bcs))
            else:
                operator = FactorizedOperator(matrix.petsc, f"{self.prefix}step_")
                self.factorisations += 1
            self._step = (matrix, operator, a, L)
            if self.carried is not None:
                self._carried = self._carried_forcing()
        else:
            matrix, operator, a, L = self._step
            matrix.assemble()
            assembled = time.perf_counter()
            if self.step_solver == "direct":
                operator.refactor()
                self.factorisations += 1
            elif operator.stale:
                operator.refactor()
        matrix, operator, a, L = self._step
        factorised = time.perf_counter()
        self._place_modes()
        response = self._solve(operator, self.step_rhs(), responses)
        if self.step_solver == "reuse":
            operator.end_step()
            self.factorisations = operator.factorisations
        self.assembly_s += assembled - start
        self.factorise_s += factorised - assembled
        self.solve_s += time.perf_counter() - factorised
        return response

    def step_rhs(self) -> PETSc.Vec:
        """The step's right-hand side without the penalty's pull, b(u^n, u^{n-1}) lifted by the boundary values
        (the flow's own vector, overwritten by the next solve); after the first `step`."""
        _, _, a, L = self._step
        return lifted_rhs(self.rhs, L, a, self.bcs)

    @property
    def step_operator(self):
        """The step's solver (fem.solver.FactorizedOperator or ReusedFactorOperator; None before the first step)."""
        return None if self._step is None else self._step[1]

    @property
    def step_matrix(self) -> PETSc.Mat | None:
        """The last step's assembled matrix (None before the first step)."""
        return None if self._step is None else self._step[0].petsc

    def field(self, amplitudes, out: PETSc.Vec | None = None) -> PETSc.Vec:
        """u(s) = x_0 + sum_j s_j x_j [a W-vector] of the last solve, for the rigid amplitudes s."""
        still = [name for k, name in enumerate(self.geometry.mode_names) if k not in self.moving and amplitudes[k]]
        if still:
            raise ValueError(f"the flow solves no response for the modes {still}: their amplitudes must be 0")
        out = self.x0.x.petsc_vec.duplicate() if out is None else out
        self.x0.x.petsc_vec.copy(out)
        for k in self.moving:
            s, x = amplitudes[k], self.responses[k]
            out.axpy(float(s), x.x.petsc_vec)
        return out

    def commit(self, amplitudes) -> None:
        """u^{n-1} <- u^n <- u(s) of the last step, for the amplitudes the body integrator chose."""
        now, before = self.states
        before.x.array[:] = now.x.array
        self.field(amplitudes, now.x.petsc_vec)
        now.x.scatter_forward()

    def set_state(self, vector: PETSc.Vec) -> None:
        """Every history level set to `vector` (a W-vector: a steady state to start from)."""
        for state in self.states:
            vector.copy(state.x.petsc_vec)
            state.x.scatter_forward()

    # -- checks --------------------------------------------------------------------------------
    def interior_slip(self, state: fem.Function, amplitudes, depth: float) -> float:
        """max |u - U_rigid| [m/s] over the velocity dofs within `depth` [m] of the sphere's centre (all ranks)."""
        center = self.sphere.center.value.copy()
        worst = 0.0
        for k in range(3):
            space, dofs = collapse(self.W.sub(0).sub(k))
            x = space.tabulate_dof_coordinates()
            inside = np.linalg.norm(x - center, axis=1) <= depth
            if inside.any():
                rigid = self.geometry.rigid_velocity_at(x[inside], amplitudes, center)[:, k]
                worst = max(worst, float(np.abs(state.x.array[dofs[inside]] - rigid).max()))
        return self.mesh.comm.allreduce(worst, op=MPI.MAX)

    @property
    def unknowns(self) -> int:
        return self.W.dofmap.index_map.size_global * self.W.dofmap.index_map_bs

    def destroy(self) -> None:
        if self._step is not None:
            matrix, operator, _, _ = self._step
            operator.destroy()
            matrix.destroy()
            self._step = None
        for vector in (*self.mode_vectors, *self.units, self.rhs, *(self._carried or ())[2:]):
            vector.destroy()
