"""The sphere's equation of motion (paper eq. 4.10), advanced with PETSc TS.

    m_p dV/dt = f_sl + f_ss - (m_p - m_l) g,

with V positive away from the wall, f_sl the near-wall liquid force of the
contact model (contact.py): f_sim plus the unresolved lubrication below delta_sl
(the default), the paper's blend H f_thr + (1 - H) f_sim, or f_thr alone (the ODE
model), and f_ss the contact force (contact.ContactLaw: a damped Hertz contact below
the contact gap h_c, or the paper's spring).  f_thr contains the added mass
-C_M(delta) m_l dV/dt and the history force, which depends on dV/dt through
exponential modes z_i' = dV/dt - z_i / T_i
(theory.history_modes); the modes are carried only where f_thr is used.  A
resolved model hands in its force for the coming fluid step linearised in the
sphere's acceleration, f_sim = explicit - added_mass dV/dt (FluidForce), so the
coupling is implicit and stays stable for light spheres.  Everything is written as one
implicit system G(t, y, y') = 0, y = [h, V, z_1..z_n], for an adaptive
Rosenbrock-W integrator (TSROSW) whose steps sub-cycle inside a fluid step: the
elastic contact lasts tens of microseconds, a fluid step a millisecond.

TS events locate the gap crossing the contact gap (what the contact keeps, h_c or
W_o, is fixed there from the crossing speed) and delta_sl, the minimum gap (impact)
and the apex after a rebound; the run's bookkeeping (bounces.BounceRecord) turns
them into Impact and Rebound records.

contact.model = "ehd": the gap reaching the handover gap h0 on approach ends the TS solve (a terminal
event); the film collision (contact.ContactLaw.collide, fem_bounce.ehd) is solved from (h0, V_in), and the
integration resumes at t + t_c from (h0, +e V_in), or stops with the sphere at rest in the film
(`_film_jump`).  The integrator owns its PETSc objects: destroy() frees them.
"""
from __future__ import annotations

import contextlib
from dataclasses import dataclass
from typing import Callable

import numpy as np
from petsc4py import PETSc

from .bounces import IMPACT_WINDOW, BounceRecord, Impact, Rebound  # noqa: F401 -- the integrator's records
from .contact import ContactModel
from .ehd import FilmError
from .errors import RunDiverged
from .motion import prescribed_velocity, start_velocity
from .scene import Scene



@dataclass(frozen=True)
class FluidForce:
    """A resolved model's force on the sphere over one fluid step [N, kg]:
    f_sim = explicit - added_mass * dV/dt.  For a pair: explicit has one entry per sphere and
    added_mass is the 2 x 2 matrix of f_sim_i = explicit_i - sum_j added_mass_ij dV_j/dt."""

    explicit: float
    added_mass: float = 0.0


STALL_FRACTION = 1e-3  # of the launch speed: a sphere without gravity slower than this in the film has stalled


class PenetrationError(RuntimeError):
    """The sphere went through the wall as far as the contact law can tell (ContactLaw.floor): the
    contact model was overwhelmed."""


def penetration_message(law, what: str, t: float, gap: float, speed: float, materials: str) -> str:
    """What went through what, and the setting that would have stopped it."""
    if law.hertz:
        return (f"{what} at t = {t:.6g} s: the Hertz overlap passed {-law.floor * 1e6:.4g} um, a tenth of the "
                f"(reduced) radius, beyond Hertz's small-strain contact (contact speed {speed:.3g} m/s): the "
                f"solids are too soft for this impact ({materials})")
    return (f"{what} at t = {t:.6g} s (gap {gap:.3g} m, contact speed {speed:.3g} m/s): the paper's spring "
            "e_d W_o F(delta/delta_ss) stores too little energy over delta_ss to stop it; raise contact.delta_ss "
            'or use contact.model = "lubricated-hertz"')


