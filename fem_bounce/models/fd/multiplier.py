"""The rigid-body constraint as a distributed Lagrange multiplier, solved on its Schur complement.

The old forcing (immersed.ImmersedSphere's responses, numerics.fd.constraint =
"penalty") acts like a Brinkman friction rho c phi (U - u) with c = 3 / (2 dt): its
strength falls with dt, so the interior is rigid only while dt <= 0.025 h^2 / nu.
Here the interior is made rigid by a constraint instead (Glowinski et al. 1999,
J. Comput. Phys. 169, 363; the phi-weighted form of the direct-forcing fictitious
domain of Yu & Shao 2007, J. Comput. Phys. 227, 292):

    A u + Phi lambda = b,        Phi^T (u - U e_z) = 0,

with A the step's factorised Taylor-Hood matrix, Phi the phi-weighted velocity mass
(int phi lambda . v r dx) restricted to the dofs whose support meets the sphere, and
lambda the force density [N/m^3] that holds the sphere.  With the predictor
u~ = A^-1 b, u = u~ - A^-1 Phi lambda, and lambda solves the Schur system

    S lambda = Phi^T (u~ - U e_z),      S = Phi^T A^-1 Phi,

symmetric positive semi-definite (A^-1's velocity block is; Dirichlet rows are
dropped from both sides), solved by conjugate gradients; each iteration is one
back-solve with the factors the time loop already holds, so nothing is refactorised
however the sphere moves.  The constraint's strength does not depend on dt: dt is
set by convection alone.  The sphere's force is affine in U,
lambda(U) = lambda(U_e) + (U - U_e) lambda_1 with S lambda_1 = -Phi^T e_z, so the
implicit coupling (coupling.py) keeps working: the step solves for lambda at the
extrapolated velocity U_e (warm-started from the last step) and corrects it with
lambda_1, which changes only with the sphere's position: it is converged once, then
improved by a few CG iterations a step (`unit_steps`) so that it follows the sphere.

Everything here is SI; `immersed.BandAssembler.forcing` applies Phi (it is symmetric).
"""
from __future__ import annotations

import math

import numpy as np
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc


class ConstraintError(ArithmeticError):
    """Conjugate gradients broke down or did not reach the tolerance."""


