"""The rigid-body constraint solved for its force density: the implicit Brinkman penalty.

The default forcing (immersed.ImmersedSphere's responses, numerics.fd.constraint =
"penalty") is one shot of rho c phi (U - u~) with c = 3 / (2 dt) from the predictor: its
strength falls with dt, so the interior is rigid only while dt <= 0.025 h^2 / nu.  Here the
force density lambda [N/m^3] acts on the new velocity instead,

    A u + Phi lambda = b,        Phi^T (u - U e_z - eps lambda) = 0,

with A the step's factorised Taylor-Hood matrix and Phi the phi-weighted velocity mass
(int phi lambda . v r dx) on the dofs whose support meets the sphere.  eps = 1 / (rho c_B) makes
lambda = rho c_B (u - U e_z): the volume penalisation of Angot, Bruneau & Fabrie (1999, Numer.
Math. 81, 497) in the phi-weighted form, with c_B set by the mesh and the flow's rates
(domain.brinkman_rate), not by dt.  eps -> 0 is the exact constraint, the distributed Lagrange
multiplier of Glowinski et al. (2001, J. Comput. Phys. 169, 363).  With the predictor
u~ = A^-1 b, u = u~ - A^-1 Phi lambda and

    T lambda = u~ - U e_z,      T = eps I + A^-1 Phi,

solved by conjugate gradients in the Phi inner product, where T is self-adjoint and positive
(A^-1's velocity block is; Dirichlet rows are dropped).  Each iteration is one back-solve with
the factors the time loop already holds, so nothing is refactorised however the sphere moves.
The spectrum of T lies in [eps, eps + 1 / (rho c)] (c = 3 / (2 dt)), so CG converges in a few
iterations whatever the band.  (The exact multiplier, eps = 0, was tried first, solved by CG in the
Euclidean inner product: the near-null modes of A^-1 Phi, pressure gradients and the band's weak
edge, took it hundreds of iterations from rest; docs/performance.md section 1.)

The sphere's force is affine in U, lambda(U) = lambda(U_e) + (U - U_e) lambda_1 with
T lambda_1 = -e_z, so the implicit coupling (coupling.py) keeps working: the step solves for
lambda at the extrapolated velocity U_e (warm-started from the last step) and corrects it with
lambda_1, which changes only with the sphere's position: it is converged once, then improved by
a few CG iterations a step (`unit_steps`) so that it follows the sphere.

Everything here is SI; `immersed.BandAssembler.forcing` applies Phi (it is symmetric).
"""
from __future__ import annotations

import numpy as np
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from ...fem.compat import collapse


class ConstraintError(ArithmeticError):
    """Conjugate gradients broke down or did not reach the tolerance."""


