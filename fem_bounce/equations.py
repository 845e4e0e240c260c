"""The equations of motion of the bodies on the axis (paper eq. 4.10 for each sphere): every force on
them with its exact derivatives, and the residual and Jacobian of the implicit system integrator.py
advances.  One sphere is N = 1; a pair N = 2; a column of spheres N >= 3 (fem_bounce.bodies).

Sphere 1 is the lowest (its lowest point h_1 above z = 0, where the wall is when wall.present); sphere
k + 1 lies above sphere k with the surface gap s_k between them.  Velocities are positive upward.  Each
free sphere obeys

    m_i dV_i/dt = f_liquid,i + f_elastic,i - (m_i - m_l,i) g,

f_elastic,i the contact forces (contact.ContactLaw: a damped Hertz contact below the contact gap h_c, or
the paper's spring) of its neighbouring contacts: the wall's on sphere 1, and each neighbouring pair's,
equal and opposite.  f_liquid,i is, without a resolved flow (the ODE model), the theory force of each
sphere alone (theory.py: its drag with the wall's excess, added mass -C_M m_l dV/dt and the wall's
-(1/2) m_l V^2 dC_M/dh, Mei & Adrian's history force through exponential modes z' = dV/dt - z / T_k)
plus, for each neighbouring pair, the pair's Stokes interaction and its potential-flow added mass
(pair_contact.py, pair_theory.py).  The pairs are superposed: each neighbouring pair's interaction is
that of the two spheres alone, summed over the pairs, and the wall's is added to sphere 1's, not solved
as one many-body problem (docs/physics.md section 6).  A resolved model hands in its force for the
coming fluid step linearised in the accelerations, f_sim,i = explicit_i - sum_j added_mass_ij dV_j/dt
(FluidForce), so the mass matrix is implicit and the coupling stays stable for light spheres; explicit_i runs
linearly through the step from the step before's (numerics.ode.flow_force = "linear", FluidForce.ramp); below
delta_sl its correction (contact.near_wall = "correction") is added per contact, or, for one sphere under
the paper's blend, f_sl = H f_thr + (1 - H) f_sim.  A held ("fixed") or prescribed sphere follows its
motion (bodies.Body.prescribed).

Everything is one implicit system G(t, y, y') = 0 with y = [h_1, V_1, s_1, V_2, s_2, V_3, ..., z_1...,
z_2..., ...] (the layout is kinematics.AxisKinematics's, read nowhere else).  The gaps, not the heights,
are the unknowns so that the relative tolerance governs them near contact (an error of rtol h_2 would
exceed the film).  The Jacobian is exact, assembled from each force term's own derivatives (ForceTerms;
tests/test_jacobian.py checks it against differences of the residual).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .bodies import Body, scene_bodies, sphere_scene
from .bounces import BounceRecord
from .contact import ContactModel
from .kinematics import AxisKinematics, FluidForce, pair_name
from .oblique import TangentialMotion
from .pair_contact import PairContactModel
from .pair_oblique import PairTangentialMotion
from .scene import Scene
from .theory import TheoryForces
from .wall_lift import WallLift


@dataclass
class Contact:
    """One neighbouring contact: the wall and sphere 1 (`lower` None), or spheres `lower` and `lower` + 1
    (indices from 0); its model (contact.ContactModel or pair_contact.PairContactModel), its record and
    its name in checkpoints and collisions ("wall"; "pair" for a pair, "pair_12", "pair_23", ... above)."""

    lower: int | None
    upper: int
    model: ContactModel | PairContactModel
    record: BounceRecord
    name: str
    gap_index: int  # where its gap is in the state y (AxisKinematics.gap_index of `upper`)

    @property
    def law(self):
        return self.model.law

    def rate(self, rates: np.ndarray) -> float:
        """d(gap)/dt from the spheres' dh_i/dt [m/s]."""
        return rates[self.upper] - (rates[self.lower] if self.lower is not None else 0.0)


