"""Two spheres in one fd flow: a head-on pair on the axis (issue 14).

Each sphere has its own smoothed indicator phi_i (immersed.ImmersedSphere, its own BandAssembler) and
its own amplitude s_i, so the step's forcing is f = rho c sum_i phi_i (s_i e_z - u~) and its field

    u = u~ + y0 + s_1 y1_1 + s_2 y1_2,   A y0 = -rho c sum_i phi_i u~,   A y1_j = rho c phi_j e_z,

three back-solves beside the predictor with the one factorisation.  The amplitudes make each interior
move with its own sphere on average, I_i(u) = U_i V_i (coupling.rigid_amplitudes), so each sphere's
force, read from its own indicator, is affine in both new velocities: sphere 2 feels sphere 1's
velocity through y1_1 (coupling.linearise_pair gives the 2 x 2 added mass).

The indicators' supports |x - X_i| < a_h,i must not overlap (the forcing would count the liquid between
them twice and tie the two interiors together): the surfaces must stay at least
`min_gap` = (a_h,1 - a_1) + (a_h,2 - a_2) apart, one fine cell with the default radius_offset.  The
pair's hold gap (flow_model.flow_gaps) keeps the flow's spheres that far apart; `check_hold` refuses a
scene whose hold does not.
"""
from __future__ import annotations

import numpy as np
from dolfinx import fem
from petsc4py import PETSc

from ...scene import SceneError
from .coupling import PairIntegrals
from .immersed import ImmersedSphere


def check_hold(min_gap: float, pair_hold: float, what: str) -> None:
    """Refuse a hold gap [m] below min_gap: the flow's spheres could come so close that their
    indicators overlap.  `what` says where the hold comes from, for the message."""
    if pair_hold < min_gap:
        raise SceneError(
            f"numerics.fd: the two spheres' indicators overlap when their surfaces are closer than "
            f"{min_gap:.4g} m (radius_offset x fine size each), but the flow places them down to "
            f"{pair_hold:.4g} m apart ({what}): raise numerics.fd.cells_per_diameter or contact.delta_sl "
            f"(contact.near_wall = \"correction\" holds the pair at its delta_sl gap)")


class ImmersedPair:
    """The two spheres of a pair in `flow` (fluid.FlowSolver): outer radii a_h,i and true radii a_i [m],
    the band width [m] and the centres [m] of their first placement, sphere 1 (lower) first."""

    def __init__(self, flow, radii, true_radii, width: float, centers):
        self.flow = flow
        self.spheres = [ImmersedSphere(flow, radius, width, center) for radius, center in zip(radii, centers)]
        self.min_gap = max(sum(a_h - a for a_h, a in zip(radii, true_radii)), 0.0)
        self._contact_distance = sum(true_radii)  # centre distance at touching [m]
        self.forced = fem.Function(flow.W)  # y0, the response to both spheres' forcing of -u~
        self._force = flow.rhs.duplicate()
        self.check_separation([sphere.center for sphere in self.spheres])

    @property
    def volumes(self) -> np.ndarray:
        return np.array([sphere.volume for sphere in self.spheres])

    def check_separation(self, centers) -> None:
        gap = centers[1] - centers[0] - self._contact_distance
        if gap < self.min_gap * (1.0 - 1e-12):
            raise SceneError(f"numerics.fd: the pair's surfaces are {gap:.4g} m apart, closer than {self.min_gap:.4g} m"
                             " where the two spheres' indicators start to overlap")

    def place(self, centers) -> None:
        """Put the indicators' centres at z = centers [m] (each re-assembled only if it moved)."""
        self.check_separation(centers)
        for sphere, center in zip(self.spheres, centers):
            if center != sphere.center:
                sphere.place(center)

    def stale_units(self) -> tuple[list, list]:
        """The unit forcings rho c phi_j e_z of the spheres that moved since their y1_j, and the functions
        y1_j goes to: the time loop solves them with its predictor in one pass over the factors."""
        stale = [sphere for sphere in self.spheres if sphere.unit_stale]
        return [sphere.unit_forcing() for sphere in stale], [sphere.unit for sphere in stale]

    def forcing(self, predicted: fem.Function) -> PETSc.Vec:
        """-rho c (phi_1 + phi_2) u~, ready for the flow solver; its response y0 goes to `self.forced`."""
        flow = self.flow
        with self._force.localForm() as local:
            local.set(0.0)
            for sphere in self.spheres:
                sphere.band.forcing(local.array, predicted.x.array, -flow.density * flow.c)
        return flow.force_rhs(self._force)

    def integrals(self, predicted: fem.Function) -> PairIntegrals:
        spheres = self.spheres
        return PairIntegrals(
            volume=self.volumes,
            predicted=np.array([sphere.interior(predicted.vector) for sphere in spheres]),
            forced=np.array([sphere.interior(self.forced.vector) for sphere in spheres]),
            unit=np.array([[sphere.interior(other.unit.vector) for other in spheres] for sphere in spheres]))

    def field(self, predicted: fem.Function, amplitudes, out: PETSc.Vec) -> PETSc.Vec:
        """u = u~ + y0 + sum_j s_j y1_j as a W-vector."""
        predicted.vector.copy(out)
        out.axpy(1.0, self.forced.vector)
        for sphere, s in zip(self.spheres, amplitudes):
            out.axpy(float(s), sphere.unit.vector)
        return out

    def destroy(self) -> None:
        self._force.destroy()
        for sphere in self.spheres:
            sphere.destroy()