class RigidConstraint:
    """The multiplier lambda of one sphere (immersed.ImmersedSphere) in its flow (fluid.FlowSolver).

    tolerance: CG stops when the rms interior slip is below this fraction of the speed (speed_scale
    [m/s] for lambda, 1 m/s for lambda_1); unit_steps: CG iterations a step that improve lambda_1."""

    def __init__(self, flow, sphere, tolerance: float = 1e-2, unit_steps: int = 2, speed_scale: float = 1.0,
                 max_iterations: int = 200):
        self.flow, self.sphere = flow, sphere
        self.tolerance, self.unit_steps, self.speed_scale = tolerance, unit_steps, speed_scale
        self.max_iterations = max_iterations
        W = flow.W
        self.multiplier = fem.Function(W)  # lambda at the last solve (warm start)
        self.response = fem.Function(W)  # A^-1 Phi lambda
        self.unit = fem.Function(W)  # lambda_1 = dlambda/dU
        self.unit_response = fem.Function(W)  # A^-1 Phi lambda_1
        self._direction = fem.Function(W)
        self._direction_response = fem.Function(W)
        self._target = fem.Function(W)  # a velocity field to constrain against
        self._residual = flow.rhs.duplicate()
        self._image = flow.rhs.duplicate()
        self.phi_lambda = flow.rhs.duplicate()  # Phi lambda and Phi lambda_1, for the time loop's first pass
        self.phi_unit = flow.rhs.duplicate()
        _, self._uz_dofs = W.sub(0).sub(1).collapse()
        self._has_unit = False
        self._unit_norm = 1.0  # |Phi^T e_z| at the present position
        self.iterations = 0  # CG iterations (= back-solves) so far
        self.unit_iterations = 0  # of which for lambda_1
        self.solves = 0
        self.unconverged = 0  # solves of lambda that stopped at max_iterations

    # -- Phi and S ---------------------------------------------------------------------------
    def apply_phi(self, function: fem.Function, out: PETSc.Vec, scale: float = 1.0) -> PETSc.Vec:
        """out = scale Phi x (x: a W-function with ghosts up to date), ghosts accumulated, Dirichlet rows 0."""
        with out.localForm() as local:
            local.set(0.0)
            self.sphere.band.forcing(local.array, function.x.array, scale)
        return self.flow.force_rhs(out)

    def _rhs(self, predicted: fem.Function | None, velocity: float, out: PETSc.Vec) -> PETSc.Vec:
        """out = Phi^T (u~ - U e_z) (u~ = 0 when predicted is None)."""
        target = self._target
        target.x.array[:] = 0.0 if predicted is None else predicted.x.array
        target.x.array[self._uz_dofs] -= velocity
        return self.apply_phi(target, out)

    def _conjugate_gradients(self, rhs: PETSc.Vec, x: fem.Function, response: fem.Function, speed: float,
                             limit: int) -> tuple[int, bool]:
        """Solve S x = rhs by conjugate gradients from the guess x whose response A^-1 Phi x is given;
        both are updated.  Stops when |Phi^T (u - U e_z)| < tolerance * speed * |Phi^T e_z| (an rms slip
        of tolerance * speed [m/s]) or after `limit` iterations.  Returns (iterations, converged)."""
        r = self._residual
        self.apply_phi(response, r)
        r.aypx(-1.0, rhs)  # r = rhs - S x
        goal = self.tolerance * speed * self._unit_norm
        rr = r.dot(r)
        if math.sqrt(rr) <= goal:
            return 0, True
        p, z = self._direction, self._direction_response
        owned = r.getLocalSize()
        p.x.array[:] = 0.0
        p.x.array[:owned] = r.array_r
        p.x.scatter_forward()
        for iteration in range(1, limit + 1):
            self.flow.solve([self.apply_phi(p, self._image)], [z])
            q = self.apply_phi(z, self._image)
            curvature = p.vector.dot(q)
            if not curvature > 0.0:
                raise ConstraintError(f"the rigid-body constraint's CG broke down (p.Sp = {curvature:g})")
            alpha = rr / curvature
            x.x.array[:] += alpha * p.x.array
            response.x.array[:] += alpha * z.x.array
            r.axpy(-alpha, q)
            rr_new = r.dot(r)
            if math.sqrt(rr_new) <= goal:
                return iteration, True
            beta, rr = rr_new / rr, rr_new
            p.x.array[:owned] = r.array_r + beta * p.x.array[:owned]
            p.x.scatter_forward()
        return limit, False

    # -- a step ------------------------------------------------------------------------------
    def first_pass(self) -> tuple[list, list]:
        """The right-hand sides Phi lambda (and Phi lambda_1) at the present position and the functions
        their responses go to: the time loop solves them in one pass over the factors with its predictor."""
        vectors, functions = [self.apply_phi(self.multiplier, self.phi_lambda)], [self.response]
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
        self._unit_norm = self.sphere.b_phi.norm()
        rhs = self._rhs(predicted, velocity, self.flow.work)
        iterations, converged = self._conjugate_gradients(rhs, self.multiplier, self.response, self.speed_scale,
                                                          self.max_iterations)
        self.iterations += iterations
        self.unconverged += not converged
        self.solves += 1
        rhs = self._rhs(None, 1.0, self.flow.work)  # Phi^T (0 - e_z)
        limit = self.unit_steps if self._has_unit else self.max_iterations
        iterations, _ = self._conjugate_gradients(rhs, self.unit, self.unit_response, 1.0, limit)
        self._has_unit = True
        self.iterations += iterations
        self.unit_iterations += iterations

    def hold_force(self) -> float:
        """The z-force 2 pi int phi lambda_z r dx [N] (lambda pushes the fluid by minus this)."""
        return self.sphere.interior(self.multiplier.vector)

    def unit_force(self) -> float:
        """d(hold_force)/dU [N s/m]."""
        return self.sphere.interior(self.unit.vector)

    def field(self, predicted: fem.Function, shift: float, out: PETSc.Vec) -> PETSc.Vec:
        """u = u~ - A^-1 Phi (lambda + shift lambda_1) as a W-vector; lambda moves to lambda + shift lambda_1."""
        predicted.vector.copy(out)
        out.axpy(-1.0, self.response.vector)
        out.axpy(-shift, self.unit_response.vector)
        if shift:
            self.multiplier.x.array[:] += shift * self.unit.x.array
            self.response.x.array[:] += shift * self.unit_response.x.array
        return out

    def interior_slip(self, velocity_field: fem.Function, velocity: float, depth: float) -> float:
        """max |u - U e_z| [m/s] over the velocity dofs at distance <= depth from the centre (all ranks)."""
        W = self.flow.W
        worst = 0.0
        for component, target in ((0, 0.0), (1, velocity)):
            space, dofs = W.sub(0).sub(component).collapse()
            x = space.tabulate_dof_coordinates()
            inside = np.hypot(x[:, 0], x[:, 1] - self.sphere.center) <= depth
            if inside.any():
                worst = max(worst, float(np.abs(velocity_field.x.array[np.asarray(dofs)[inside]] - target).max()))
        return self.flow.mesh.comm.allreduce(worst, op=MPI.MAX)

    def destroy(self) -> None:
        for vector in (self._residual, self._image, self.phi_lambda, self.phi_unit):
            vector.destroy()