class AdvancingTS:
    """advance() of an integrator that owns a PETSc TS `ts` on its state `y` (the sphere's, the pair's):
    it sets `fluid`, honours `done`, reports the initial row once (`_post_step_initial`) and refuses a
    state that is no longer finite."""

    _film_pending: tuple[float, float] | None = None  # ehd: (t, V) where the gap reached h0 (SphereIntegrator)

    def advance(self, t_end: float, fluid: FluidForce | None = None) -> None:
        """Integrate to t_end (or until the bounce limit), with f_sim linearised as `fluid`.  A solve ended
        by a film collision (contact.model = "ehd", `_film_jump`) resumes after the jump, which may carry
        the time past t_end by the film's collision time."""
        if fluid is not None:
            self.fluid = fluid
        if self.done or t_end <= self.time:
            return
        if self.steps == 0:
            self._post_step_initial()
        while True:
            self.ts.setMaxTime(t_end)
            self.ts.solve(self.y)
            if self._film_pending is None:
                break
            self._film_jump()
            if self.done or self.time >= t_end:
                break
        if not np.all(np.isfinite(self.y.array_r)):
            raise FloatingPointError(f"the state became {self.y.array_r.tolist()} at t = {self.time:.6g} s")


class SphereIntegrator(AdvancingTS):
    """Advances one sphere; the same object serves the ODE, fd, ib and ale models."""

    def __init__(self, scene: Scene, contact: ContactModel | None = None, resolved: bool = False,
                 stop_after_impacts: int = 0):
        self.scene = scene
        self.contact = contact or ContactModel(scene)
        self.law = self.contact.law
        self.theory = self.contact.theory
        self.resolved = resolved  # f_sim comes from a flow solver (else f_sim = f_thr)
        self.uses_theory = not resolved or scene.near_wall_law == "blend"  # f_thr enters the balance
        self.mode = scene.motion.mode
        self.sphere_mass = scene.sphere.mass
        self.weight = (scene.sphere.mass - scene.displaced_mass) * scene.gravity  # net, toward the wall
        self.diameter = scene.sphere.diameter
        self._prescribed = prescribed_velocity(scene)
        self.fluid = FluidForce(0.0, 0.0)
        self.observers: list[Callable[[dict], None]] = []
        # impacts, rebounds, the step log; without gravity a rebound ends where the gap passes delta_sl outward
        self.bounces = BounceRecord(scene, self.contact, stop_after_impacts, separating=scene.gravity == 0.0)
        self.done = False  # the scene's bounce limit (or stop_after_impacts) was reached, or the sphere rests
        self.stop_reason: str | None = None  # why it is done, when not the bounce limit
        # without gravity nothing brings back a sphere the film has stopped: below this speed it has stalled
        self._stall_speed = STALL_FRACTION * scene.launch_speed if scene.gravity == 0.0 else 0.0
        self.steps = 0
        self._build_ts()

    # -- the implicit system ------------------------------------------------------------
    @property
    def n(self) -> int:
        return 2 + (self.theory.n_history if self.uses_theory else 0)

    def _build_ts(self) -> None:
        n = self.n
        self.y = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
        v0 = self._prescribed(0.0)[0] if self.mode != "free" else start_velocity(self.scene)
        self.y.setArray(np.r_[self.scene.initial_gap, v0, np.zeros(n - 2)])
        self._jac = PETSc.Mat().createDense([n, n], comm=PETSc.COMM_SELF)
        self._jac.setUp()
        opts = self.scene.numerics.ode
        # Without f_ss lubrication stops the sphere ~1e-11 m from the wall: the gap's absolute
        # tolerance is 1e-6 of the others so the relative one governs down there.
        atol = self._atol = self.y.duplicate()
        atol.set(opts.atol)
        atol.setValue(0, 1e-6 * opts.atol)
        events = None
        if self.mode == "free":
            # ehd: reaching h0 ends the solve, and advance() replaces the collision by the film's jump
            events = ([0, 0, 0, -1], [self.law.ehd, False, False, True], self._indicators, self._post_event)
        elif self.scene.wall.present:  # an imposed path that reaches the wall is an error in the path
            events = ([-1], [True], self._wall_indicator, self._path_reaches_wall)
        self._events = events
        self.ts = rosw_solver("sphere_", self, atol, self.scene.time_unit, opts.rtol, events)

    def _terms(self, h: float, v: float, z: np.ndarray) -> dict:
        """Every force term that does not need dV/dt [N], and C_M m_l [kg]."""
        th = self.theory
        engaged = self.bounces.engaged_now
        gap, film = self.law.film(h, engaged)  # inside a Hertz contact the film is held at h_c and fades
        terms = dict(
            blend=self._theory_weight(h),
            c_m=th.added_mass(gap)[0],
            drag=th.drag(gap, v, film),
            history=th.history(gap, v, z, film),
            am_velocity=th.added_mass_velocity_term(gap, v) if film == 1.0 else 0.0,  # C_M held inside
            elastic=self.law.force(h, v, engaged) if self.in_contact else 0.0,
        )
        if self.resolved:
            terms["correction"], terms["correction_mass"] = self.contact.correction(gap, v, film)
        else:
            terms["correction"], terms["correction_mass"] = 0.0, 0.0
        return terms

    def _theory_weight(self, h: float) -> float:
        """The weight of f_thr in f_sl: 1 without a resolved flow, H(delta) under the paper's blend."""
        if not self.resolved:
            return 1.0
        return self.contact.blend(h) if self.uses_theory else 0.0

    def _balance(self, t: float, h: float, v: float, z: np.ndarray) -> tuple[float, float]:
        """(M, R): the equation of motion reads M dV/dt = R."""
        if self.mode != "free":
            return 1.0, self._prescribed(t)[1]
        f = self._terms(h, v, z)
        blend = f["blend"]
        fluid = self.fluid if self.resolved else FluidForce(0.0)
        mass = self.sphere_mass + blend * f["c_m"] + (1.0 - blend) * fluid.added_mass
        rhs = blend * (f["drag"] + f["history"] + f["am_velocity"]) + (1.0 - blend) * fluid.explicit
        mass += f["correction_mass"]
        return mass, rhs + f["correction"] + f["elastic"] - self.weight

    def _ifunction(self, ts, t, y, ydot, f) -> None:
        h, v, *z = y.array_r
        hdot, vdot, *zdot = ydot.array_r
        z, zdot = np.asarray(z), np.asarray(zdot)
        mass, rhs = self._balance(t, h, v, z)
        out = np.empty(self.n)
        out[0] = hdot - (0.0 if self.mode == "fixed" else v)
        out[1] = mass * vdot - rhs
        out[2:] = zdot - vdot + z / self.theory.history_times[: len(z)]
        f.setArray(out)

    def _ijacobian(self, ts, t, y, ydot, a, A, P) -> bool:
        h, v, *z = y.array_r
        z = np.asarray(z)
        vdot = ydot.array_r[1]
        n = self.n
        jac = np.zeros((n, n))
        jac[0, 0] = a
        jac[0, 1] = 0.0 if self.mode == "fixed" else -1.0

        def g1(hh, vv, zz):
            mass, rhs = self._balance(t, hh, vv, zz)
            return mass * vdot - rhs

        base = g1(h, v, z)
        mass, _ = self._balance(t, h, v, z)
        dh = 1e-7 * max(abs(h), self.diameter * 1e-3)
        dv = 1e-7 * max(abs(v), 1e-3)
        jac[1, 0] = (g1(h + dh, v, z) - base) / dh
        jac[1, 1] = (g1(h, v + dv, z) - base) / dv + a * mass
        if n > 2:
            if self.mode == "free":
                gap, film = self.law.film(h, self.bounces.engaged_now)
                jac[1, 2:] = self._theory_weight(h) * self.theory.history_coefficients(gap, v, film)
            jac[2:, 1] = -a
            jac[2:, 2:] = np.diag(a + 1.0 / self.theory.history_times)
        P.setValues(range(n), range(n), jac.ravel())
        P.assemble()
        if A != P:
            A.assemble()
        return True

    # -- events and records ---------------------------------------------------------------
    def _indicators(self, ts, t, y, values) -> None:
        h, v = y.array_r[:2]
        if self.law.ehd and self.bounces.phase == "rebound":
            values[0] = 1.0  # resumed at h0 after a film collision: the next one starts after the apex
        else:
            values[0] = (h - self.law.boundary(max(-v, 0.0), self.bounces.engaged_now)) / self.diameter
        values[1] = v / self.scene.velocity_unit
        values[2] = (h - self.contact.blend_gap) / self.diameter
        values[3] = (h - self.law.floor) / self.diameter

    def _post_event(self, ts, events, t, y, forward) -> None:
        h, v = y.array_r[:2]
        for event in events:
            if event == 0 and self.law.ehd:
                if v < 0.0 and self.bounces.phase == "approach":
                    self._film_pending = (t, v)
            elif event == 0:
                self.bounces.contact_crossing(h, v)
            elif event == 1:
                self.bounces.turning_point(t, h)
            elif event == 2:
                self.bounces.blend_crossing(t, v, h)
            else:
                raise PenetrationError(penetration_message(
                    self.law, "the sphere went through the wall", t, h, self.bounces.contact_speed,
                    "sphere.youngs_modulus, wall.youngs_modulus"))

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
        h0, speed = self.law.handover, -v
        mass = self.sphere_mass + self.theory.added_mass(h0)[0]
        try:
            result = self.law.collide(speed, mass, force=-self.weight)
        except FilmError as err:
            raise RunDiverged(f"the film collision (contact.model = \"ehd\") at t = {t:.6g} s, arriving at {speed:.3g} "
                              f"m/s at h0 = {h0 * 1e6:.3g} um, could not be solved: {err}; another "
                              "contact.ehd_handover or contact.model = \"lubricated-hertz\" may run") from None
        t_end, h_end, v_end = self.bounces.film_collision(t, h0, speed, result)
        state = self.y.array.copy()
        if len(state) > 2:
            taus = self.theory.history_times[: len(state) - 2]
            duration = max(t_end - t, 1e-300)
            decay = np.exp(-duration / taus)
            state[2:] = state[2:] * decay + (v_end - v) * taus / duration * (1.0 - decay)
        state[0], state[1] = h_end, v_end
        self.y.setArray(state)
        # A fresh TS: PETSc 3.18's event handler keeps the interval of the terminated event, and a solve
        # resumed at a later time bisected it forever (dt stuck at 3e-9 s, measured).
        old, opts = self.ts, self.scene.numerics.ode
        self.ts = rosw_solver("sphere_", self, self._atol, self.scene.time_unit, opts.rtol, self._events)
        old.destroy()
        self.ts.setTime(t_end)
        self.ts.setTimeStep(1e-7 * self.scene.time_unit)
        if result.outcome != "rebound":
            self.done = True
            self.stop_reason = (f"the sphere came to rest on the wall in the film at t = {t_end:.6g} s (the film "
                                f"collision at {speed:.3g} m/s from h0 = {h0 * 1e6:.3g} um gave no rebound: "
                                f"{result.outcome})")
        elif self.bounces.stop_at <= t_end:
            self.done = True

    def _wall_indicator(self, ts, t, y, values) -> None:
        values[0] = y.array_r[0] / self.diameter

    def _path_reaches_wall(self, ts, events, t, y, forward) -> None:
        motion = self.scene.motion
        path = f"motion.series = {motion.series!r}" if motion.series else f"motion.velocity = {motion.velocity:g} m/s"
        raise PenetrationError(f"the {motion.mode} motion ({path}) drives the sphere into the wall at t = {t:.6g} s: "
                               f"an imposed path must keep the gap above 0 (initial_gap = {self.scene.initial_gap:g} m); "
                               "change the path or end the run earlier (run.end_time)")

    def _post_step(self, ts) -> None:
        t = ts.getTime()
        h, v, *z = ts.getSolution().array_r
        self.steps += 1
        self.bounces.log(t, h, v)
        if self.mode == "free" and self.in_contact and not self.bounces.resting and self.law.resting(
                h, v, self.bounces.engaged, self.sphere_mass + self.theory.added_mass(h)[0], self.weight):
            self.bounces.rest(t, h)
            self.stop_reason = f"the sphere came to rest on the wall at t = {t:.6g} s"
        elif (abs(v) < self._stall_speed and not self.in_contact and h < self.contact.blend_gap
              and not self.bounces.resting):
            self.bounces.rest(t, h)
            self.stop_reason = (f"the sphere stalled in the lubrication film at t = {t:.6g} s (gap "
                                f"{h / self.diameter:.3g} D, speed below {STALL_FRACTION:g} of its launch speed, "
                                "no gravity to bring it back)")
        if self.observers:
            row = self.row(t, h, v, np.asarray(z))
            for observer in self.observers:
                observer(row)
        if t >= self.bounces.stop_at:
            self.done = True
        if self.done:
            ts.setConvergedReason(PETSc.TS.ConvergedReason.CONVERGED_USER)

    def row(self, t: float, h: float, v: float, z: np.ndarray) -> dict:
        """Gap, velocity, acceleration and every force term at one instant [SI].
        Under fixed or prescribed motion the forces are those along the imposed path."""
        mass, rhs = self._balance(t, h, v, z)
        accel = rhs / mass
        f = self._terms(h, v, z)
        added_mass = -f["c_m"] * accel + f["am_velocity"]
        theory = f["drag"] + f["history"] + added_mass
        sim = self.fluid.explicit - self.fluid.added_mass * accel if self.resolved else theory
        correction = f["correction"] - f["correction_mass"] * accel
        blend = f["blend"]
        return dict(t=t, gap=h, velocity=v, acceleration=accel, f_drag=f["drag"], f_history=f["history"],
                    f_added_mass=added_mass, f_theory=theory, f_sim=sim, blend=blend,
                    f_liquid=blend * theory + (1.0 - blend) * sim + correction, f_elastic=f["elastic"],
                    f_correction=correction)

    # -- driving it -----------------------------------------------------------------------------
    @property
    def time(self) -> float:
        return self.ts.getTime() if self.ts is not None else self._final[0]

    @property
    def gap(self) -> float:
        return float(self.y.array_r[0]) if self.ts is not None else self._final[1]

    @property
    def velocity(self) -> float:
        return float(self.y.array_r[1]) if self.ts is not None else self._final[2]

    def current_row(self) -> dict:
        h, v, *z = self.y.array_r
        return self.row(self.time, h, v, np.asarray(z))

    def _post_step_initial(self) -> None:
        """Log and report the initial state as the first row."""
        h, v, *z = self.y.array_r
        self.bounces.log(0.0, h, v, initial=True)
        for observer in self.observers:
            observer(self.row(0.0, h, v, np.asarray(z)))

    def finish(self) -> None:
        """Close the records: 2 ms rebound means, and restitution 0 for an impact that never left contact."""
        self.bounces.finish()

    # -- the records, read through the integrator ---------------------------------------------------
    @property
    def impacts(self) -> list[Impact]:
        return self.bounces.impacts

    @property
    def rebounds(self) -> list[Rebound]:
        return self.bounces.rebounds

    @property
    def blend_crossings(self) -> list[dict]:
        return self.bounces.blend_crossings

    @property
    def in_contact(self) -> bool:
        return self.bounces.in_contact

    def destroy(self) -> None:
        """Free the PETSc objects (the records, and the last state as plain numbers, stay)."""
        if self.ts is None:
            return
        self._final = (self.ts.getTime(), float(self.y.array_r[0]), float(self.y.array_r[1]))
        for obj in (self.ts, self._jac, self._atol, self.y):
            obj.destroy()
        self.ts = None

    # -- checkpoints ----------------------------------------------------------------------------
    def state_dict(self) -> dict:
        state = dict(time=self.time, y=self.y.array_r.tolist(), step_size=self.ts.getTimeStep(),
                     machine={"done": self.done, "steps": self.steps})
        self.bounces.save(state)
        return state

    def load_state_dict(self, state: dict) -> None:
        self.ts.setTime(state["time"])
        self.ts.setTimeStep(state["step_size"])
        self.y.setArray(state["y"])
        machine = dict(state["machine"])
        self.done, self.steps = machine.pop("done"), machine.pop("steps")
        self.bounces.load(state)


