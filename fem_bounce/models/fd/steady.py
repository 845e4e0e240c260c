"""The steady state of the fd time step for held spheres in Stokes flow, found without marching.

For held spheres (mode = "fixed") at Re -> 0 the time loop converges to a
fixed point of its own step map, but only after a viscous time (domain size)^2 / nu,
hundreds of thousands of steps at the time step the immersed forcing needs.  The
fixed point can be written down instead.  With S = A - rho c M the steady Stokes
operator (A the step's matrix, M the velocity mass, fem.geometry's weighted forms as in A), the step

    u~ = A^-1 (rho c M u),  f = rho c sum_i Phi_i (s_i e_z - u~),  u = u~ + A^-1 f

is at rest when S u = f, so the immersed force f solves

    J f = f + rho c Phi A^-1 rho c M S^-1 f = sum_j s_j rho c Phi_j e_z,

where Phi = sum_i Phi_i is the phi-weighted mass and s_j the amplitudes that give each interior its
sphere's mean velocity.  J is badly conditioned (rho c / (mu k^2) is large for the
smooth modes), so GMRES is right-preconditioned with the exact inverse of its
Brinkman-like part I + rho c Phi S^-1, namely S (S + rho c Phi)^-1: the
preconditioned operator is I - rho c Phi A^-1 S (S + rho c Phi)^-1, close to the
identity, and converges in a few dozen iterations.  J f_j = rho c Phi_j e_z is solved for each sphere
j, u_j = S^-1 f_j, and the amplitudes s = K^-1 (U_i V_i) with K_ij = I_i(u_j) give every interior its
sphere's mean velocity; the state is u = sum_j s_j u_j and each sphere's force the step's,
F_i = -rho c (s_i V_i - I_i(u~)).  This is the state marching would reach at the same dt, so it checks
the forcing the bouncing runs use (Brenner's wall drag; Stimson & Jeffery's and Cooley & O'Neill's
pair drags, benchmarks/pair_stokes.py) at the cost of three extra factorisations.  Convection is left
out.
"""
from __future__ import annotations

import functools
import operator

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem.petsc import assemble_matrix, set_bc
from petsc4py import PETSc

from ...fem.solver import FactorizedOperator, SolverError
from .coupling import InteriorIntegrals
from .immersed import indicator


