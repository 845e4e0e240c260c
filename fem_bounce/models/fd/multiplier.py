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
lambda_1, which changes only with the sphere's position and is refreshed when the
sphere has moved `unit_refresh` fine cells since it was computed.

Everything here is SI; `immersed.BandAssembler.forcing` applies Phi (it is symmetric).
"""
from __future__ import annotations

import math

import numpy as np
from dolfinx import fem
from petsc4py import PETSc


class ConstraintError(ArithmeticError):
    """Conjugate gradients broke down or did not reach the tolerance."""


class RigidConstraint:
    """The multiplier lambda of one sphere (immersed.ImmersedSphere) in its flow (fluid.FlowSolver).

    tolerance: CG stops when the constraint residual is below this fraction of the right-hand side's;
    unit_refresh: lambda_1 is recomputed after the sphere moved this many fine cells [-];
    fine_size [m]."""

    def __init__(self, flow, sphere, tolerance: float = 1e-2, unit_refresh: float = 0.5, fine_size: float = 1.0,
                 speed_scale: float = 1.0, max_iterations: int = 100):
        self.flow, self.sphere = flow, sphere
        self.speed_scale = speed_scale
        self.tolerance, self.max_iterations = tolerance, max_iterations
        self.refresh_distance = unit_refresh * fine_size
        W = flow.W
        self.multiplier = fem.Function(W)  # lambda at the last solve (warm start)
        self.response = fem.Function(W)  # A^-1 Phi lambda
        self.unit = fem.Function(W)  # lambda_1 = dlambda/dU
        self.unit_response = fem.Function(W)  # A^-1 Phi lambda_1
        self._direction = fem.Function(W)
        self._direction_response = fem.Function(W)
        self._residual = flow.rhs.duplicate()
        self._image = flow.rhs.duplicate()
        self.phi_lambda = flow.rhs.duplicate()  # Phi lambda, for the time loop's first pass
        self._target = fem.Function(W)  # a velocity field to constrain against
        self._unit_at = math.nan
        self._has_unit = False
        self.iterations = 0  # CG iterations (= back-solves) so far
        self.solves = 0
        self.unit_iterations = 0  # of which for lambda_1
        self.unconverged = 0  # solves that stopped at max_iterations (the slip left is then reported)
        self._unit_norm = 1.0
        self.unit_solves = 0
        _, self._uz_dofs = W.sub(0).sub(1).collapse()

    # -- Phi and S ---------------------------------------------------------------------------
    def apply_phi(self, function: fem.Function, out: PETSc.Vec, scale: float = 1.0) -> PETSc.Vec:
        """out = scale Phi x (x: a W-function with ghosts up to date), ghosts accumulated, Dirichlet rows 0."""
        with out.localForm() as local:
            local.set(0.0)
            self.sphere.band.forcing(local.array, function.x.array, scale)
        return self.flow.force_rhs(out)

    def _respond(self, functions: list, responses: list) -> None:
        """responses = A^-1 Phi x for each x, in one pass over the factors."""
        rhs = []
        for k, x in enumerate(functions):
            vector = self._image if k == 0 else self._residual.duplicate()
            rhs.append(self.apply_phi(x, vector))
        self.flow.solve(rhs, responses)
        for vector in rhs[1:]:
            vector.destroy()

    def _conjugate_gradients(self, rhs: PETSc.Vec, x: fem.Function, response: fem.Function,
                             speed: float) -> int:
        """Solve S x = rhs by conjugate gradients from the guess x whose response A^-1 Phi x is given;
        both are updated.  Stops when the weighted interior slip |Phi^T (u - U e_z)| is below
        tolerance * speed * |Phi^T e_z|, i.e. an rms slip of `tolerance` times `speed` [m/s].
        Returns the iterations (one back-solve each)."""
        r = self._residual
        self.apply_phi(response, r)
        r.aypx(-1.0, rhs)  # r = rhs - S x
        goal = self.tolerance * speed * self._unit_norm
        rr = r.dot(r)
        if math.sqrt(rr) <= goal:
            return 0
        p, z = self._direction, self._direction_response
        owned = r.getLocalSize()
        p.x.array[:] = 0.0
        p.x.array[:owned] = r.array_r
        p.x.scatter_forward()
        for iteration in range(1, self.max_iterations + 1):
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
                return iteration
            beta, rr = rr_new / rr, rr_new
            p.x.array[:owned] = r.array_r + beta * p.x.array[:owned]
            p.x.scatter_forward()
        self.unconverged += 1
        return self.max_iterations

    # -- a step ------------------------------------------------------------------------------
    @property
    def unit_stale(self) -> bool:
        return not (self._has_unit and abs(self.sphere.center - self._unit_at) <= self.refresh_distance)

    def _rhs(self, predicted: fem.Function | None, velocity: float, out: PETSc.Vec) -> PETSc.Vec:
        """out = Phi^T (u~ - U e_z)."""
        target = self._target
        if predicted is None:
            target.x.array[:] = 0.0
        else:
            target.x.array[:] = predicted.x.array
        target.x.array[self._uz_dofs] -= velocity
        return self.apply_phi(target, out)

    def solve(self, predicted: fem.Function, velocity: float, response_ready: bool = False) -> None:
        """lambda for the sphere velocity U [m/s] given the predictor u~; the warm start is the last
        lambda, whose response A^-1 Phi lambda at the present position must already be in
        `self.response` when response_ready (the time loop solves it beside the predictor)."""
        if not response_ready:
            self._respond([self.multiplier], [self.response])
        self._unit_norm = self.sphere.b_phi.norm()
        rhs = self._rhs(predicted, velocity, self.flow.work)
        self.iterations += self._conjugate_gradients(rhs, self.multiplier, self.response, self.speed_scale)
        self.solves += 1
        if self.unit_stale:
            self.solve_unit()

    def solve_unit(self) -> None:
        """lambda_1: S lambda_1 = -Phi^T e_z (warm-started from the last one)."""
        if self._has_unit:
            self._respond([self.unit], [self.unit_response])
        rhs = self._rhs(None, 1.0, self.flow.work)  # Phi^T (0 - e_z)
        iterations = self._conjugate_gradients(rhs, self.unit, self.unit_response, 1.0)
        self.iterations += iterations
        self.unit_iterations += iterations
        self.unit_solves += 1
        self._unit_at = self.sphere.center
        self._has_unit = True

    def hold_force(self, shift: float = 0.0) -> float:
        """The z-force the multiplier applies to the fluid, 2 pi int phi lambda_z r dx, for
        lambda + shift lambda_1 [N] (its reaction pushes the sphere)."""
        total = self.sphere.interior(self.multiplier.vector)
        return total + shift * self.sphere.interior(self.unit.vector) if shift else total

    def unit_force(self) -> float:
        """d(hold force)/dU [N s/m]."""
        return self.sphere.interior(self.unit.vector)

    def field(self, predicted: fem.Function, shift: float, out: PETSc.Vec) -> PETSc.Vec:
        """u = u~ - A^-1 Phi (lambda + shift lambda_1), a W-vector; also moves lambda by shift lambda_1."""
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
        from mpi4py import MPI

        return self.flow.mesh.comm.allreduce(worst, op=MPI.MAX)

    def destroy(self) -> None:
        self._residual.destroy()
        self._image.destroy()
        self.phi_lambda.destroy()

