"""Axisymmetric incompressible flow around a boundary-fitted sphere on a moving mesh (ALE), BDF in time.

On the mesh of the new time level, with nodal (mesh-following) histories u^n, u^{n-1}:

    rho (sum_j alpha_j u^{n+1-j}) / dt + rho ((u* - w) . grad) u^{n+1} - mu Lap u^{n+1} + grad p^{n+1} = 0,
    div u^{n+1} = 0,     u* = 2 u^n - u^{n-1} (extrapolated),   w the mesh velocity (fem.mesh_motion),

the non-conservative ALE form (Formaggia & Nobile 2004, in "Finite Element Methods:
1970's and Beyond"; Foerster, Wall & Ramm 2007 CMAME 196): the time derivative is
taken along mesh trajectories (the same dof at its old positions) and every integral
on the current mesh, so a uniform flow is an exact discrete solution however the mesh
moves.  Convection is linearised about the extrapolated velocity and kept implicit, so the
step has no convective stability limit.  BDF2 and EXT2 follow Karniadakis, Israeli & Orszag (1991),
as in the fd model.  Gravity is not in the fluid.

The matrix changes every step (the convecting velocity u* - w, and the mesh moves), so it is
assembled every step; numerics.ale.factorisation says how it is solved:

- "every-step": factorised every step (MUMPS), two back-solves.
- "reuse" (the default): flexible GMRES preconditioned by the LU factors of an earlier step's matrix
  (fem.solver.ReusedFactorOperator), to |b - A x| <= krylov_rtol |b|, factorised again when that
  pays (a renewal rule counting GMRES iterations against factorisation_cost) and on every new mesh.
  The unit responses start from the last step's, U_ref's solve from u* moved to U_ref by them, so
  a step takes a few iterations.  The scheme is the same: the two paths differ by the Krylov
  tolerance (docs/performance.md).  (Extrapolating convection instead, so that the matrix changes
  only with the mesh, bought no fewer iterations on case 3 and needed a Courant limit: a held
  sphere's surface moves through the finest cells, and a stream at Re 100 oscillated at cell Courant
  numbers 0.75-1.5.)

Every number that varies between runs or meshes (rho, mu, dt) enters the forms as a dolfinx
Constant, so the compiled forms are the same for every scene and mesh of one time order (compiled
once per machine, in the form cache).

The sphere surface is a no-slip boundary moving with the sphere, u = (0, U).  The flow
is affine in U, so one factorisation and two back-solves give it for every U:
x(U) = x_ref + (U - U_ref) x_unit, x_ref for the reference velocity U_ref and x_unit the
response to U = 1 with everything else zero.  With N spheres on the axis (holes tagged SPHERE,
SPHERE_2, ...) there is one unit response per sphere: x(U) = x_ref + sum_k (U_k - U_ref,k) x_unit,k,
N + 1 back-solves with one factorisation.

The force on the sphere is the consistent variational (reaction) force: with phi the
finite-element function equal to e_z on the sphere and 0 at every other node,

    F_z = -R(x; phi),   R(x; v) = a(x, v) - L(v)  the step's residual,

which is the surface integral of the traction for the exact solution (Green's formula)
and converges faster than the integrated discrete stress (Babuska & Miller 1984,
CMAME 45; Brummelen et al. 2012).  R is affine in x, so F(U) = F(U_ref) + (U - U_ref) dF/dU
with dF/dU = -a(x_unit, phi); phi_i is e_z on sphere i only, F_i = -R(x; phi_i) and
dF_i/dU_j = -a(x_unit,j, phi_i), an N x N matrix (every form is fem.geometry's, weighted to the physical
volume: no factor here).  The stress integral over the surface is kept as a diagnostic.

Per-sphere quantities (velocities, forces) are arrays over the spheres, sphere 1 (the lowest) first,
as in the FlowModel interface (kinematics.Prediction).

Boundaries are named by the mesh's facet tags: "no-slip", "slip", "inflow" (u = (0, U_in)),
"outflow" (do nothing); the axis has u_r = 0.  When every side fixes the normal velocity
the pressure is pinned at the far corner.  SI units throughout.
"""
from __future__ import annotations

import time

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import apply_lifting, assemble_matrix, assemble_vector, create_vector, set_bc
from petsc4py import PETSc