class SteadyStokes:
    """The steady Stokes state of a FictitiousDomainModel's step for its held spheres (immersed.ImmersedSphere,
    sphere 1 first)."""

    def __init__(self, flow, spheres: list, prefix: str = "fd_steady_"):
        self.flow, self.spheres = flow, spheres
        (u, p), (v, q) = ufl.TrialFunctions(flow.W), ufl.TestFunctions(flow.W)
        rho_c, geometry = flow.density * flow.c, flow.geometry
        x = ufl.SpatialCoordinate(flow.mesh)
        phi = functools.reduce(operator.add, [indicator(x, held.center, held.band.radius, held.band.width)
                                              for held in self.spheres])
        dx_phi = ufl.Measure("dx", domain=flow.mesh, metadata={"quadrature_degree": 6})
        stokes = geometry.stokes_operator(u, p, v, q, 0.0, flow.viscosity)
        penalty = geometry.weighted(rho_c * phi * ufl.inner(u, v), dx_phi)
        self.matrices = {}
        # every vector these matrices meet is zero on the Dirichlet rows (_homogeneous): their diagonal there,
        # the weighted forms' as in the step's matrix, changes no solution
        for name, form, bcs in (("stokes", stokes, flow.bcs), ("brinkman", stokes + penalty, flow.bcs),
                                ("mass", rho_c * geometry.mass(u, v), []), ("phi", penalty, [])):
            matrix = assemble_matrix(fem.form(form), bcs=bcs, diag=geometry.dirichlet_diagonal)
            matrix.assemble()
            self.matrices[name] = matrix
        self.stokes = FactorizedOperator(self.matrices["stokes"], prefix + "stokes_")
        self.brinkman = FactorizedOperator(self.matrices["brinkman"], prefix + "brinkman_")
        self.vectors = [flow.rhs.duplicate() for _ in range(2)]
        self.iterations = 0

    def _homogeneous(self, vector: PETSc.Vec) -> PETSc.Vec:
        set_bc(vector, self.flow.bcs, alpha=0.0)
        return vector

    def operator(self, shell, f: PETSc.Vec, out: PETSc.Vec) -> None:
        """out = J f = f + rho c Phi A^-1 rho c M S^-1 f."""
        a, b = self.vectors
        self.stokes.solve(f, a)
        self.matrices["mass"].mult(a, b)
        self.flow.operator.solve(self._homogeneous(b), a)
        self.matrices["phi"].mult(a, out)
        self._homogeneous(out)
        out.axpy(1.0, f)

    def preconditioner(self, pc, y: PETSc.Vec, out: PETSc.Vec) -> None:
        """out = S (S + rho c Phi)^-1 y."""
        a = self.vectors[0]
        self.brinkman.solve(y, a)
        self.matrices["stokes"].mult(a, out)

    def _steady_force(self, rhs: PETSc.Vec, rtol: float) -> PETSc.Vec:
        """f with J f = rhs (a new vector), by right-preconditioned FGMRES."""
        flow = self.flow
        comm = flow.mesh.comm
        size = (flow.rhs.getLocalSize(), flow.rhs.getSize())
        shell = PETSc.Mat().createPython((size, size), comm=comm)
        shell.setPythonContext(_Apply(self.operator))
        shell.setUp()
        ksp = PETSc.KSP().create(comm)
        ksp.setOptionsPrefix("fd_steady_gmres_")
        ksp.setOperators(shell)
        ksp.setType("fgmres")
        ksp.setGMRESRestart(200)
        ksp.setPCSide(PETSc.PC.Side.RIGHT)
        pc = ksp.getPC()
        pc.setType("python")
        pc.setPythonContext(_Apply(self.preconditioner, "apply"))
        ksp.setTolerances(rtol=rtol, max_it=1000)
        ksp.setFromOptions()
        force = rhs.duplicate()
        try:
            ksp.solve(rhs, force)
            iterations = ksp.getIterationNumber()
            self.iterations += iterations
            reason = ksp.getConvergedReason()
        finally:
            ksp.destroy()
            shell.destroy()
        if reason < 0:
            force.destroy()
            raise SolverError(f"steady Stokes GMRES did not converge (reason {reason}, {iterations} iterations)")
        return force

    def solve(self, velocities, rtol: float = 1e-10) -> tuple[np.ndarray, InteriorIntegrals]:
        """Set the flow's states to the steady state of the held spheres whose surfaces move at `velocities`
        [m/s] (sphere 1 first); return (each sphere's force [N], the step's integrals)."""
        flow, spheres = self.flow, self.spheres
        self.iterations = 0
        velocities = np.asarray(velocities, dtype=float)
        volumes = np.array([held.volume for held in spheres])
        states = []  # u_j = S^-1 f_j for a unit amplitude at sphere j
        for held in spheres:
            unit_force = held.unit_forcing().copy()
            force = self._steady_force(unit_force, rtol)
            state = flow.rhs.duplicate()
            self.stokes.solve(force, state)
            flow.operator.solve(unit_force, held.unit.x.petsc_vec)  # y1_j, for the added mass
            states.append(state)
            force.destroy()
            unit_force.destroy()
        interiors = np.array([[held.interior(state) for state in states] for held in spheres])  # K_ij
        amplitudes = np.linalg.solve(interiors, velocities * volumes)
        u, predicted = flow.now, flow.predicted
        u.x.petsc_vec.set(0.0)
        for s, state in zip(amplitudes, states):
            u.x.petsc_vec.axpy(float(s), state)
            state.destroy()
        u.x.scatter_forward()
        self.matrices["mass"].mult(u.x.petsc_vec, self.vectors[1])
        flow.operator.solve(self._homogeneous(self.vectors[1]), predicted.x.petsc_vec)
        predicted.x.scatter_forward()
        for state in flow.states[1:]:
            state.x.array[:] = u.x.array
        unit = np.array([[held.interior(other.unit.x.petsc_vec) for other in spheres] for held in spheres])
        inside = np.array([held.interior(predicted.x.petsc_vec) for held in spheres])
        integrals = InteriorIntegrals(volume=volumes, predicted=inside,
                                  forced=velocities * volumes - inside - unit @ amplitudes, unit=unit)
        forces = -flow.density * flow.c * (amplitudes * volumes - inside)
        return forces, integrals

    def destroy(self) -> None:
        self.stokes.destroy()
        self.brinkman.destroy()
        for matrix in self.matrices.values():
            matrix.destroy()
        for vector in self.vectors:
            vector.destroy()


class _Apply:
    """A petsc4py Python context calling fn(obj, x, y) as `mult` (matrix) or `apply` (preconditioner)."""

    def __init__(self, fn, method: str = "mult"):
        setattr(self, method, fn)