class RigidConstraint:
    """The Brinkman force density lambda = rho c_B (u - U e_z) of one sphere (immersed.ImmersedSphere) in its
    flow (fluid.FlowSolver); regularisation: eps = 1 / (rho c_B) [m^3 s/kg].

    tolerance: CG stops when lambda is that accurate (relative; see _conjugate_gradients); unit_steps: CG
    iterations a step that improve lambda_1."""

    def __init__(self, flow, sphere, regularisation: float, tolerance: float = 1e-2, unit_steps: int = 2,
                 max_iterations: int = 200):
        if not regularisation > 0.0:
            raise ValueError(f"the Brinkman constraint needs eps = 1 / (rho c_B) > 0, not {regularisation}")
        self.flow, self.sphere = flow, sphere
        self.tolerance, self.unit_steps = tolerance, unit_steps
        self.max_iterations, self.regularisation = max_iterations, regularisation
        W = flow.W
        self.density = fem.Function(W)  # lambda at the last solve (warm start)
        self.response = fem.Function(W)  # A^-1 Phi lambda
        self.unit = fem.Function(W)  # lambda_1 = dlambda/dU
        self.unit_response = fem.Function(W)  # A^-1 Phi lambda_1
        self._direction = fem.Function(W)
        self._direction_response = fem.Function(W)
        self._slip = fem.Function(W)  # the CG's residual s, a velocity field
        self._residual = flow.rhs.duplicate()  # Phi s
        self._phi_p = flow.rhs.duplicate()
        self._phi_x = flow.rhs.duplicate()
        self._image = flow.rhs.duplicate()
        self.phi_lambda = flow.rhs.duplicate()  # Phi lambda and Phi lambda_1, for the time loop's first pass
        self.phi_unit = flow.rhs.duplicate()
        _, self._uz_dofs = collapse(W.sub(0).sub(1))
        # 1 on the velocity dofs without a Dirichlet condition, 0 elsewhere (pressure, boundary values)
        active = fem.Function(W)
        active.x.array[collapse(W.sub(0))[1]] = 1.0
        self.flow.force_rhs(active.x.petsc_vec)  # (ghosts are summed into owners: only != 0 counts)
        active.x.scatter_forward()
        self._active = (active.x.array != 0.0).astype(float)
        self._has_unit = False
        self.iterations = 0  # CG iterations (= back-solves) so far
        self.unit_iterations = 0  # of which for lambda_1
        self.unconverged = 0  # solves of lambda that stopped at max_iterations

    # -- Phi and the CG --------------------------------------------------------------------------
    def apply_phi(self, function: fem.Function, out: PETSc.Vec) -> PETSc.Vec:
        """out = Phi x (x: a W-function with ghosts up to date), ghosts accumulated, Dirichlet rows 0."""
        with out.localForm() as local:
            local.set(0.0)
            self.sphere.band.forcing(local.array, function.x.array, 1.0)
        return self.flow.force_rhs(out)

    def _conjugate_gradients(self, predicted: fem.Function | None, velocity: float, x: fem.Function,
                             response: fem.Function, limit: int) -> tuple[int, bool]:
        """Solve T x = u~ - U e_z, T = eps I + A^-1 Phi, by conjugate gradients in the Phi inner product
        (T is self-adjoint there: Phi T = eps Phi + Phi A^-1 Phi), from the guess x whose response
        A^-1 Phi x is given; both are updated.  Working with the velocity residual s = u - U e_z - eps x
        (the slip the constraint leaves, less the penalty's own) rather than Phi s keeps Phi's bad scaling
        (its rows for the dofs at the band's edge are tiny) out of the iteration: the condition number
        is about 1 + c_B / c whatever the band.  Stops when |s|_Phi <= tolerance |eps x|_Phi (x to that
        relative accuracy: the penalty's own slip eps x sets the force) or after `limit` iterations.
        Returns (iterations, converged)."""
        s, eps = self._slip, self.regularisation
        s.x.array[:] = 0.0 if predicted is None else predicted.x.array
        s.x.array[self._uz_dofs] -= velocity
        s.x.array[:] -= response.x.array + eps * x.x.array
        s.x.array[:] *= self._active
        r = self.apply_phi(s, self._residual)
        rr = s.x.petsc_vec.dot(r)
        phi_x = self.apply_phi(x, self._phi_x)  # kept up to date below, for the stopping bound
        if rr <= self._goal(x, phi_x):
            return 0, True
        p, z = self._direction, self._direction_response
        p.x.array[:] = s.x.array
        for iteration in range(1, limit + 1):
            phi_p = self.apply_phi(p, self._phi_p)
            self.flow.solve([phi_p], [z])
            q = self.apply_phi(z, self._image)
            q.axpy(eps, phi_p)  # Phi T p
            curvature = p.x.petsc_vec.dot(q)
            if not curvature > 0.0:
                raise ConstraintError(f"the rigid-body constraint's CG broke down (p.Phi T p = {curvature:g})")
            alpha = rr / curvature
            x.x.array[:] += alpha * p.x.array
            phi_x.axpy(alpha, phi_p)
            response.x.array[:] += alpha * z.x.array
            s.x.array[:] -= alpha * (eps * p.x.array + z.x.array * self._active)
            r.axpy(-alpha, q)
            rr_new = s.x.petsc_vec.dot(r)
            if rr_new <= self._goal(x, phi_x):
                return iteration, True
            beta, rr = rr_new / rr, rr_new
            p.x.array[:] = s.x.array + beta * p.x.array
        return limit, False

    def _goal(self, x: fem.Function, phi_x: PETSc.Vec) -> float:
        """The CG's stopping bound on |s|_Phi^2, (tolerance |eps x|_Phi)^2 (phi_x = Phi x)."""
        return (self.tolerance * self.regularisation) ** 2 * x.x.petsc_vec.dot(phi_x)

    # -- a step ------------------------------------------------------------------------------
    def first_pass(self) -> tuple[list, list]:
        """The right-hand sides Phi lambda (and Phi lambda_1) at the present position and the functions
        their responses go to: the time loop solves them in one pass over the factors with its predictor."""
        vectors, functions = [self.apply_phi(self.density, self.phi_lambda)], [self.response]
        if self._has_unit:
            vectors.append(self.apply_phi(self.unit, self.phi_unit))
            functions.append(self.unit_response)
        return vectors, functions

    def solve(self, predicted: fem.Function, velocity: float, responses_ready: bool = False) -> None:
        """lambda for the sphere velocity U [m/s] given the predictor u~, and lambda_1 improved.

        Both are warm-started from the last step; their responses A^-1 Phi x at the present position must
        be in `response`, `unit_response` when responses_ready (solved beside the predictor, `first_pass`)."""
        if not responses_ready:
            vectors, functions = self.first_pass()
            self.flow.solve(vectors, functions)
        iterations, converged = self._conjugate_gradients(predicted, velocity, self.density, self.response,
                                                          self.max_iterations)
        self.iterations += iterations
        self.unconverged += not converged
        limit = self.unit_steps if self._has_unit else self.max_iterations
        iterations, _ = self._conjugate_gradients(None, 1.0, self.unit, self.unit_response, limit)  # T x = -e_z
        self._has_unit = True
        self.iterations += iterations
        self.unit_iterations += iterations

    def hold_force(self) -> float:
        """The z-force 2 pi int phi lambda_z r dx [N] (lambda pushes the fluid by minus this)."""
        return self.sphere.interior(self.density.x.petsc_vec)

    def unit_force(self) -> float:
        """d(hold_force)/dU [N s/m]."""
        return self.sphere.interior(self.unit.x.petsc_vec)

    def field(self, predicted: fem.Function, shift: float, out: PETSc.Vec) -> PETSc.Vec:
        """u = u~ - A^-1 Phi (lambda + shift lambda_1) as a W-vector; lambda moves to lambda + shift lambda_1."""
        predicted.x.petsc_vec.copy(out)
        out.axpy(-1.0, self.response.x.petsc_vec)
        out.axpy(-shift, self.unit_response.x.petsc_vec)
        if shift:
            self.density.x.array[:] += shift * self.unit.x.array
            self.response.x.array[:] += shift * self.unit_response.x.array
        return out

    def interior_slip(self, velocity_field: fem.Function, velocity: float, depth: float) -> float:
        """max |u - U e_z| [m/s] over the velocity dofs at distance <= depth from the centre (all ranks)."""
        W = self.flow.W
        worst = 0.0
        for component, target in ((0, 0.0), (1, velocity)):
            space, dofs = collapse(W.sub(0).sub(component))
            x = space.tabulate_dof_coordinates()
            inside = np.hypot(x[:, 0], x[:, 1] - self.sphere.center) <= depth
            if inside.any():
                worst = max(worst, float(np.abs(velocity_field.x.array[dofs[inside]] - target).max()))
        return self.flow.mesh.comm.allreduce(worst, op=MPI.MAX)

    def destroy(self) -> None:
        for vector in (self._residual, self._phi_p, self._phi_x, self._image, self.phi_lambda, self.phi_unit):
            vector.destroy()
