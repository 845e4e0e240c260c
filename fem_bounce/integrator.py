"""The equations of motion of the bodies on the axis (paper eq. 4.10 for each sphere), advanced with
PETSc TS.  One sphere is N = 1; a pair N = 2; a column of spheres N >= 3 (fem_bounce.bodies).

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
(FluidForce), so the mass matrix is implicit and the coupling stays stable for light spheres; below
delta_sl its correction (contact.near_wall = "correction") is added per contact, or, for one sphere under
the paper's blend, f_sl = H f_thr + (1 - H) f_sim.  A held ("fixed") or prescribed sphere follows its
motion (bodies.Body.prescribed).

Everything is one implicit system G(t, y, y') = 0 with y = [h_1, V_1, s_1, V_2, s_2, V_3, ..., z_1...,
z_2..., ...] (the layout is kinematics.AxisKinematics's, read nowhere else) for an adaptive Rosenbrock-W integrator (TSROSW) whose steps sub-cycle inside a fluid step:
the elastic contact lasts tens of microseconds, a fluid step a millisecond.  The gaps, not the heights,
are integrated so that the relative tolerance governs them near contact (an error of rtol h_2 would
exceed the film).  Its Jacobian is exact, assembled from each force term's own derivatives (ForceTerms);
with history modes each unknown is held to its own tolerance, a mode's set by how far its error moves the
velocity (`_build_ts`, `_new_ts`; docs/performance.md, the ODE model's steps).

TS events, for each neighbouring contact (each pair bottom up, then the wall): the gap crossing its
contact gap (what the contact keeps, h_c or W_o, is fixed there from the approach speed) and delta_sl
(D or 2a*), the gap's rate changing sign (an impact's minimum gap, or a rebound's apex), and the gap
reaching the law's floor (penetration).  One BounceRecord (bounces.py) per contact keeps its collisions.
A prescribed sphere 1 driven into the wall stops the run with an error in its path.

contact.model = "ehd" (one sphere and a wall): the gap reaching the handover gap h0 on approach ends the
TS solve (a terminal event), and `_film_jump` takes the sphere through the film collision.  The
integrator owns its PETSc objects: destroy() frees them.
"""
from __future__ import annotations

import contextlib
import dataclasses
import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from petsc4py import PETSc

from .bodies import Body, scene_bodies, sphere_scene
from .bounces import BounceRecord, Impact, Rebound
from .contact import ContactModel
from .ehd import FilmError
from .errors import RunDiverged
from .kinematics import AxisKinematics, FluidForce
from .pair_contact import PairContactModel
from .scene import Scene
from .theory import TheoryForces

STALL_FRACTION = 1e-3  # of the launch speed: a sphere without gravity slower than this in the film has stalled
# A contact's turning-point event watches its rate (in velocity units) minus this offset, not the rate
# itself, when the run goes on with that contact at rest (more than one body): two spheres moving
# together, or one resting on the wall under another, have a rate of round-off size whose flicker about
# zero made PETSc locate a "turning point" every step until the steps collapsed (a pair creeping together
# in 0.8 Pa s stalled at t = 0.51 s).  A real turning point passes the offset a vanishing time after
# zero.  One sphere's run ends when it rests (ContactLaw.resting), so its rate is watched as it is.
TURNING_OFFSET = 1e-9
RESTART_STEP = 1e-7  # time units: the first step after an event, a film collision's jump or a step PETSc left at 0


class PenetrationError(RuntimeError):
    """A sphere went through the wall or another sphere as far as the contact law can tell
    (ContactLaw.floor): the contact model was overwhelmed."""


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