from ...fem.compat import collapse
from ...fem.geometry import Axisymmetric
from ...fem.matrix import FormMatrix
from ...fem.mesh import AXIS, SPHERE
from ...fem.solver import FactorizedOperator, ReusedFactorOperator
from ...fem.taylor_hood import (SIDE_KINDS, lifted_rhs, owned_dirichlet_rows, pressure_pin, set_velocity,
                                side_constraints, step_coefficients, taylor_hood_space)

FACTORISATIONS = ("reuse", "every-step")  # numerics.ale.factorisation


class SphereFlow:
    """The flow around the sphere (or the spheres whose surfaces carry `sphere_tags`, lowest first) on
    one mesh (moved in place by a MeshMotion).

    density [kg/m3], viscosity [Pa s], dt [s]; `sides` maps WALL/OUTER/TOP to a kind in
    SIDE_KINDS; `mesh_velocity` is a UFL vector (fem.mesh_motion.MeshMotion.velocity); `factorisation` is
    "every-step" or "reuse" (then `krylov_rtol`, `factorisation_cost` and `reuse_iterations` set
    ReusedFactorOperator's tolerance, renewal rule and bound)."""

    def __init__(self, mesh, facet_tags, sides: dict[int, str], density: float, viscosity: float, dt: float,
                 mesh_velocity, inflow_speed: float = 0.0, order: int = 2, prefix: str = "ale_flow_",
                 sphere_tags: tuple[int, ...] = (SPHERE,), factorisation: str = "every-step",
                 reuse_iterations: int = 30, krylov_rtol: float = 1e-7, factorisation_cost: float = 20.0):
        for kind in sides.values():
            if kind not in SIDE_KINDS:
                raise ValueError(f"boundary kind {kind!r} is not one of {SIDE_KINDS}")
        if factorisation not in FACTORISATIONS:
            raise ValueError(f"numerics.ale.factorisation = {factorisation!r} is not one of {FACTORISATIONS}")
        self.factorisation, self.reuse_iterations, self.krylov_rtol = factorisation, reuse_iterations, krylov_rtol
        self.factorisation_cost = factorisation_cost
        # [s] this flow's matrix assembly, factorisations, solves
        self.assembly_s = self.factorise_s = self.solve_s = 0.0
        self._direct_factorisations = 0
        self.mesh, self.density, self.viscosity = mesh, density, viscosity
        self.order = order
        self.prefix = prefix
        self.inflow_speed = inflow_speed
        self.sphere_tags = tuple(sphere_tags)
        self.W = taylor_hood_space(mesh)
        self.states = [fem.Function(self.W) for _ in range(order)]  # u^n, u^{n-1} (nodal, with p)
        self.now = self.states[0]
        self.solution = fem.Function(self.W)  # x_ref, then the step's field
        self.units = [fem.Function(self.W) for _ in self.sphere_tags]  # x_unit,k
        self.phis = [fem.Function(self.W) for _ in self.sphere_tags]  # e_z on sphere k, 0 elsewhere
        self._boundary_conditions(facet_tags, sides)

        self.geometry = geometry = Axisymmetric(mesh)
        ds = ufl.Measure("ds", domain=mesh, subdomain_data=facet_tags)
        (u, p), (v, q) = ufl.TrialFunctions(self.W), ufl.TestFunctions(self.W)
        # the numbers of a scene and of the step as Constants, not literals: one compiled form for every
        # scene, mesh and step length.  One vector Constant holds them all, [rho, mu, 1/dt, alpha_0..,
        # beta_0..] (the step's BDF rates alpha_j / dt and extrapolation weights beta_j): UFL orders the
        # terms of a sum by comparing distinct Constants by their repr, which holds a global count, so
        # separate Constants made the form's signature (and a recompilation) depend on how many Constants
        # the process had made before (count 99 sorts after 100).
        self.numbers = fem.Constant(mesh, np.zeros(3 + 2 * order + 1, dtype=PETSc.ScalarType))
        numbers = self.numbers
        rho, mu, inverse_dt = numbers[0], numbers[1], numbers[2]
        bdf = [numbers[3 + j] for j in range(order + 1)]
        ext = [numbers[4 + order + j] for j in range(order)]
        numbers.value[:2] = density, viscosity
        self.rho, self.mu = rho, mu
        self.set_time_step(dt)
        past = [ufl.split(state)[0] for state in self.states]
        extrapolated = sum(beta * u_j for beta, u_j in zip(ext, past))
        history = -rho * inverse_dt * sum(alpha * u_j for alpha, u_j in zip(bdf[1:], past))
        a = (geometry.stokes_operator(u, p, v, q, rho * bdf[0] * inverse_dt, mu)
             + rho * geometry.convection(extrapolated - mesh_velocity, u, v))
        L = geometry.source(history, v)
        self.a, self.L = fem.form(a), fem.form(L)
        self.force_forms = [fem.form(-(ufl.action(ufl.action(a, self.solution), phi) - ufl.action(L, phi)))
                            for phi in self.phis]
        self.force_slope_forms = [[fem.form(-ufl.action(ufl.action(a, unit), phi)) for unit in self.units]
                                  for phi in self.phis]
        self.surface_force_forms = [fem.form(surface_force(geometry, self.solution, self.mu, ds(tag)))
                                    for tag in self.sphere_tags]

        # the fixed rows scaled with the weighted forms, so that "reuse"'s GMRES weighs them against the others
        # as with the plain forms (Geometry.dirichlet_diagonal)
        self.assembler = FormMatrix(self.a, self.bcs, geometry.dirichlet_diagonal)
        self.matrix = self.assembler.petsc
        self.operator: FactorizedOperator | ReusedFactorOperator | None = None
        self.rhs = create_vector(self.W)

    def set_time_step(self, dt: float, previous: float | None = None, order: int | None = None) -> None:
        """The coming step's length dt [s] and the one before it (default dt): the BDF and extrapolation
        coefficients of the step (fem.taylor_hood.step_coefficients; variable-step BDF2 when they differ), of a
        lower `order` than the flow's for a cold start (the older level then weighs 0)."""
        self.dt = dt
        order = order or self.order
        bdf, ext = step_coefficients(order, dt / (previous or dt))
        padding = (0.0,) * (self.order - order)
        self.bdf, self.ext = bdf + padding, ext + padding
        self.c = self.bdf[0] / dt  # du/dt ~ c (u^{n+1} - reference)
        self.numbers.value[2:] = [1.0 / dt, *self.bdf, *self.ext]

    # -- boundary conditions ---------------------------------------------------------------
    def _boundary_conditions(self, facet_tags, sides) -> None:
        W, fdim = self.W, self.mesh.topology.dim - 1
        self.bcs = []
        self.values = {}  # name -> the Function holding a boundary value

        def component_bc(component: int, facets, name: str | None = None):
            sub = W.sub(0).sub(component)
            space, _ = collapse(sub)
            g = fem.Function(space)
            if name is not None:
                self.values[name] = g
            dofs = fem.locate_dofs_topological((sub, space), fdim, facets)
            self.bcs.append(fem.dirichletbc(g, dofs, sub))
            return dofs

        component_bc(0, facet_tags.find(AXIS))
        sphere_dofs = []
        for k, tag in enumerate(self.sphere_tags):
            sphere = facet_tags.find(tag)
            component_bc(0, sphere)
            sphere_dofs.append(component_bc(1, sphere, f"sphere {k}"))
        fixed, pinned = side_constraints(facet_tags, sides)
        for component, facets, inflow in fixed:
            component_bc(component, facets, "inflow" if inflow else None)
        if pinned:
            self.bcs.append(pressure_pin(W, self.mesh))
        self.pressure_pinned = pinned
        # phi_k = e_z on sphere k: a Dirichlet condition of value 1 set into a zero vector
        sub = W.sub(0).sub(1)
        space, _ = collapse(sub)
        one = fem.Function(space)
        one.x.array[:] = 1.0
        for phi, dofs in zip(self.phis, sphere_dofs):
            set_bc(phi.x.petsc_vec, [fem.dirichletbc(one, dofs, sub)])
            phi.x.scatter_forward()

    def per_sphere(self, values) -> np.ndarray:
        """The spheres' values as an array, checked to hold one per sphere (a number: one sphere's)."""
        values = np.atleast_1d(np.asarray(values, dtype=float))
        if values.shape != (len(self.sphere_tags),):
            raise ValueError(f"expected one value per sphere ({len(self.sphere_tags)}), got {values.shape}")
        return values

    def set_boundary_values(self, sphere_velocity, inflow: float | None = None) -> None:
        """u_z = sphere_velocity on each sphere [m/s]; u_z on the inflow side (default: the scene's)."""
        for k, velocity in enumerate(self.per_sphere(sphere_velocity)):
            self.values[f"sphere {k}"].x.array[:] = velocity
        if "inflow" in self.values:
            self.values["inflow"].x.array[:] = self.inflow_speed if inflow is None else inflow

    # -- the state ---------------------------------------------------------------------------
    def set_uniform(self, velocity: tuple[float, float]) -> None:
        """Every history level = the uniform velocity, zero pressure (a start from rest or a uniform stream)."""
        for state in self.states:
            set_velocity(state, velocity)

    def commit(self, velocity_change) -> None:
        """The step's field x_ref + sum_k velocity_change_k x_unit,k becomes u^n; the history shifts."""
        for change, unit in zip(self.per_sphere(velocity_change), self.units):
            self.solution.x.petsc_vec.axpy(change, unit.x.petsc_vec)
        self.solution.x.scatter_forward()
        for older, newer in zip(self.states[::-1], self.states[-2::-1]):
            older.x.array[:] = newer.x.array
        self.now.x.array[:] = self.solution.x.array

    # -- one step ------------------------------------------------------------------------------
    def factorise(self) -> None:
        """Assemble the step's matrix on the mesh as it is now and factorise it ("every-step": every step;
        "reuse": on a new mesh, and when the renewal rule says so)."""
        start = time.perf_counter()
        A = self.assembler.assemble()
        assembled = time.perf_counter()
        self.assembly_s += assembled - start
        if self.operator is None:
            if self.factorisation == "reuse":
                self.operator = ReusedFactorOperator(A, self.prefix + "reuse_", rtol=self.krylov_rtol,
                                                     factorisation_cost=self.factorisation_cost,
                                                     max_iterations=self.reuse_iterations,
                                                     fixed_rows=owned_dirichlet_rows(self.bcs))
            else:
                self.operator = FactorizedOperator(A, self.prefix)
                self._direct_factorisations += 1
        elif self.factorisation == "every-step":
            self.operator.refactor()
            self._direct_factorisations += 1
        elif self.operator.stale:
            self.operator.refactor()
        self.factorise_s += time.perf_counter() - assembled

    def renew(self) -> None:
        """Factorise at the next step (at a checkpoint: a restart, which has no factors, then repeats the
        run's digits)."""
        if isinstance(self.operator, ReusedFactorOperator):
            self.operator.stale = True

    @property
    def factorisations(self) -> int:
        """Numerical factorisations of the step matrix on this mesh so far."""
        if isinstance(self.operator, ReusedFactorOperator):
            return self.operator.factorisations
        return self._direct_factorisations

    @property
    def krylov_iterations(self) -> int:
        """GMRES iterations on this mesh so far ("reuse"; 0 for "every-step")."""
        return getattr(self.operator, "iterations", 0)

    def _solve(self, with_history: bool, out: fem.Function) -> None:
        b = lifted_rhs(self.rhs, self.L if with_history else None, self.a, self.bcs, self.geometry.dirichlet_diagonal)
        start = time.perf_counter()
        self.operator.solve(b, out.x.petsc_vec)  # "reuse": out holds the initial guess
        self.solve_s += time.perf_counter() - start
        out.x.scatter_forward()

    def step(self, reference_velocity, extrapolated_velocity=None):
        """Factorise (if due), solve for the unit response of each sphere and for U_ref; return
        (F(U_ref) [N], dF/dU [N s/m]): the forces F_i and the N x N matrix dF_i/dU_j.
        Under "reuse" the Krylov solves start from the last step's unit responses and, for U_ref, from
        the extrapolated field u* moved to the surface velocity U_ref by those responses: u* + sum_k
        (U_ref,k - U*_k) x_unit,k, with U* = `extrapolated_velocity` the spheres' extrapolated velocities
        (the surface values of u*) [m/s]."""
        self.factorise()
        reused = isinstance(self.operator, ReusedFactorOperator)
        for k, unit in enumerate(self.units):
            self.set_boundary_values(np.eye(len(self.units))[k], inflow=0.0)
            self._solve(False, unit)
        self.set_boundary_values(reference_velocity)
        if reused:
            guess = self.solution.x.array
            guess[:] = sum(beta * state.x.array for beta, state in zip(self.ext, self.states))
            if extrapolated_velocity is not None:
                shifts = self.per_sphere(reference_velocity) - self.per_sphere(extrapolated_velocity)
                for shift, unit in zip(shifts, self.units):
                    guess += shift * unit.x.array
        self._solve(True, self.solution)
        if reused:
            self.operator.end_step()
        integrate = self.geometry.integrate
        forces = np.array([integrate(form) for form in self.force_forms])
        slopes = np.array([[integrate(form) for form in row] for row in self.force_slope_forms])
        return forces, slopes

    def surface_force(self):
        """The traction integrated over each sphere, of the last committed field [N] (a diagnostic)."""
        return np.array([self.geometry.integrate(form) for form in self.surface_force_forms])

    def momentum(self, state: fem.Function) -> float:
        """The fluid's axial momentum rho int u_z dV of a (u, p) function on this mesh [kg m/s]."""
        return self.geometry.integrate(self.geometry.weighted(self.rho * ufl.split(state)[0][1]))

    def fluid_volume(self) -> float:
        """int dV: the volume of liquid the mesh holds [m^3]."""
        return self.geometry.integrate(self.geometry.weighted(1.0))

    # -- steady states (a held sphere) -----------------------------------------------------------
    def steady(self, sphere_velocity, convection: bool, rtol: float = 1e-10, max_iterations: int = 30, log=None):
        """Solve the steady Stokes (or Navier-Stokes, by Newton from the Stokes state) problem with the
        spheres' surfaces at sphere_velocity [m/s]; set every history level to it; return the force on
        each sphere [N]."""
        rho, mu, geometry = self.rho, self.mu, self.geometry
        diagonal = geometry.dirichlet_diagonal
        (u_trial, p_trial), (v, q) = ufl.TrialFunctions(self.W), ufl.TestFunctions(self.W)
        x = self.solution
        u, p = ufl.split(x)
        stokes = geometry.stokes_operator(u_trial, p_trial, v, q, 0.0, mu)
        residual = ufl.action(stokes, x)
        if convection:
            residual = residual + rho * geometry.convection(u, u, v)
        jacobian = ufl.derivative(residual, x)
        force_forms = [fem.form(-ufl.action(residual, phi)) for phi in self.phis]
        self.set_boundary_values(sphere_velocity)
        J, F = fem.form(jacobian), fem.form(residual)
        A = assemble_matrix(J, bcs=self.bcs, diag=diagonal)
        A.assemble()
        solver = FactorizedOperator(A, self.prefix + "steady_")
        correction = fem.Function(self.W)
        b = create_vector(self.W)
        x.x.array[:] = 0.0
        try:
            for iteration in range(max_iterations if convection else 1):
                if iteration > 0:
                    A.zeroEntries()
                    assemble_matrix(A, J, bcs=self.bcs, diag=diagonal)
                    A.assemble()
                    solver.refactor()
                # Newton: J dx = -F(x), with dx = g - x on Dirichlet rows so x + dx meets the conditions
                with b.localForm() as local:
                    local.set(0.0)
                assemble_vector(b, F)
                apply_lifting(b, [J], [self.bcs], x0=[x.x.petsc_vec], alpha=-1.0)
                b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
                b.scale(-1.0)
                set_bc(b, self.bcs, x.x.petsc_vec, diagonal)
                solver.solve(b, correction.x.petsc_vec)
                correction.x.scatter_forward()
                x.x.array[:] += correction.x.array
                size = correction.x.petsc_vec.norm() / max(x.x.petsc_vec.norm(), 1e-300)
                if log is not None:
                    log(f"steady iteration {iteration}: |dx|/|x| = {size:.2e}")
                if size < rtol:
                    break
            else:
                if convection:
                    raise RuntimeError(f"steady Navier-Stokes: Newton did not converge in {max_iterations} iterations")
        finally:
            solver.destroy()
            A.destroy()
            b.destroy()
        for state in self.states:
            state.x.array[:] = x.x.array
        for unit in self.units:
            unit.x.array[:] = 0.0
        return np.array([geometry.integrate(form) for form in force_forms])

    @property
    def unknowns(self) -> int:
        return self.W.dofmap.index_map.size_global * self.W.dofmap.index_map_bs

    def destroy(self) -> None:
        if self.operator is not None:
            self.operator.destroy()
        self.assembler.destroy()
        self.rhs.destroy()


def surface_force(geometry, state: fem.Function, viscosity, ds_sphere):
    """-int_S (sigma n)_z dS, n the fluid's outward normal: the z-force on the sphere (a UFL form, weighted by
    the geometry to the whole surface of revolution); viscosity [Pa s] a float or a Constant.

    sigma = -p I + mu (grad u + grad u^T); only its (r, z) block enters the axial force (Axisymmetric.stress)."""
    u, p = ufl.split(state)
    traction = geometry.traction(u, p, viscosity, ufl.FacetNormal(geometry.mesh))
    return -geometry.weighted(traction[1], ds_sphere)
