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
z_2..., ...] for an adaptive Rosenbrock-W integrator (TSROSW) whose steps sub-cycle inside a fluid step:
the elastic contact lasts tens of microseconds, a fluid step a millisecond.  The gaps, not the heights,
are integrated so that the relative tolerance governs them near contact (an error of rtol h_2 would
exceed the film).

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


@dataclass(frozen=True)
class FluidForce:
    """A resolved model's forces on the N bodies over one fluid step [N, kg]:
    f_sim,i = explicit_i - sum_j added_mass_ij dV_j/dt, `explicit` of shape (N,), `added_mass` (N, N)."""

    explicit: np.ndarray
    added_mass: np.ndarray


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

    @property
    def gap_index(self) -> int:
        """Where its gap is in the state y."""
        return 2 * self.upper

    @property
    def law(self):
        return self.model.law

    def rate(self, rates: np.ndarray) -> float:
        """d(gap)/dt from the spheres' dh_i/dt [m/s]."""
        return rates[self.upper] - (rates[self.lower] if self.lower is not None else 0.0)


class BodyIntegrator:
    """Advances the scene's bodies; the same object serves the ODE, fd, ib and ale models."""

    _film_pending: tuple[float, float] | None = None  # ehd: (t, V) where the gap reached h0

    def __init__(self, scene: Scene, resolved: bool = False, stop_after_impacts: int = 0):
        self.scene = scene
        self.resolved = resolved  # f_sim comes from a flow solver (else f_sim = f_thr)
        self.bodies: tuple[Body, ...] = scene_bodies(scene)
        count = len(self.bodies)
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
        ends = 2 * count + np.cumsum(self.n_history, dtype=int)  # in y, after the gaps and velocities
        self._mode_slices = [slice(int(end) - modes, int(end)) for end, modes in zip(ends, self.n_history)]
        self._drag_scaled_history = scene.contact.history_wall_factor == "drag-scaled"
        self.fluid = FluidForce(np.zeros(count), np.zeros((count, count)))
        self.observers: list[Callable[[dict], None]] = []
        self.contacts: list[Contact] = []
        for k in range(count - 1):
            pair = PairContactModel(scene, resolved, lower=k)
            name = "pair" if count == 2 else f"pair_{k + 1}{k + 2}"
            self.contacts.append(Contact(k, k + 1, pair, BounceRecord(
                scene, pair, stop_after_impacts, numbers=pair.numbers, separating=True), name))
        if self.contact is not None:
            # without gravity a rebound ends where the gap passes delta_sl outward
            self.contacts.append(Contact(None, 0, self.contact, BounceRecord(
                scene, self.contact, stop_after_impacts, separating=scene.gravity == 0.0), "wall"))
        self.wall = self.contacts[-1] if self.contact is not None else None
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
        return 2 * len(self.bodies) + sum(self.n_history)

    @property
    def pairs(self) -> list[PairContactModel]:
        """Each neighbouring pair's contact model, bottom up."""
        return [c.model for c in self.contacts if c.lower is not None]

    @property
    def hold_gaps(self) -> tuple[float, ...]:
        """(sphere 1's hold above the wall, each pair gap's hold) [m]: delta_sl D1 and delta_sl 2a* under
        contact.near_wall = "correction" with a free sphere, else 0 (flow_model.flow_gaps)."""
        return (self.contact.hold_gap if self.contact else 0.0, *(pair.hold_gap for pair in self.pairs))

    def _history_states(self, y) -> list[np.ndarray]:
        """Each sphere's history modes in the state y."""
        return [np.asarray(y[modes]) for modes in self._mode_slices]

    # -- the implicit system ------------------------------------------------------------
    def _build_ts(self) -> None:
        opts, n = self.scene.numerics.ode, self.n
        start = []
        for k, body in enumerate(self.bodies):
            gap = body.initial_gap if k == 0 else body.sphere.gap
            start += [gap, body.start_velocity]
        self.y = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
        self.y.setArray(np.r_[start, np.zeros(n - len(start))])
        self._jac = PETSc.Mat().createDense([n, n], comm=PETSc.COMM_SELF)
        self._jac.setUp()
        # Without f_ss lubrication stops a sphere ~1e-11 m from the wall: each contact gap's absolute
        # tolerance is 1e-6 of the others so that the relative one governs down there.
        atol = self._atol = self.y.duplicate()
        atol.set(opts.atol)
        for contact in self.contacts:
            atol.setValue(contact.gap_index, 1e-6 * opts.atol)
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
            f"{prefix}ts_event_post_event_step": 1e-7 * time_unit,
        }
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
        return np.where(self.held, 0.0, np.asarray(y[1:2 * len(self.bodies):2]))

    def _heights(self, y) -> np.ndarray:
        """Each sphere's lowest point above z = 0 [m] from the state's gaps."""
        heights = [y[0]]
        for k in range(1, len(self.bodies)):
            heights.append(heights[-1] + self.bodies[k - 1].diameter + y[2 * k])
        return np.array(heights)

    def _blend(self, h1: float) -> np.ndarray:
        """Each sphere's weight of f_thr in f_sl: 1 without a resolved flow; sphere 1 under the paper's
        blend H(delta); 0 otherwise (the correction)."""
        weights = np.full(len(self.bodies), 0.0 if self.resolved else 1.0)
        if self.resolved and self.uses_theory and self.contact is not None:
            weights[0] = self.contact.blend(h1)
        return weights

    def _terms(self, t: float, y) -> dict:
        """Every force term that does not need the accelerations [N], the added masses C_M,i m_l,i [kg] and
        the pairs' added-mass matrix less the isolated spheres' [kg]."""
        count = len(self.bodies)
        heights = self._heights(y)
        v = np.asarray(y[1:2 * count:2], dtype=float)
        rates = self._rates(y)
        wall_gaps, films = list(heights), [1.0] * count  # to the wall, as each sphere's drag sees it
        wall = self.wall
        if wall is not None:
            wall_gaps[0], films[0] = wall.law.film(y[0], wall.record.engaged_now)
        th = self.theories
        zero = np.zeros(count)
        terms = dict(
            gaps=heights, velocities=v, blend=self._blend(y[0]),
            c_m=np.array([th[k].added_mass(wall_gaps[k])[0] for k in range(count)]),
            drag=np.array([th[k].drag(wall_gaps[k], v[k], films[k]) for k in range(count)]),
            am_velocity=np.array([th[k].added_mass_velocity_term(wall_gaps[k], v[k]) if films[k] == 1.0 else 0.0
                                  for k in range(count)]),  # C_M held inside a Hertz contact
            pair=zero.copy(), elastic=zero.copy(), correction=zero.copy(), correction_mass=zero.copy(),
            pair_mass=np.zeros((count, count)), pair_am_velocity=zero.copy(), history=zero.copy(),
            history_coefficients=[np.zeros(0)] * count,
        )
        pair_films = {}  # lower index -> (the lubrication's gap, the share of it left)
        for contact in self.contacts:
            if contact.lower is None:
                continue
            k, pair, s = contact.lower, contact.model, y[contact.gap_index]
            both = slice(k, k + 2)
            gap, film = pair.law.film(s, contact.record.engaged_now)  # held and fading inside a Hertz contact
            pair_films[k] = (gap, film)
            terms["pair"][both] += pair.interaction(gap, v[both], film)
            if self.resolved:
                terms["correction"][both] += pair.correction(gap, v[both], film)
            else:  # the pair's added mass, held with the film inside a Hertz contact as C_M is
                terms["pair_mass"][both, both] += pair.added_mass(gap)[0]
                if film == 1.0:
                    terms["pair_am_velocity"][both] += pair.added_mass_velocity_term(gap, v[both], contact.rate(rates))
        for k, z in enumerate(self._history_states(y)):
            if len(z):
                c = th[k].history_coefficients(wall_gaps[k], v[k], films[k])
                adjacent = [j for j in (k - 1, k) if j in pair_films]  # the pairs below and above it
                if self._drag_scaled_history and adjacent:  # K_H^(3/2): the wall's lambda plus each pair's X_kk - 1
                    factor = own = th[k].wall_factor(wall_gaps[k], films[k])
                    for j in adjacent:
                        (gap, film), side = pair_films[j], k - j  # side 1: k is the pair's upper sphere
                        factor = factor + film * (self.pairs[j].resistance(gap)[side, side] - 1.0)
                    c = c * factor / own
                terms["history_coefficients"][k] = c
                terms["history"][k] = -float(c @ z)
        for contact in self.contacts:
            engaged = contact.record.engaged_now
            if engaged is not None:
                push = contact.law.force(y[contact.gap_index], contact.rate(rates), engaged)
                if contact.lower is not None:
                    terms["elastic"][contact.lower] -= push
                terms["elastic"][contact.upper] += push
        if self.resolved and self.contact is not None:
            force, mass = self.contact.correction(wall_gaps[0], v[0], films[0])
            terms["correction"][0] += force
            terms["correction_mass"][0] += mass
        return terms

    def _balance(self, t: float, y, terms: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(M, R): the equations of motion read M dV/dt = R (a held or prescribed sphere's row: its
        acceleration).  The theory force weighs `blend` (1 for the ODE model), the resolved flow's 1 - blend."""
        f = terms or self._terms(t, y)
        blend = f["blend"]
        explicit, added_mass = self.fluid.explicit, self.fluid.added_mass  # zero without a resolved flow
        mass = (np.diag(self.masses + blend * f["c_m"] + f["correction_mass"]) + blend[:, None] * f["pair_mass"]
                + (1.0 - blend)[:, None] * added_mass)
        theory = f["drag"] + f["am_velocity"] + f["pair"] + f["pair_am_velocity"] + f["history"]
        rhs = blend * theory + (1.0 - blend) * explicit + f["correction"] + f["elastic"] - self.weights
        for k in np.flatnonzero(~self.free):
            mass[k] = np.eye(len(self.bodies))[k]
            rhs[k] = self.bodies[k].prescribed(t)[1]
        return mass, rhs

    def _residual(self, t: float, y, ydot, terms: dict | None = None) -> np.ndarray:
        count = len(self.bodies)
        mass, rhs = self._balance(t, y, terms)
        rates = self._rates(y)
        out = np.empty(self.n)
        out[0:2 * count:2] = np.asarray(ydot[0:2 * count:2]) - np.diff(rates, prepend=0.0)  # the gaps' rates
        out[1:2 * count:2] = mass @ np.asarray(ydot[1:2 * count:2]) - rhs
        for k, (modes, z) in enumerate(zip(self._mode_slices, self._history_states(y))):
            out[modes] = np.asarray(ydot[modes]) - ydot[2 * k + 1] + z / self.theories[k].history_times[: len(z)]
        return out

    def _ifunction(self, ts, t, y, ydot, f) -> None:
        f.setArray(self._residual(t, y.array_r, ydot.array_r))

    def _ijacobian(self, ts, t, y, ydot, a, A, P) -> bool:
        y, ydot = np.array(y.array_r), np.array(ydot.array_r)
        count, n = len(self.bodies), self.n
        terms = self._terms(t, y)  # at the base state: for its residual and the exact blocks below
        base = self._residual(t, y, ydot, terms)
        jac = np.zeros((n, n))
        lengths = [self.bodies[0].diameter] + [pair.diameter for pair in self.pairs]
        for k in range(2 * count):  # by differences in the gaps and velocities (the gap rows too: they are linear)
            step = 1e-7 * max(abs(y[k]), (lengths[k // 2] if k % 2 == 0 else 1.0) * 1e-3)
            shifted = y.copy()
            shifted[k] += step
            jac[:, k] = (self._residual(t, shifted, ydot) - base) / step
        mass, _ = self._balance(t, y, terms)
        gaps, velocities = np.arange(0, 2 * count, 2), np.arange(1, 2 * count, 2)
        jac[gaps, gaps] += a
        jac[np.ix_(velocities, velocities)] += a * mass
        for k, modes in enumerate(self._mode_slices):  # the history rows and columns, exactly
            if self.free[k]:
                jac[2 * k + 1, modes] = terms["blend"][k] * terms["history_coefficients"][k]
            jac[modes, 2 * k + 1] = -a
            jac[modes, modes] = np.diag(a + 1.0 / self.theories[k].history_times[:self.n_history[k]])
        P.setValues(range(n), range(n), jac.ravel())
        P.assemble()
        if A != P:
            A.assemble()
        return True

    # -- events and records ---------------------------------------------------------------
    def _event_list(self) -> list:
        """(contact, kind, indicator(y) dimensionless, direction, terminate) of each event located."""
        events = []
        vu = self.scene.velocity_unit
        for contact in self.contacts:
            moving = [k for k in (contact.lower, contact.upper) if k is not None and self.free[k]]
            if not moving and contact.lower is None:  # an imposed path that reaches the wall is an error in it
                events.append((contact, "path", lambda y: y[0] / self.bodies[0].diameter, -1, True))
            if not moving:
                continue
            rate = (lambda c: lambda y: c.rate(self._rates(y)))(contact)
            length, law, index = contact.model.diameter, contact.law, contact.gap_index  # D or 2a*

            def at_contact(y, c=contact, rate=rate, length=length, index=index):
                if c.law.ehd and c.record.phase == "rebound":
                    return 1.0  # resumed at h0 after a film collision: the next one starts after the apex
                return (y[index] - c.law.boundary(max(-rate(y), 0.0), c.record.engaged_now)) / length
            events += [
                (contact, "contact", at_contact, 0, law.ehd),  # ehd: h0 ends the solve, advance() jumps
                (contact, "turn", lambda y, rate=rate: rate(y) / vu - self._turning_offset, 0, False),
                (contact, "blend", lambda y, c=contact, i=index, d=length: (y[i] - c.model.blend_gap) / d, 0, False),
                (contact, "penetration", lambda y, i=index, d=length, law=law: (y[i] - law.floor) / d, -1, True),
            ]
        return events

    def _indicators(self, ts, t, y, values) -> None:
        y = y.array_r
        for k, (_, _, indicator, _, _) in enumerate(self._events):
            values[k] = indicator(y)

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
                record.contact_crossing(gap, rate)
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
            state[history] = state[history] * decay + (v_end - v) * taus / duration * (1.0 - decay)
        state[0], state[1] = h_end, v_end
        self.y.setArray(state)
        # A fresh TS: PETSc 3.18's event handler keeps the interval of the terminated event, and a solve
        # resumed at a later time bisected it forever (dt stuck at 3e-9 s, measured).
        old, self.ts = self.ts, self._new_ts()
        old.destroy()
        self.ts.setTime(t_end)
        self.ts.setTimeStep(1e-7 * self.scene.time_unit)
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
            inertia = self.masses + np.array([th.added_mass(h)[0] for th, h in zip(self.theories, self._heights(y))])
            if not all(c.law.resting(y[c.gap_index], c.rate(rates), c.record.engaged, inertia[c.upper:].sum(),
                                     self.weights[c.upper:].sum()) for c in contacts):
                return
            count = len(self.bodies)
            everyone = {1: "the sphere", 2: "both spheres"}.get(count, f"all {count} spheres")
            reason = f"{everyone} came to rest on the wall at t = {t:.6g} s"
        elif all(abs(c.rate(rates)) < self._stall_speed and not c.record.in_contact
                 and y[c.gap_index] < c.model.blend_gap for c in contacts):
            reason = (f"the sphere stalled in the lubrication film at t = {t:.6g} s (gap "
                      f"{y[0] / self.bodies[0].diameter:.3g} D, speed below {STALL_FRACTION:g} of its launch "
                      "speed, no gravity to bring it back)")
        else:
            return
        for c in contacts:
            c.record.rest(t, y[c.gap_index])
        self.stop_reason = reason

    def row(self, t: float, y) -> dict:
        """Every sphere's gap, velocity, acceleration and force terms at one instant [SI], named as the
        trajectory's columns (output.trajectory_columns): one sphere's plain, more with suffixes _1, _2,
        ... and the gaps between neighbours.  f_added_mass holds the pairs' added mass too; f_history is
        in f_theory.  Under fixed or prescribed motion the forces are those along the imposed path."""
        f = self._terms(t, y)
        mass, rhs = self._balance(t, y, f)
        accel = np.linalg.solve(mass, rhs)
        added_mass = -f["c_m"] * accel - f["pair_mass"] @ accel + f["am_velocity"] + f["pair_am_velocity"]
        theory = f["drag"] + f["pair"] + added_mass + f["history"]
        count, blend = len(self.bodies), f["blend"]
        sim = self.fluid.explicit - self.fluid.added_mass @ accel if self.resolved else theory
        correction = f["correction"] - f["correction_mass"] * accel
        per_sphere = dict(gap=f["gaps"], velocity=f["velocities"], acceleration=accel, f_drag=f["drag"],
                          f_history=f["history"], f_pair=f["pair"], f_added_mass=added_mass, f_theory=theory,
                          f_sim=sim, blend=blend, f_liquid=blend * theory + (1.0 - blend) * sim + correction,
                          f_elastic=f["elastic"], f_correction=correction)
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
        return self._heights(self._state())

    @property
    def velocities(self) -> np.ndarray:
        """Each sphere's velocity, positive upward [m/s]."""
        return self._state()[1:2 * len(self.bodies):2].copy()

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