def rosw_solver(prefix: str, integrator, atol, time_unit: float, rtol: float, events=None) -> PETSc.TS:
    """The adaptive Rosenbrock-W solver (PETSc TSROSW) of an integrator with `_ifunction`, `_ijacobian`,
    its dense Jacobian `_jac` and `_post_step`: steps from 1e-3 time units, at most 0.02 (options
    PREFIXts_adapt_dt_max ... override), LU on the small system, and `events` = (directions, terminate,
    indicator, post_event) located to 1e-9 (dimensionless indicators)."""
    ts = PETSc.TS().create(comm=PETSc.COMM_SELF)
    ts.setOptionsPrefix(prefix)
    ts.setType(PETSc.TS.Type.ROSW)
    ts.setIFunction(integrator._ifunction, None)
    ts.setIJacobian(integrator._ijacobian, integrator._jac)
    ts.setTolerances(rtol=rtol, atol=atol)
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
    ts.setPostStep(integrator._post_step)
    with _options_for_one_solver(scene_defaults):  # the event handler reads its options when set
        if events is not None:
            ts.setEventHandler(*events)
            ts.setEventTolerances(1e-9)  # dimensionless; 1e-12 made PETSc 3.18 take dt = 0 steps
        ts.setFromOptions()
    return ts


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