class ForceTerms:
    """Every force on the N bodies at one state [N] and their added masses [kg], each with its derivatives
    in the state's gaps and velocities (the columns c of y[:2N]: h_1, V_1, s_1, V_2, ...): the exact Jacobian
    of the equations of motion is built from them (BodyIntegrator.jacobian).  Each term adds its value and
    its derivatives together, so that a new term brings its own (tests/test_jacobian.py compares the
    Jacobian with differences of the residual and catches a missing one).

    `theory` is f_thr (drag, added mass velocity terms, the pairs' interaction, history), which the balance
    weighs by `blend`; `theory_mass` its added masses (C_M,i m_l,i on the diagonal, each neighbouring pair's
    beyond the isolated spheres'); `correction`, `correction_mass` and `elastic` are added whole.  Values are
    lists over the spheres, derivatives lists of entries (sphere k, column c, d/dy_c) or, for the added
    masses, (k, j, c, dM_kj/dy_c): plain Python, which a few numbers per sphere cost less than numpy.  What
    sphere k feels of the wall through its height h_k = h_1 + sum of the gaps below it is kept as d/dh_k
    (`theory_height_slopes`, `theory_mass_height_slopes`), spread over those gaps by the Jacobian."""

    def __init__(self, count: int):
        self.count = count
        self.clear()

    def clear(self) -> None:
        count = self.count
        self.heights, self.velocities = [0.0] * count, [0.0] * count
        self.blend = [1.0] * count
        self.theory, self.drag, self.am_velocity, self.pair, self.pair_am_velocity, self.history = (
            [0.0] * count for _ in range(6))
        self.elastic, self.correction, self.correction_mass = [0.0] * count, [0.0] * count, [0.0] * count
        self.theory_mass = [[0.0] * count for _ in range(count)]
        self.history_factors = [1.0] * count  # K_H^(3/2)
        self.theory_height_slopes = [0.0] * count  # d f_thr,k / d h_k
        self.theory_mass_height_slopes = [0.0] * count  # d (C_M,k m_l,k) / d h_k
        self.theory_slopes: list[tuple[int, int, float]] = []
        self.other_slopes: list[tuple[int, int, float]] = []  # of the elastic and correction forces
        self.blend_slopes: list[tuple[int, int, float]] = []
        self.theory_mass_slopes: list[tuple[int, int, int, float]] = []
        self.correction_mass_slopes: list[tuple[int, int, float]] = []
        self.across = 0.0  # sphere 1's velocity along the wall when its drag's inertia reads it
        self.across_slope = 0.0  # d f_thr,1 / d sphere 1's velocity along the wall (its drag's and lift's)
        self.lift = 0.0  # sphere 1's lift from sliding along the wall (wall_lift), in its theory force