class BodyIntegrator:
    """Advances the scene's bodies; the same object serves the ODE, fd, ib and ale models."""

    _film_pending: tuple[float, float] | None = None  # ehd: (t, V) where the gap reached h0

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
        self.fluid = FluidForce.none(count)
        self.observers: list[Callable[[dict], None]] = []
        self.contacts: list[Contact] = []
        for k in range(count - 1):
            pair = PairContactModel(scene, resolved, lower=k)
            name = "pair" if count == 2 else f"pair_{k + 1}{k + 2}"
            self.contacts.append(Contact(k, k + 1, pair, BounceRecord(
                scene, pair, stop_after_impacts, numbers=pair.numbers, separating=True), name, layout.gap_index(k + 1)))
        if self.contact is not None:
            # without gravity a rebound ends where the gap passes delta_sl outward
            self.contacts.append(Contact(None, 0, self.contact, BounceRecord(
                scene, self.contact, stop_after_impacts, separating=scene.gravity == 0.0), "wall",
                layout.gap_index(0)))
        self.wall = self.contacts[-1] if self.contact is not None else None
        self.pair_contacts = [c for c in self.contacts if c.lower is not None]  # bottom up: pair k below sphere k + 1
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
        self.done = False  # the bounce limit (or stop_after_impacts) was reached, or the bodies rest
        self.stop_reason: str | None = None  # why it is done, when not the bounce limit
        # without gravity nothing brings back a sphere the film has stopped: below this speed it has stalled
        self._stall_speed = STALL_FRACTION * scene.launch_speed if scene.gravity == 0.0 else 0.0
        self._turning_offset = TURNING_OFFSET if count > 1 else 0.0
        self.steps = 0
        self._build_ts()

    @property
    def n(self) -> int:
        """The number of unknowns: a gap and a velocity per sphere, and the history modes."""
        return self.kinematics.size + sum(self.n_history)

    @property
    def pairs(self) -> list[PairContactModel]:
        """Each neighbouring pair's contact model, bottom up."""
        return [c.model for c in self.pair_contacts]

    @property
    def hold_gaps(self) -> tuple[float, ...]:
        """(sphere 1's hold above the wall, each pair gap's hold) [m]: delta_sl D1 and delta_sl 2a* under
        contact.near_wall = "correction" with a free sphere, else 0 (flow_model.flow_gaps)."""
        return (self.contact.hold_gap if self.contact else 0.0, *(pair.hold_gap for pair in self.pairs))

    # -- the implicit system ------------------------------------------------------------
    def _build_ts(self) -> None:
        opts, n, layout = self.scene.numerics.ode, self.n, self.kinematics
        start = layout.state([body.initial_gap if k == 0 else body.sphere.gap for k, body in enumerate(self.bodies)],
                             [body.start_velocity for body in self.bodies])
        self.y = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
        self.y.setArray(np.r_[start, np.zeros(n - len(start))])
        self._residual_out = np.zeros(n)
        self._forces_state, self._forces_engaged = b"", None  # the state `forces` saw last
        # The Jacobian's nonzeros: the gaps' and velocities' block, each sphere's velocity with its own
        # history modes, and the modes' diagonal.  Sparse, so that LU (nested dissection) eliminates the
        # modes at no fill: a dense LU of five spheres' 180 unknowns cost 15 times more per step.
        pattern = np.zeros((n, n), dtype=bool)
        pattern[:layout.size, :layout.size] = True
        for k, modes in enumerate(self._mode_slices):
            velocity = layout.velocity_index(k)
            pattern[velocity, modes] = pattern[modes, velocity] = True
            pattern[modes, modes] = np.eye(modes.stop - modes.start, dtype=bool)
        rows, columns = np.nonzero(pattern)
        indptr = np.r_[0, np.cumsum(pattern.sum(axis=1))].astype(PETSc.IntType)
        self._pattern = (rows, columns, indptr, columns.astype(PETSc.IntType))
        self._jac = PETSc.Mat().createAIJ([n, n], csr=(indptr, self._pattern[3], np.zeros(len(rows))),
                                          comm=PETSc.COMM_SELF)
        # Without f_ss lubrication stops a sphere ~1e-11 m from the wall: each contact gap's absolute
        # tolerance is 1e-6 of the others so that the relative one governs down there.
        atol = self._atol = self.y.duplicate()
        atol.set(opts.atol)
        for contact in self.contacts:
            atol.setValue(contact.gap_index, 1e-6 * opts.atol)
        # A history mode matters only through its share of the history force: an error dz in mode i moves
        # its sphere's velocity by at most s_i dz (TheoryForces.history_sensitivity, 2e-5 to 0.04 for case
        # 3).  Each mode is held to the error that moves the velocity by the velocity's own tolerance at the
        # scene's speed, atol + rtol U, shared among the sphere's modes; held to atol, as the gaps and
        # velocities are, the 34 modes took half of case 3's steps and bought no accuracy (docs/performance.md).
        for body, theory, modes in zip(self.bodies, self.theories, self._mode_slices):
            if modes.stop == modes.start:
                continue
            sensitivity = theory.history_sensitivity(body.mass + 0.5 * body.displaced_mass, self.scene.time_unit)
            tolerance = (opts.atol + opts.rtol * self.scene.velocity_unit) / (len(sensitivity) * sensitivity)
            atol.setValues(range(modes.start, modes.stop), tolerance)
        atol.assemble()
        self._events = self._event_list()
        self._event_handler = None
        if self._events:
            directions, terminal = ([event[k] for event in self._events] for k in (3, 4))
            self._event_handler = (directions, terminal, self._indicators, self._post_event)
        self.ts = self._new_ts()

    def _new_ts(self) -> PETSc.TS:
        """The adaptive Rosenbrock-W solver (PETSc TSROSW, options prefix sphere_): steps from 1e-3 time
        units, at most 0.02 (options sphere_ts_adapt_dt_max ... override), LU on the small system, and the
        events located to 1e-9 (dimensionless indicators)."""
        time_unit, prefix = self.scene.time_unit, "sphere_"
        ts = PETSc.TS().create(comm=PETSc.COMM_SELF)
        ts.setOptionsPrefix(prefix)
        ts.setType(PETSc.TS.Type.ROSW)
        ts.setIFunction(self._ifunction, None)
        ts.setIJacobian(self._ijacobian, self._jac)
        ts.setTolerances(rtol=self.scene.numerics.ode.rtol, atol=self._atol)
        ts.setTime(0.0)
        ts.setTimeStep(1e-3 * time_unit)
        ts.setMaxSteps(2**31 - 1)
        ts.setMaxSNESFailures(-1)
        ts.setExactFinalTime(PETSc.TS.ExactFinalTime.MATCHSTEP)
        scene_defaults = {
            f"{prefix}ts_adapt_dt_max": 0.02 * time_unit,
            # After an event PETSc 3.18 resumes with the rest of the interrupted step, unchecked by the
            # error control; inside the stiff contact that lost 0.5 % of the energy.  Restart tiny instead.
            f"{prefix}ts_event_post_event_step": RESTART_STEP * time_unit,
        }
        if sum(self.n_history):
            # Each unknown within its own tolerance: the default root-mean-square over the 2N + 34N unknowns
            # averaged the gaps' and velocities' errors away among the history modes.  Without modes (a
            # resolved flow carries the history) the mean over the 2N numbers is kept: there the infinity
            # norm moved refactor_check's fd, ib and ale numbers by 1e-5 (e of ale-three by 3e-4) with 4-19 %
            # more sub-steps, a stricter sub-cycling than the flow's own step needs.
            scene_defaults[f"{prefix}ts_adapt_wnormtype"] = "infinity"
        ts.getSNES().getKSP().setType("preonly")
        ts.getSNES().getKSP().getPC().setType("lu")
        ts.setPostStep(self._post_step)
        with _options_for_one_solver(scene_defaults):  # the event handler reads its options when set
            if self._event_handler is not None:
                ts.setEventHandler(*self._event_handler)
                ts.setEventTolerances(1e-9)  # dimensionless; 1e-12 made PETSc 3.18 take dt = 0 steps
            ts.setFromOptions()
        return ts

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
            drag, d_gap, d_share, d_velocity = theory.drag_slopes(gap, v[k], share)
            f.drag[k] = drag
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
        mass, rhs = self._balance(t, self.forces(t, y))
        out, rates = self._residual_out, self._rates(y)
        gaps, velocities = layout.gap_slice, layout.velocity_slice
        accelerations = ydot[velocities]
        out[gaps] = ydot[gaps] - rates
        out[layout.gap_columns[1:]] += rates[:-1]  # a pair gap's rate is the upper sphere's less the lower's
        out[velocities] = mass @ accelerations - rhs
        modes = slice(layout.size, None)  # every sphere's, each z' - dV/dt + z / T
        taken_in = accelerations if not self._pause_history else self._remembering() * accelerations
        out[modes] = ydot[modes] - taken_in[self._mode_owners] + y[modes] / self._all_mode_times
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
        return jac

    def _ifunction(self, ts, t, y, ydot, f) -> None:
        f.setArray(self.residual(t, y.array_r, ydot.array_r))

    def _ijacobian(self, ts, t, y, ydot, shift, A, P) -> bool:
        jac = self.jacobian(t, y.array_r, ydot.array_r, shift)
        rows, columns, indptr, indices = self._pattern
        P.setValuesCSR(indptr, indices, jac[rows, columns])
        P.assemble()
        if A != P:
            A.assemble()
        return True

    # -- events and records ---------------------------------------------------------------
    def _event_list(self) -> list:
        """(contact, kind, indicator(y, rates) dimensionless, direction, terminate) of each event located;
        rates are the spheres' dh_i/dt (`_rates`), computed once for all the indicators."""
        events = []
        vu = self.scene.velocity_unit
        for contact in self.contacts:
            moving = [k for k in (contact.lower, contact.upper) if k is not None and self.free[k]]
            if not moving and contact.lower is None:  # an imposed path that reaches the wall is an error in it
                events.append((contact, "path", lambda y, rates, i=contact.gap_index: y[i] / self.bodies[0].diameter,
                               -1, True))
            if not moving:
                continue
            length, law, index = contact.model.diameter, contact.law, contact.gap_index  # D or 2a*

            def at_contact(y, rates, c=contact, length=length, index=index):
                if c.law.ehd and c.record.phase == "rebound":
                    return 1.0  # resumed at h0 after a film collision: the next one starts after the apex
                return (y[index] - c.law.boundary(max(-c.rate(rates), 0.0), c.record.engaged_now)) / length
            events += [
                (contact, "contact", at_contact, 0, law.ehd),  # ehd: h0 ends the solve, advance() jumps
                (contact, "turn", lambda y, rates, c=contact: c.rate(rates) / vu - self._turning_offset, 0, False),
                (contact, "blend", lambda y, rates, c=contact, i=index, d=length: (y[i] - c.model.blend_gap) / d, 0,
                 False),
                (contact, "penetration", lambda y, rates, i=index, d=length, law=law: (y[i] - law.floor) / d, -1,
                 True),
            ]
        return events

    def _indicators(self, ts, t, y, values) -> None:
        y = y.array_r
        rates = self._rates(y).tolist()
        for k, (_, _, indicator, _, _) in enumerate(self._events):
            values[k] = indicator(y, rates)

    def _post_event(self, ts, events, t, y, forward) -> None:
        y = y.array_r
        rates = self._rates(y)
        for event in events:
            contact, kind = self._events[event][:2]
            record, gap, rate = contact.record, y[contact.gap_index], contact.rate(rates)
            if kind == "contact" and contact.law.ehd:
                if rate < 0.0 and record.phase == "approach":
                    self._film_pending = (t, rate)
            elif kind == "contact":
                record.contact_crossing(gap, rate, landing=rate < 0.0 and self._landing(contact, y, -rate))
            elif kind == "turn":
                record.turning_point(t, gap)
            elif kind == "blend":
                record.blend_crossing(t, rate, gap)
            elif kind == "path":
                self._path_reaches_wall(t)
            else:
                self._penetration(contact, t, gap)

    def _penetration(self, contact: Contact, t: float, gap: float) -> None:
        """Stop: what went through what, and the setting that would have stopped it."""
        law, speed = contact.law, contact.record.contact_speed
        if contact.lower is None:
            what = f"{'the sphere' if len(self.bodies) == 1 else 'sphere 1'} went through the wall"
            materials = "sphere.youngs_modulus, wall.youngs_modulus"
        else:
            what = f"sphere {contact.upper + 1} went through sphere {contact.lower + 1}"
            materials = ", ".join(f"{self.bodies[k].key}.youngs_modulus" for k in (contact.lower, contact.upper))
        if law.hertz:
            raise PenetrationError(
                f"{what} at t = {t:.6g} s: the Hertz overlap passed {-law.floor * 1e6:.4g} um, a tenth of the "
                f"(reduced) radius, beyond Hertz's small-strain contact (contact speed {speed:.3g} m/s): the "
                f"solids are too soft for this impact ({materials})")
        raise PenetrationError(
            f"{what} at t = {t:.6g} s (gap {gap:.3g} m, contact speed {speed:.3g} m/s): the paper's spring "
            "e_d W_o F(delta/delta_ss) stores too little energy over delta_ss to stop it; raise contact.delta_ss "
            'or use contact.model = "lubricated-hertz"')

    def _path_reaches_wall(self, t: float) -> None:
        motion = self.scene.motion
        path = f"motion.series = {motion.series!r}" if motion.series else f"motion.velocity = {motion.velocity:g} m/s"
        raise PenetrationError(f"the {motion.mode} motion ({path}) drives the sphere into the wall at t = {t:.6g} s: "
                               "an imposed path must keep the gap above 0 "
                               f"(initial_gap = {self.scene.initial_gap:g} m); "
                               "change the path or end the run earlier (run.end_time)")

    def _film_jump(self) -> None:
        """contact.model = "ehd": the film collision of Davis, Serayssol & Hinch (1986) from the handover
        gap h0 (contact.ContactLaw.collide), its inertia the sphere's mass plus its added mass C_M(h0) m_l
        (the liquid outside the film moves with the sphere; C_M is held at its h0 value over the few
        microns of the collision), pressed by the film and the net weight; the outer drag and the history
        force are left out during it (the Stokes drag's impulse over t_c is 0.02-0.2 % of the sphere's
        momentum on case 3; the weight's 0.3-22 %, so it is kept).  The integration resumes at t + t_c at
        h0 moving away at e V_in, or stops at rest.

        The history force's states z_i (z_i' = dV/dt - z_i / T_i) are carried through the collision as
        if the velocity had changed uniformly over t_c: z_i <- z_i e^(-t_c/T_i) + dV (T_i / t_c)
        (1 - e^(-t_c/T_i)), the exact solution for a constant acceleration dV / t_c.  Not reset: the
        lubricated-hertz path integrates them through its Hertz contact, and the velocity's reversal is
        what drives Mei & Adrian's history force after an impact; a reset would forget it and the
        rebound would meet less resistance than under the other contact models."""
        t, v = self._film_pending
        self._film_pending = None
        law, theory = self.wall.law, self.theories[0]
        h0, speed = law.handover, -v
        mass = self.masses[0] + theory.added_mass(h0)[0]
        try:
            result = law.collide(speed, mass, force=-self.weights[0])
        except FilmError as err:
            raise RunDiverged(f"the film collision (contact.model = \"ehd\") at t = {t:.6g} s, arriving at {speed:.3g} "
                              f"m/s at h0 = {h0 * 1e6:.3g} um, could not be solved: {err}; another "
                              "contact.ehd_handover or contact.model = \"lubricated-hertz\" may run") from None
        t_end, h_end, v_end = self.wall.record.film_collision(t, h0, speed, result)
        state = self.y.array.copy()
        history, taus = self._mode_slices[0], theory.history_times[:self.n_history[0]]
        if len(taus):
            duration = max(t_end - t, 1e-300)
            decay = np.exp(-duration / taus)
            remembered = 0.0 if self._pause_history else (v_end - v) * taus / duration * (1.0 - decay)
            state[history] = state[history] * decay + remembered
        state[self.wall.gap_index], state[self.kinematics.velocity_index(0)] = h_end, v_end
        self.y.setArray(state)
        # A fresh TS: PETSc 3.18's event handler keeps the interval of the terminated event, and a solve
        # resumed at a later time bisected it forever (dt stuck at 3e-9 s, measured).
        old, self.ts = self.ts, self._new_ts()
        old.destroy()
        self.ts.setTime(t_end)
        self.ts.setTimeStep(RESTART_STEP * self.scene.time_unit)
        if result.outcome != "rebound":
            self.done = True
            self.stop_reason = (f"the sphere came to rest on the wall in the film at t = {t_end:.6g} s (the film "
                                f"collision at {speed:.3g} m/s from h0 = {h0 * 1e6:.3g} um gave no rebound: "
                                f"{result.outcome})")
        elif self.wall.record.stop_at <= t_end:
            self.done = True

    def _log(self, t: float, y, initial: bool = False) -> None:
        rates = self._rates(y)
        for contact in self.contacts:
            contact.record.log(t, y[contact.gap_index], contact.rate(rates), initial=initial)

    def _post_step(self, ts) -> None:
        t = ts.getTime()
        y = ts.getSolution().array_r
        self.steps += 1
        self._log(t, y)
        self._check_rest(t, y)
        self._report(t, y)
        if t >= min((c.record.stop_at for c in self.contacts), default=math.inf):
            self.done = True
        if self.done:
            ts.setConvergedReason(PETSc.TS.ConvergedReason.CONVERGED_USER)

    def _check_rest(self, t: float, y) -> None:
        """Stop when the free column is stacked on the wall at rest: each contact, loaded by the net weight
        above it, passes ContactLaw.resting with the inertia of what moves on it (the spheres and their
        added masses); or, without gravity, when it stalled in the wall's film (no force brings it back)."""
        wall = self.wall
        if wall is None or not self.free.all() or wall.record.resting:
            return
        rates, contacts = self._rates(y), self.contacts
        if all(c.record.in_contact for c in contacts):
            inertia = self._inertia(y)
            if not all(c.law.resting(y[c.gap_index], c.rate(rates), c.record.engaged, inertia[c.upper:].sum(),
                                     self.weights[c.upper:].sum()) for c in contacts):
                return
            count = len(self.bodies)
            everyone = {1: "the sphere", 2: "both spheres"}.get(count, f"all {count} spheres")
            reason = f"{everyone} came to rest on the wall at t = {t:.6g} s"
        elif all(abs(c.rate(rates)) < self._stall_speed and not c.record.in_contact
                 and y[c.gap_index] < c.model.blend_gap for c in contacts):
            gap = y[self.wall.gap_index] / self.bodies[0].diameter
            reason = (f"the sphere stalled in the lubrication film at t = {t:.6g} s (gap {gap:.3g} D, speed below "
                      f"{STALL_FRACTION:g} of its launch speed, no gravity to bring it back)")
        else:
            return
        for c in contacts:
            c.record.rest(t, y[c.gap_index])
        self.stop_reason = reason

    def _inertia(self, y) -> np.ndarray:
        """Each sphere's mass and added mass at the state y [kg]."""
        return self.masses + np.array([th.added_mass(h)[0] for th, h in zip(self.theories,
                                                                              self.kinematics.heights(y))])

    def _landing(self, contact: Contact, y, speed: float) -> bool:
        """Whether the wall contact entered at `speed` [m/s] is the free column settling onto the wall
        (ContactLaw.landing, with what moves on the contact and its net weight): no impact."""
        if contact is not self.wall or not self.free.all():
            return False
        return contact.law.landing(speed, self._inertia(y)[contact.upper:].sum(), self.weights[contact.upper:].sum())

    def row(self, t: float, y) -> dict:
        """Every sphere's gap, velocity, acceleration and force terms at one instant [SI], named as the
        trajectory's columns (output.trajectory_columns): one sphere's plain, more with suffixes _1, _2,
        ... and the gaps between neighbours.  f_added_mass holds the pairs' added mass too; f_history is
        in f_theory.  Under fixed or prescribed motion the forces are those along the imposed path."""
        f = self.forces(t, y)
        mass, rhs = self._balance(t, f)
        accel = np.linalg.solve(mass, rhs)
        drag, pair, history, blend = (np.array(values) for values in (f.drag, f.pair, f.history, f.blend))
        added_mass = -np.array(f.theory_mass) @ accel + f.am_velocity + f.pair_am_velocity
        theory = drag + pair + added_mass + history
        count = len(self.bodies)
        sim = self.fluid.explicit - self.fluid.added_mass @ accel if self.resolved else theory
        correction = np.array(f.correction) - np.array(f.correction_mass) * accel
        per_sphere = dict(gap=f.heights, velocity=f.velocities, acceleration=accel, f_drag=drag,
                          f_lubrication=[d - sphere.free_drag(u) for d, sphere, u in
                                         zip(drag, self.theories, f.velocities)],
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
        return row

    # -- driving it -----------------------------------------------------------------------------
    def advance(self, t_end: float, fluid: FluidForce | None = None) -> None:
        """Integrate to t_end (or until the bounce limit), with f_sim linearised as `fluid`.  A solve ended
        by a film collision (contact.model = "ehd", `_film_jump`) resumes after the jump, which may carry
        the time past t_end by the film's collision time."""
        if fluid is not None:
            self.fluid = fluid
        if self.done or t_end <= self.time:
            return
        if self.steps == 0:  # the initial state is the first row
            self._log(0.0, self.y.array_r, initial=True)
            self._report(0.0, self.y.array_r)
        while True:
            # PETSc 3.25's TS can leave a step of 0 after a step that lands on the end time (MATCHSTEP) as an event
            # is located there (pair-settling-wall with ale: the lower sphere resting in its Hertz contact); the
            # next solve would divide by it (PETSc error 72).  It restarts at the step taken after a jump.
            if not self.ts.getTimeStep() > 0.0:
                self.ts.setTimeStep(RESTART_STEP * self.scene.time_unit)
            self.ts.setMaxTime(t_end)
            try:
                self.ts.solve(self.y)
            except PETSc.Error as err:
                # petsc4py 3.2x hands an exception raised in a callback (a penetration, the energy bound, a
                # signal) back as PETSc error 101 with the original as its cause: raise the original
                if err.__cause__ is not None and not isinstance(err.__cause__, PETSc.Error):
                    raise err.__cause__ from None
                raise
            if self._film_pending is None:
                break
            self._film_jump()
            if self.done or self.time >= t_end:
                break
        if not np.all(np.isfinite(self.y.array_r)):
            raise FloatingPointError(f"the state became {self.y.array_r.tolist()} at t = {self.time:.6g} s")

    def _state(self) -> np.ndarray:
        return np.array(self.y.array_r) if self.ts is not None else self._final

    @property
    def time(self) -> float:
        return self.ts.getTime() if self.ts is not None else self._final_time

    @property
    def gaps(self) -> np.ndarray:
        """Each sphere's lowest point above z = 0 [m], sphere 1 first."""
        return np.array(self.kinematics.heights(self._state()))

    @property
    def velocities(self) -> np.ndarray:
        """Each sphere's velocity, positive upward [m/s]."""
        return self.kinematics.velocities(self._state()).copy()

    def _report(self, t: float, y) -> None:
        """Hand the observers the row of the state y at t."""
        if self.observers:
            row = self.row(t, y)
            for observer in self.observers:
                observer(row)

    def finish(self) -> None:
        """Close the records (the rebound means; e = 0 for a collision that never left contact)."""
        for contact in self.contacts:
            contact.record.finish()

    # -- the records ------------------------------------------------------------------------------
    @property
    def impacts(self) -> list[Impact]:
        """Sphere 1's impacts on the wall (the pairs' collisions: `collisions`)."""
        return self.wall.record.impacts if self.wall else []

    @property
    def rebounds(self) -> list[Rebound]:
        return self.wall.record.rebounds if self.wall else []

    @property
    def blend_crossings(self) -> list[dict]:
        return self.wall.record.blend_crossings if self.wall else []

    def collisions(self) -> list[dict]:
        """Every collision, in time order: kind (the contact's name: "pair" or "wall"; "pair_12", ... for
        three spheres or more), time of the minimum gap, min_gap, the relative impact speed, Re and St of
        it, and the restitution e.

        A pair's e and impact speed are taken where the pair gap passes delta_sl 2a* (on the way in, and
        out after the collision): e = separation speed / approach speed there, 0 when the gap does not
        open beyond delta_sl 2a* before the next collision or the end (docs/physics.md section 6: the 2 ms
        means of the wall, also given as *_2ms, lie inside the contact layer at a pendulum's speeds).
        A wall collision's are the wall's 2 ms means (bounces.Rebound).  A pair that comes to rest in
        contact still has minima of its gap; one that did not come in through delta_sl 2a* since the
        previous minimum belongs to the collision before it and is not listed."""
        found = []
        for contact in self.contacts:
            record, two_spheres = contact.record, contact.lower is not None
            for k, impact in enumerate(record.impacts):
                if two_spheres and k > 0 and not any(
                        c["direction"] == "in" and record.impacts[k - 1].time < c["time"] <= impact.time
                        for c in record.blend_crossings):
                    continue
                entry = {"kind": contact.name, **dataclasses.asdict(impact)}
                if k < len(record.rebounds):
                    entry.update(dataclasses.asdict(record.rebounds[k]))
                if two_spheres:
                    following = record.impacts[k + 1].time if k + 1 < len(record.impacts) else math.inf
                    _at_blend_gap(entry, record.blend_crossings, following, contact.model)
                found.append(entry)
        return sorted(found, key=lambda c: c["time"])

    def destroy(self) -> None:
        """Free the PETSc objects (the records, and the last state as plain numbers, stay)."""
        if self.ts is None:
            return
        self._final, self._final_time = np.array(self.y.array_r), self.ts.getTime()
        for obj in (self.ts, self._jac, self._atol, self.y):
            obj.destroy()
        self.ts = None

    # -- checkpoints ----------------------------------------------------------------------------
    def state_dict(self) -> dict:
        state = dict(time=self.time, y=self.y.array_r.tolist(), step_size=self.ts.getTimeStep(),
                     machine={"done": self.done, "steps": self.steps}, records={})
        for contact in self.contacts:
            contact.record.save(state["records"].setdefault(contact.name, {}))
        return state

    def load_state_dict(self, state: dict) -> None:
        self.ts.setTime(state["time"])
        self.ts.setTimeStep(state["step_size"])
        self.y.setArray(state["y"])
        self.done, self.steps = state["machine"]["done"], state["machine"]["steps"]
        for contact in self.contacts:
            contact.record.load(state["records"][contact.name])


def _at_blend_gap(entry: dict, crossings: list[dict], following: float, pair: PairContactModel) -> None:
    """Speeds, St, Re and e of a pair collision where its gap passes delta_sl 2a* (collisions)."""
    before = [c for c in crossings if c["direction"] == "in" and c["time"] <= entry["time"]]
    after = [c for c in crossings if c["direction"] == "out" and entry["time"] < c["time"] < following]
    for key in ("impact_speed", "Re", "St", "restitution"):
        entry[f"{key}_2ms"] = entry.get(key)
    if not before:  # it started inside delta_sl 2a*: the 2 ms means stand
        return
    approach = before[-1]["speed"]
    entry["impact_speed"] = approach
    entry["Re"], entry["St"] = pair.numbers(approach)
    entry["separation_speed"] = after[0]["speed"] if after else 0.0
    entry["restitution"] = entry["separation_speed"] / approach


@contextlib.contextmanager
def _options_for_one_solver(defaults: dict):
    """PETSc options the user did not give, set only while one solver reads them: they depend on the
    scene, and the options database outlives it (a study or a test session runs many scenes)."""
    options = PETSc.Options()
    added = [name for name in defaults if not options.hasName(name)]
    for name in added:
        options[name] = defaults[name]
    try:
        yield
    finally:
        for name in added:
            options.delValue(name)
