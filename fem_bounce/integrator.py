"""The bodies' equations of motion (equations.py) advanced with PETSc TS, and the events that locate
each collision.

The system G(t, y, y') = 0 (equations.BodyEquations) goes to an adaptive Rosenbrock-W integrator
(TSROSW) whose steps sub-cycle inside a fluid step: the elastic contact lasts tens of microseconds, a fluid
step a millisecond.  With history modes each unknown is held to its own tolerance, a mode's set by how far
its error moves the velocity (`_build_ts`, `_new_ts`; docs/performance.md, the ODE model's steps).

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
import math
from typing import Callable

import numpy as np
from petsc4py import PETSc

from .bounces import Impact, Rebound, collisions
from .ehd import FilmError
from .equations import BodyEquations, Contact
from .errors import RunDiverged
from .kinematics import FluidForce
from .scene import Scene

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


class BodyIntegrator(BodyEquations):
    """Advances the scene's bodies; the same object serves the ODE, fd, ib and ale models."""

    _film_pending: tuple[float, float] | None = None  # ehd: (t, V) where the gap reached h0

    def __init__(self, scene: Scene, resolved: bool = False, stop_after_impacts: int = 0):
        super().__init__(scene, resolved, stop_after_impacts)
        count = len(self.bodies)
        self.observers: list[Callable[[dict], None]] = []
        self.done = False  # the bounce limit (or stop_after_impacts) was reached, or the bodies rest
        self.stop_reason: str | None = None  # why it is done, when not the bounce limit
        # without gravity nothing brings back a sphere the film has stopped: below this speed it has stalled
        self._stall_speed = STALL_FRACTION * scene.launch_speed if scene.gravity == 0.0 else 0.0
        self._turning_offset = TURNING_OFFSET if count > 1 else 0.0
        self.steps = 0
        # each oblique impact at its two stations (tangential_contact.oblique_record)
        self.oblique_impacts: list[dict] = []
        # each station's (t, normal speed, U, Omega) where the current collision passed it on the way in
        self._oblique_entries: dict[str, tuple | None] = {"contact": None, "outer": None}
        self._build_ts()

    # -- the implicit system ------------------------------------------------------------
    def _build_ts(self) -> None:
        opts, n, layout = self.scene.numerics.ode, self.n, self.kinematics
        start = layout.state([body.initial_gap if k == 0 else body.sphere.gap for k, body in enumerate(self.bodies)],
                             [body.start_velocity for body in self.bodies])
        self.y = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
        initial = np.r_[start, np.zeros(n - len(start))]
        along = self.tangential_slice
        if self.tangential is not None:
            initial[along] = self.tangential.start
        self.y.setArray(initial)
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
        if self.tangential is not None:  # the tangential rows read their own unknowns, their contact's gap and speeds
            contact = self.oblique_contact
            pattern[along, along] = pattern[along, contact.gap_index] = True
            for k in (contact.lower, contact.upper):
                if k is not None:
                    pattern[along, layout.velocity_index(k)] = True
            if self.pair_frame is not None:  # the turning frame's terms in the normal rows and their modes
                pattern[layout.velocity_columns[:, None], np.arange(along.start, along.stop)] = True
                pattern[layout.size:along.stop, contact.gap_index] = pattern[layout.size:along.stop, along] = True
            if self.resolved:  # a resolved flow's added mass couples the normal row to U' and Omega'
                pattern[layout.velocity_index(0), along] = True
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
        if self.tangential is not None:  # the spring's stretch, a fraction of the Hertz overlap: 1e-2 of the others'
            stretch = along.start + self.tangential.STRETCH  # (as tight as a gap's, the steps collapsed where the
            atol.setValue(stretch, 1e-2 * opts.atol)  # friction switches between sticking and sliding)
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
        if self.tangential is not None:  # the modes along the wall or across the line of centres alike
            modes = slice(along.start + len(self.tangential.names), along.stop)
            atol.setValues(range(modes.start, modes.stop), self.tangential.mode_tolerances(
                opts.atol + opts.rtol * self.scene.velocity_unit, self.scene.time_unit))
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
                if contact is self.oblique_contact:
                    self._tangential_crossing(ts, t, rate, "contact")
            elif kind == "turn":
                record.turning_point(t, gap)
            elif kind == "blend":
                record.blend_crossing(t, rate, gap)
                if contact is self.oblique_contact:
                    self._tangential_crossing(ts, t, rate, "outer")
            elif kind == "path":
                self._path_reaches_wall(t)
            else:
                self._penetration(contact, t, gap)

    def _tangential_crossing(self, ts, t: float, rate: float, station: str) -> None:
        """An oblique collision passes one of its two stations (tangential_contact.oblique_record): the contact gap
        ("contact": its spring starts unstretched there) or delta_sl D ("outer"), on the way in or out."""
        solution = ts.getSolution()
        along = self.tangential_slice
        found = self.tangential.station(solution.array_r[along])
        if rate < 0.0:
            if station == "contact":
                solution.setValue(along.start + self.tangential.STRETCH, 0.0)
                solution.assemble()
            self._oblique_entries[station] = (t, -rate, *found)
            return
        entry, self._oblique_entries[station] = self._oblique_entries[station], None
        if entry is None:
            return
        found = self.tangential.record(entry, t, rate, found)
        if station == "contact":
            self.oblique_impacts.append({"contact": found, "outer": None})
        elif self.oblique_impacts and self.oblique_impacts[-1]["outer"] is None:
            self.oblique_impacts[-1]["outer"] = found

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

    def _landing(self, contact: Contact, y, speed: float) -> bool:
        """Whether the wall contact entered at `speed` [m/s] is the free column settling onto the wall
        (ContactLaw.landing, with what moves on the contact and its net weight): no impact."""
        if contact is not self.wall or not self.free.all():
            return False
        return contact.law.landing(speed, self._inertia(y)[contact.upper:].sum(), self.weights[contact.upper:].sum())

    # -- driving it -----------------------------------------------------------------------------
    def advance(self, t_end: float, fluid: FluidForce | None = None) -> None:
        """Integrate to t_end (or until the bounce limit), with f_sim linearised as `fluid`.  A solve ended
        by a film collision (contact.model = "ehd", `_film_jump`) resumes after the jump, which may carry
        the time past t_end by the film's collision time."""
        if fluid is not None:
            self.fluid = self.step_fluid = fluid
            if self.tangential is not None:
                self.tangential.fluid = fluid.plane
            self.flow_at(self.time)
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

    @property
    def along(self) -> np.ndarray | None:
        """An oblique collision's (x [m], U [m/s], Omega [1/s]) of sphere 1 along the wall (oblique.py), else None."""
        return None if self.tangential is None else self._state()[self.tangential_slice][:3].copy()

    @property
    def across_energy(self) -> float:
        """A pair off its line of centres: the spheres' kinetic energy across it and in their spins [J]
        (pair_oblique.PairTangentialMotion.kinetic_energy), which the turning frame trades with the normal one's;
        else 0."""
        if self.pair_frame is None:
            return 0.0
        return self.tangential.kinetic_energy(self._state()[self.tangential_slice])

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
        """Every collision of every contact, in time order (bounces.collisions)."""
        return collisions(self.contacts)

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
        if self.tangential is not None:
            state["oblique"] = {"impacts": self.oblique_impacts, "entries": self._oblique_entries}
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
        if self.done and not any(c.record.resting for c in self.contacts) and self.time < min(
                c.record.stop_at for c in self.contacts):
            self.done = False  # a restart raised run.bounces past the limit the checkpoint had reached
        if self.tangential is not None:
            oblique = state["oblique"]
            self.oblique_impacts = list(oblique["impacts"])
            self._oblique_entries = {key: None if entry is None else tuple(entry)
                                     for key, entry in oblique["entries"].items()}


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