class BodyEquations:
    """G(t, y, y') = 0 for the scene's bodies: their force terms, residual and exact Jacobian (module docstring)."""

    def __init__(self, scene: Scene, resolved: bool = False, stop_after_impacts: int = 0):
        self.scene = scene
        self.resolved = resolved  # f_sim comes from a flow solver (else f_sim = f_thr)
        self.bodies: tuple[Body, ...] = scene_bodies(scene)
        count = len(self.bodies)
        self.kinematics = layout = AxisKinematics([b.diameter for b in self.bodies])
        self.free = np.array([b.free for b in self.bodies])
        self.held = np.array([b.held for b in self.bodies])  # its gap does not change
        self.masses = np.array([b.mass for b in self.bodies])
        self.weights = np.array([b.net_weight for b in self.bodies])  # net, toward z = 0 [N]
        # the wall's contact, then each sphere's theory forces (the wall's own for sphere 1)
        self.contact = ContactModel(scene) if scene.wall.present else None
        self.theories = tuple(self.contact.theory if k == 0 and self.contact else TheoryForces(sphere_scene(scene, k))
                              for k in range(count))
        self.uses_theory = not resolved or scene.near_wall_law == "blend"  # f_thr enters the balance
        # the history modes of each sphere (none with a resolved flow: its flow carries the history)
        self.n_history = tuple(th.n_history if self.uses_theory else 0 for th in self.theories)
        ends = layout.size + np.cumsum(self.n_history, dtype=int)  # in y, after the gaps and velocities
        self._mode_slices = [slice(int(end) - modes, int(end)) for end, modes in zip(ends, self.n_history)]
        self._drag_scaled_history = scene.contact.history_wall_factor == "drag-scaled"
        self._pause_history = scene.contact.history_across_contact == "pause"
        self.fluid = self.step_fluid = FluidForce.none(count)  # the flow's force now; over its whole step
        self.contacts: list[Contact] = []
        for k in range(count - 1):
            pair = PairContactModel(scene, resolved, lower=k)
            name = pair_name(k, count)
            self.contacts.append(Contact(k, k + 1, pair, BounceRecord(
                scene, pair, stop_after_impacts, numbers=pair.numbers, separating=True), name, layout.gap_index(k + 1)))
        if self.contact is not None:
            # without gravity a rebound ends where the gap passes delta_sl outward
            self.contacts.append(Contact(None, 0, self.contact, BounceRecord(
                scene, self.contact, stop_after_impacts, separating=scene.gravity == 0.0), "wall",
                layout.gap_index(0)))
        self.wall = self.contacts[-1] if self.contact is not None else None
        self.pair_contacts = [c for c in self.contacts if c.lower is not None]  # bottom up: pair k below sphere k + 1
        # an oblique collision, after the history modes: sphere 1's motion along the wall (oblique.py), or a pair's
        # across its line of centres (pair_oblique.py); the contact whose friction and records it has
        self.tangential: TangentialMotion | PairTangentialMotion | None = None
        self.oblique_contact = self.pair_frame = None
        if scene.oblique and self.wall is not None:
            body = self.bodies[0]
            self.tangential = TangentialMotion(scene, self.contact.law, body.mass, body.displaced_mass,
                                               self.contact.hold_gap if resolved else None)
            self.oblique_contact = self.wall
        elif scene.oblique:
            self.oblique_contact = self.pair_frame = self.pair_contacts[0]
            self.tangential = PairTangentialMotion(scene, self.pair_frame.law, self.bodies, self.theories)
        # the normal drag's inertia at the whole speed's Re (contact.inertial_speed; theory.TheoryForces.drag_slopes)
        self._whole_speed = self.tangential is not None and scene.contact.inertial_speed == "whole"
        # the lift of sphere 1 sliding along the wall, in its theory force (contact.lift; wall_lift)
        self._lift = (WallLift(scene.sphere.diameter, scene.liquid.density, scene.liquid.viscosity)
                      if self.tangential is not None and self.pair_frame is None and self.uses_theory
                      and scene.contact.lift == "steady" else None)
        start = layout.size + sum(self.n_history)
        self.tangential_slice = slice(start, start + (self.tangential.size if self.tangential else 0))
        # what the force terms and the residual reuse at every call (ForceTerms, forces, residual)
        self._terms = ForceTerms(count)
        self._rate_slope_array = np.where(self.held, 0.0, 1.0)  # d(dh_k/dt)/dV_k
        self._rate_slopes = self._rate_slope_array.tolist()
        self._adjacent_pairs = [[j for j in (k - 1, k) if 0 <= j < count - 1] for k in range(count)]
        self._wall_films: list[tuple] = [()] * count  # each sphere's (gap, share, d gap, d share) of the last `forces`
        self._pair_films: list[tuple] = [()] * max(count - 1, 0)  # each pair's
        self._mode_times = [th.history_times[:modes] for th, modes in zip(self.theories, self.n_history)]
        self._all_mode_times = np.concatenate([np.zeros(0), *self._mode_times])
        self._mode_owners = np.repeat(np.arange(count), self.n_history)  # the sphere of each mode in y
        self._diagonal = np.diag_indices(count)
        self._imposed = np.flatnonzero(~self.free).tolist()
    @property
    def n(self) -> int:
        """The number of unknowns: a gap and a velocity per sphere, and the history modes."""
        return self.tangential_slice.stop

    @property
    def pairs(self) -> list[PairContactModel]:
        """Each neighbouring pair's contact model, bottom up."""
        return [c.model for c in self.pair_contacts]

    @property
    def hold_gaps(self) -> tuple[float, ...]:
        """(sphere 1's hold above the wall, each pair gap's hold) [m]: delta_sl D1 and delta_sl 2a* under
        contact.near_wall = "correction" with a free sphere, else 0 (flow_model.flow_gaps)."""
        return (self.contact.hold_gap if self.contact else 0.0, *(pair.hold_gap for pair in self.pairs))

    def _rates(self, y) -> np.ndarray:
        """dh_i/dt: a held sphere's gap stays (its surface may still move: motion.mode = "fixed")."""
        return self._rate_slope_array * self.kinematics.velocities(y)

    def forces(self, t: float, y) -> ForceTerms:
        """Every force term at the state y [SI] with its derivatives (ForceTerms; the object is reused: read it
        before the next call).  A sphere's drag, added mass and history see the wall at its height (sphere 1
        through its contact's film, ContactLaw.film: inside a Hertz contact the lubrication is evaluated at
        h_c and faded out); each neighbouring pair's interaction, added mass and contact its pair gap.

        The last state's terms are kept: the Rosenbrock step evaluates its Jacobian and its first stage at
        the state it starts from, which the previous step's trajectory row has seen (4 evaluations a step
        instead of 6).  The forces depend on y and on what each contact fixed when it began, not on t."""
        f, count, layout = self._terms, len(self.bodies), self.kinematics
        contact_states = tuple(contact.record.engaged_now for contact in self.contacts)
        state = y.tobytes()
        if contact_states == self._forces_engaged and state == self._forces_state:
            return f
        self._forces_engaged = None  # until the terms below are whole
        f.clear()
        v = f.velocities = layout.velocities(y).tolist()
        rate_slopes = self._rate_slopes  # dr_k/dV_k: 0 for a held sphere, whose gap stays
        rates = [v[k] * rate_slopes[k] for k in range(count)]
        heights = f.heights = layout.heights(y)
        wall = self.wall
        if self.resolved:  # f_sim from the flow, f_thr only in the paper's blend on sphere 1
            f.blend = [0.0] * count
            if self.uses_theory and self.contact is not None:
                f.blend[0], slope = self.contact.blend_slope(heights[0])
                f.blend_slopes.append((0, layout.gap_index(0), slope))
        slopes = f.theory_slopes
        for k, theory in enumerate(self.theories):
            # the wall as this sphere sees it: (gap, share of the lubrication left, their d/d height)
            if k == 0 and wall is not None:
                film = wall.law.film_slopes(heights[0], wall.record.engaged_now)
            else:
                film = (heights[k], 1.0, 1.0, 0.0)
            self._wall_films[k] = film
            gap, share, gap_slope, share_slope = film
            velocity = layout.velocity_index(k)
            across = float(y[self.tangential_slice.start + 1]) if k == 0 and self._whole_speed else 0.0
            drag, d_gap, d_share, d_velocity, d_across = theory.drag_slopes(gap, v[k], share, across)
            f.drag[k] = drag
            if across:  # the drag's inertia is the whole speed's (theory.TheoryForces.drag_slopes)
                f.across, f.across_slope = across, d_across
            d_height = d_gap * gap_slope + d_share * share_slope
            slopes.append((k, velocity, d_velocity))
            added_mass = theory.added_mass_slopes(gap)
            f.theory_mass[k][k] += added_mass[0]
            f.theory_mass_height_slopes[k] = added_mass[1] * gap_slope
            term = 0.0
            if share == 1.0:  # C_M is held with the film inside a Hertz contact: no velocity term there
                term, d_gap, d_velocity = theory.added_mass_velocity_term_slopes(gap, v[k], added_mass)
                d_height += d_gap * gap_slope
                slopes.append((k, velocity, d_velocity))
            f.theory_height_slopes[k] += d_height
            f.am_velocity[k] = term
            f.theory[k] += drag + term
        if self._lift is not None:
            gap, _, gap_slope, _ = self._wall_films[0]
            f.lift, d_gap, d_along = self._lift.force_slopes(gap, float(y[self.tangential_slice.start + 1]))
            f.theory[0] += f.lift
            f.theory_height_slopes[0] += d_gap * gap_slope
            f.across_slope += d_along
        for contact in self.pair_contacts:
            self._pair_forces(f, contact, float(y[contact.gap_index]), v, rates)
        for k, modes in enumerate(self._mode_slices):
            if modes.stop > modes.start:
                self._history_force(f, k, y[modes], v[k])
        for contact in self.contacts:
            engaged = contact.record.engaged_now
            if engaged is not None:
                self._contact_force(f, contact, float(y[contact.gap_index]), rates, engaged)
        if self.resolved and self.contact is not None:
            gap, share, gap_slope, share_slope = self._wall_films[0]
            force, mass, d_gap, d_share, d_velocity, d_mass = self.contact.correction_slopes(gap, v[0], share)
            f.correction[0] += force
            gap_column, velocity_column = layout.gap_index(0), layout.velocity_index(0)
            f.other_slopes += [(0, gap_column, d_gap * gap_slope + d_share * share_slope),
                               (0, velocity_column, d_velocity)]
            f.correction_mass[0] += mass
            f.correction_mass_slopes.append((0, gap_column, d_mass * gap_slope))
        self._forces_state, self._forces_engaged = state, contact_states
        return f

    def _pair_forces(self, f: ForceTerms, contact: Contact, gap: float, v: list, rates: list) -> None:
        """A neighbouring pair's Stokes interaction (a resolved flow's correction instead), added mass and its
        velocity terms on its two spheres, into f; its film kept for a drag-scaled history."""
        lower, upper, column = contact.lower, contact.upper, contact.gap_index
        pair, both = contact.model, (lower, upper)
        film = self._pair_films[lower] = pair.law.film_slopes(gap, contact.record.engaged_now)
        gap, share, gap_slope, share_slope = film
        velocities = (self.kinematics.velocity_index(lower), self.kinematics.velocity_index(upper))
        values, d_gap, d_share, d_velocity = pair.interaction_slopes(gap, v[lower], v[upper], share)
        for i, k in enumerate(both):
            f.pair[k] += values[i]
            f.theory[k] += values[i]
            f.theory_slopes += [(k, column, d_gap[i] * gap_slope + d_share[i] * share_slope),
                                (k, velocities[0], d_velocity[i][0]), (k, velocities[1], d_velocity[i][1])]
        if self.resolved:
            values, d_gap, d_share, d_velocity = pair.correction_slopes(gap, v[lower], v[upper], share)
            for i, k in enumerate(both):
                f.correction[k] += values[i]
                f.other_slopes += [(k, column, d_gap[i] * gap_slope + d_share[i] * share_slope),
                                   (k, velocities[0], d_velocity[i][0]), (k, velocities[1], d_velocity[i][1])]
            return
        # the pair's added mass, held with the film inside a Hertz contact as C_M is
        added_mass = pair.added_mass_slopes(gap)
        excess, slope, _ = added_mass
        for i, k in enumerate(both):
            for j, other in enumerate(both):
                f.theory_mass[k][other] += excess[2 * i + j]
                f.theory_mass_slopes.append((k, other, column, slope[2 * i + j] * gap_slope))
        if share != 1.0:
            return
        rate = contact.rate(rates)
        values, d_gap, d_velocity, d_rate = pair.added_mass_velocity_term_slopes(gap, v[lower], v[upper], rate,
                                                                                  added_mass)
        rate_slopes = (-self._rate_slopes[lower], self._rate_slopes[upper])  # d rate / d(V_lower, V_upper)
        for i, k in enumerate(both):
            f.pair_am_velocity[k] += values[i]
            f.theory[k] += values[i]
            f.theory_slopes += [(k, column, d_gap[i]),
                                (k, velocities[0], d_velocity[i][0] + d_rate[i] * rate_slopes[0]),
                                (k, velocities[1], d_velocity[i][1] + d_rate[i] * rate_slopes[1])]

    def _history_force(self, f: ForceTerms, k: int, modes: np.ndarray, velocity: float) -> None:
        """Sphere k's history force f_H = -K_H^(3/2) sum_i c_i z_i into f.  K_H^(3/2) is 1, or drag-scaled
        (contact.history_wall_factor): the wall's lambda at the sphere's gap plus each neighbouring pair's
        X_kk - 1, each faded inside its contact as the drag's excess is."""
        memory, memory_slope = self.theories[k].history_memory(velocity, modes)  # sum_i c_i z_i [N]
        factor = 1.0
        if self._drag_scaled_history:
            gap, share, gap_slope, share_slope = self._wall_films[k]
            factor, d_gap, d_share = self.theories[k].wall_factor_slopes(gap, share)
            f.theory_height_slopes[k] -= memory * (d_gap * gap_slope + d_share * share_slope)
            for lower in self._adjacent_pairs[k]:  # the pairs below and above it
                gap, share, gap_slope, share_slope = self._pair_films[lower]
                side = 3 if lower < k else 0  # (X22 or X11) in (11, 12, 21, 22)
                pair = self.pair_contacts[lower]
                resistance, resistance_slopes = pair.model.resistance_slopes(gap)
                factor += share * (resistance[side] - 1.0)
                f.theory_slopes.append((k, pair.gap_index, -memory * (share * resistance_slopes[side] * gap_slope
                                                                      + (resistance[side] - 1.0) * share_slope)))
        f.history[k] = -factor * memory
        f.theory[k] -= factor * memory
        f.theory_slopes.append((k, self.kinematics.velocity_index(k), -factor * memory_slope))
        f.history_factors[k] = factor

    def _contact_force(self, f: ForceTerms, contact: Contact, gap: float, rates: list, engaged: float) -> None:
        """A contact's elastic force (ContactLaw.force), pushing its two surfaces apart, into f."""
        lower, upper, layout = contact.lower, contact.upper, self.kinematics
        push, d_gap, d_rate = contact.law.force_slopes(gap, contact.rate(rates), engaged)
        for k, sign in ((upper, 1.0), (lower, -1.0)):  # equal and opposite
            if k is None:
                continue
            f.elastic[k] += sign * push
            f.other_slopes += [(k, contact.gap_index, sign * d_gap),
                               (k, layout.velocity_index(upper), sign * d_rate * self._rate_slopes[upper])]
            if lower is not None:
                f.other_slopes.append((k, layout.velocity_index(lower), -sign * d_rate * self._rate_slopes[lower]))

    def flow_at(self, t: float) -> None:
        """The resolved flow's force at t [s] within its fluid step (FluidForce.at), which the balance and the
        tangential rows read."""
        if self.step_fluid.ramp is not None:
            self.fluid = self.step_fluid.at(t)
            if self.tangential is not None:
                self.tangential.fluid = self.fluid.plane

    def _balance(self, t: float, f: ForceTerms) -> tuple[np.ndarray, np.ndarray]:
        """(M, R): the equations of motion read M dV/dt = R (a held or prescribed sphere's row: its
        acceleration).  The theory force weighs `blend` (1 for the ODE model), the resolved flow's 1 - blend."""
        mass, rhs = np.array(f.theory_mass), np.array(f.theory)
        if self.resolved:
            blend = np.array(f.blend)
            mass = blend[:, None] * mass + (1.0 - blend)[:, None] * self.fluid.added_mass
            rhs = blend * rhs + (1.0 - blend) * self.fluid.explicit
        mass[self._diagonal] += self.masses + f.correction_mass
        rhs += np.array(f.correction) + f.elastic - self.weights
        for k in self._imposed:
            mass[k] = 0.0
            mass[k, k] = 1.0
            rhs[k] = self.bodies[k].prescribed(t)[1]
        return mass, rhs

    def residual(self, t: float, y, ydot) -> np.ndarray:
        """G(t, y, y') of the implicit system (module docstring): the gaps' rates, the equations of motion
        M dV/dt - R and the history modes z' - dV/dt + z / T.  Returns the integrator's own array, rewritten by
        the next call."""
        layout = self.kinematics
        self.flow_at(t)
        mass, rhs = self._balance(t, self.forces(t, y))
        out, rates = self._residual_out, self._rates(y)
        gaps, velocities = layout.gap_slice, layout.velocity_slice
        accelerations = ydot[velocities]
        out[gaps] = ydot[gaps] - rates
        out[layout.gap_columns[1:]] += rates[:-1]  # a pair gap's rate is the upper sphere's less the lower's
        out[velocities] = mass @ accelerations - rhs
        modes = slice(layout.size, self.tangential_slice.start)  # every sphere's, each z' - dV/dt + z / T
        taken_in = accelerations if not self._pause_history else self._remembering() * accelerations
        out[modes] = ydot[modes] - taken_in[self._mode_owners] + y[modes] / self._all_mode_times
        if self.pair_frame is not None:  # the pair's rows across its line of centres, and the turning frame's terms
            along, pair = self.tangential_slice, self.pair_frame
            gap = y[pair.gap_index]
            out[along] = self.tangential.residual(y[along], ydot[along], gap, pair.rate(rates), self._pair_films[0][0],
                                                  pair.record.engaged_now, y[velocities])
            lack = self.tangential.frame_terms(y[along], gap)[0]  # what dV/dt lacks of the acceleration along n
            out[velocities] -= mass @ lack
            out[modes] += (lack if not self._pause_history else self._remembering() * lack)[self._mode_owners]
        elif self.tangential is not None:
            along, wall = self.tangential_slice, self.wall
            out[along] = self.tangential.residual(y[along], ydot[along], y[wall.gap_index], rates[0],
                                                  self._wall_films[0][0], wall.record.engaged_now, accelerations[0])
            plane = self.fluid.plane
            if plane is not None:  # a resolved flow's added mass of the normal force on the tangential accelerations
                out[layout.velocity_index(0)] += plane.mass[0, 1:] @ ydot[along][1:3]
        return out

    def _remembering(self) -> np.ndarray:
        """1 for a sphere whose history modes take in its acceleration now, 0 for one in a contact under
        contact.history_across_contact = "pause" (its modes then only decay: the contact's reversal is not
        remembered, docs/physics.md 3.6)."""
        remember = np.ones(len(self.bodies))
        if self._pause_history:
            for contact in self.contacts:
                if contact.record.engaged_now is not None:
                    remember[[k for k in (contact.lower, contact.upper) if k is not None]] = 0.0
        return remember

    def jacobian(self, t: float, y, ydot, shift: float) -> np.ndarray:
        """dG/dy + shift dG/dy' at (t, y, y'), exact: the gaps' and the history modes' rows are linear; the
        equations of motion's are the force terms' own derivatives (ForceTerms) and the added masses'
        d(M dV/dt)/dy.  Dense (n, n); the solver keeps only its nonzero pattern."""
        count, n, layout = len(self.bodies), self.n, self.kinematics
        self.flow_at(t)
        f = self.forces(t, y)
        mass, _ = self._balance(t, f)
        accelerations = np.asarray(layout.velocities(ydot)).tolist()
        blend = f.blend
        # d(M dV/dt - R)/dy of the velocity rows, R = blend f_thr + (1 - blend) f_sim + the rest
        motion = np.zeros((count, layout.size))
        for k, column, slope in f.theory_slopes:
            motion[k, column] -= blend[k] * slope
        for k, column, slope in f.other_slopes:
            motion[k, column] -= slope
        for k, j, column, slope in f.theory_mass_slopes:
            motion[k, column] += blend[k] * slope * accelerations[j]
        for k, column, slope in f.correction_mass_slopes:
            motion[k, column] += slope * accelerations[k]
        if f.blend_slopes:  # the blend's own derivative weighs f_thr against the flow's force
            explicit, added_mass = self.fluid.explicit, self.fluid.added_mass
            for k, column, slope in f.blend_slopes:
                theory_mass = np.array(f.theory_mass[k])
                motion[k, column] += slope * ((theory_mass - added_mass[k]) @ accelerations
                                              - (f.theory[k] - explicit[k]))
        for k in range(count):  # through the sphere's height, every gap below it
            motion[k, layout.gaps_below(k)] += blend[k] * (f.theory_mass_height_slopes[k] * accelerations[k]
                                                    - f.theory_height_slopes[k])
        motion[self._imposed] = 0.0
        jac = np.zeros((n, n))
        gaps, velocities = layout.gap_columns, layout.velocity_columns
        jac[gaps, gaps] = shift
        jac[gaps, velocities] = -self._rate_slope_array
        jac[gaps[1:], velocities[:-1]] = self._rate_slope_array[:-1]
        jac[velocities, :layout.size] = motion
        jac[np.ix_(velocities, velocities)] += shift * mass
        remember = self._remembering()
        for k, modes in enumerate(self._mode_slices):
            if modes.stop > modes.start:
                velocity = layout.velocity_index(k)
                if self.free[k]:  # -dR/dz: R holds blend f_H = -blend K c . z
                    jac[velocity, modes] = blend[k] * f.history_factors[k] * self.theories[k].history_coefficients(
                        f.velocities[k])
                jac[modes, velocity] = -shift * remember[k]
                jac[modes, modes] = np.diag(shift + 1.0 / self._mode_times[k])
        if self.pair_frame is not None:
            self._pair_frame_jacobian(jac, y, f, mass, shift)
        elif self.tangential is not None:
            along, wall = self.tangential_slice, self.wall
            gap, _, film_slope, _ = self._wall_films[0]
            own, normal = self.tangential.jacobian(y[along], y[wall.gap_index], self._rates(y)[0], gap, film_slope,
                                                   wall.record.engaged_now, shift)
            jac[along, along] = own
            jac[along, [wall.gap_index, layout.velocity_index(0)]] = normal
            if self.free[0]:  # the normal drag's inertia and the lift through the speed along the wall
                jac[layout.velocity_index(0), along.start + 1] -= blend[0] * f.across_slope
            if self.fluid.plane is not None:
                jac[layout.velocity_index(0), along.start + 1:along.start + 3] += shift * self.fluid.plane.mass[0, 1:]
        return jac

    def _pair_frame_jacobian(self, jac: np.ndarray, y, f: ForceTerms, mass: np.ndarray, shift: float) -> None:
        """The pair's rows across its line of centres (pair_oblique.PairTangentialMotion.jacobian) and the turning
        frame's terms in the normal rows and modes, into `jac`."""
        layout, along, pair = self.kinematics, self.tangential_slice, self.pair_frame
        gap = y[pair.gap_index]
        film, _, film_slope, _ = self._pair_films[0]
        velocities = layout.velocity_columns
        own, normal = self.tangential.jacobian(y[along], gap, pair.rate(self._rates(y)), film, film_slope,
                                               pair.record.engaged_now, shift, y[velocities])
        jac[along, along] = own
        jac[along, [pair.gap_index, *velocities]] = normal
        lack, d_across, d_gap = self.tangential.frame_terms(y[along], gap)
        across = slice(along.start + 3, along.start + 5)  # U_1, U_2
        jac[velocities, across] -= mass @ d_across
        jac[velocities, pair.gap_index] -= mass @ d_gap
        for k, j, column, slope in f.theory_mass_slopes:  # the pair's added mass in its gap
            jac[velocities[k], column] -= slope * lack[j]
        modes = slice(layout.size, along.start)
        remember = self._remembering() if self._pause_history else np.ones(len(self.bodies))
        owners = self._mode_owners
        jac[modes, across] += (remember[:, None] * d_across)[owners]
        jac[modes, pair.gap_index] += (remember * d_gap)[owners]

    def _inertia(self, y) -> np.ndarray:
        """Each sphere's mass and added mass at the state y [kg]."""
        return self.masses + np.array([th.added_mass(h)[0] for th, h in zip(self.theories,
                                                                              self.kinematics.heights(y))])

    def row(self, t: float, y) -> dict:
        """Every sphere's gap, velocity, acceleration and force terms at one instant [SI], named as the
        trajectory's columns (output.trajectory_columns): one sphere's plain, more with suffixes _1, _2,
        ... and the gaps between neighbours.  f_added_mass holds the pairs' added mass too; f_history is
        in f_theory.  Under fixed or prescribed motion the forces are those along the imposed path."""
        self.flow_at(t)
        f = self.forces(t, y)
        mass, rhs = self._balance(t, f)
        accel = np.linalg.solve(mass, rhs)
        along_accelerations, across = self._along_accelerations(y, mass, rhs)
        if along_accelerations is not None:
            accel = np.array([(rhs[0] - across @ along_accelerations) / mass[0, 0]])
        drag, pair, history, blend = (np.array(values) for values in (f.drag, f.pair, f.history, f.blend))
        added_mass = -np.array(f.theory_mass) @ accel + f.am_velocity + f.pair_am_velocity
        theory = drag + pair + added_mass + history
        theory[0] += f.lift
        count = len(self.bodies)
        sim = self.fluid.explicit - self.fluid.added_mass @ accel if self.resolved else theory
        if along_accelerations is not None:
            sim = sim - across @ along_accelerations
        correction = np.array(f.correction) - np.array(f.correction_mass) * accel
        per_sphere = dict(gap=f.heights, velocity=f.velocities, acceleration=accel, f_drag=drag,
                          f_lubrication=[d - sphere.free_drag(u, f.across if k == 0 else 0.0) for k, (d, sphere, u)
                                         in enumerate(zip(drag, self.theories, f.velocities))],
                          f_history=history, f_pair=pair, f_added_mass=added_mass, f_theory=theory,
                          f_sim=sim, blend=blend, f_liquid=blend * theory + (1.0 - blend) * sim + correction,
                          f_elastic=f.elastic, f_correction=correction)
        row = {"t": t}
        suffixes = [""] if count == 1 else [f"_{k + 1}" for k in range(count)]
        for name, values in per_sphere.items():
            for suffix, value in zip(suffixes, values):
                row[name + suffix] = float(value)
        for contact in self.contacts:
            if contact.lower is not None:
                row[contact.name.replace("pair", "pair_gap")] = float(y[contact.gap_index])
        if self.pair_frame is not None:
            along, pair = y[self.tangential_slice], self.pair_frame
            gap = float(y[pair.gap_index])
            lack = self.tangential.frame_terms(along, gap)[0]
            row.update(self.tangential.row(along, gap, float(pair.rate(self._rates(y))), self._pair_films[0][0],
                                           pair.record.engaged_now, float(pair.rate(accel + lack))))
        elif self.tangential is not None:
            along = y[self.tangential_slice]
            row.update(zip(TangentialMotion.names[:3], (float(v) for v in along[:3])))
            row.update(self.tangential.row(along, y[self.wall.gap_index], self._rates(y)[0], self._wall_films[0][0],
                                           self.wall.record.engaged_now, float(accel[0]), along_accelerations))
            row["f_lift"] = float(f.lift)
        return row

    def _along_accelerations(self, y, mass, rhs) -> tuple:
        """(dU/dt, dOmega/dt) and the normal force's added mass on them (kinematics.PlaneForce.mass[0, 1:]) when a
        resolved flow's added mass couples the normal and tangential equations (one sphere), else (None, None): the
        three accelerations solved together from the residual's rows."""
        plane = self.fluid.plane if self.tangential is not None else None
        if plane is None:
            return None, None
        along, wall = y[self.tangential_slice], self.wall
        pushed = -self.tangential.residual(along, np.zeros(len(along)), y[wall.gap_index], self._rates(y)[0],
                                           self._wall_films[0][0], wall.record.engaged_now)[1:3]  # F and T at rest
        system = np.array(plane.mass)
        system[0, 0] = mass[0, 0]
        system[1:, 1:] += np.diag([self.tangential.mass, self.tangential.inertia])
        return np.linalg.solve(system, np.r_[rhs[0], pushed])[1:], plane.mass[0, 1:]
