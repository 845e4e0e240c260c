"""Two spheres on the axis (a head-on pair, issue 14), advanced with PETSc TS like one sphere (sphere.py).

Sphere 1 is the lower one (its lowest point h1 above z = 0, where the wall is when wall.present), sphere 2
the second sphere above it; the pair gap s = h2 - h1 - D1 is the distance between the two surfaces.
Velocities are positive upward.  Each free sphere obeys

    m_i dV_i/dt = f_liquid,i + f_elastic,i - (m_i - m_l,i) g,

and the liquid couples them: f_liquid,i = f_sim,i + f_c,i for a resolved flow, whose force comes
linearised in both accelerations, f_sim,i = explicit_i - sum_j added_mass_ij dV_j/dt (FluidForce of
arrays), so the 2 x 2 mass matrix is implicit; without one (the ODE model) f_liquid,i is the theory force
of pair_contact.py and theory.py:

    f_i = -6 pi mu a_i [lambda_i(delta_i) + phi(Re_i) - 1] V_i          its own drag, the wall's excess included
          - 6 pi mu a_i sum_j (X_ij(s) - delta_ij) V_j                   the pair's Stokes interaction
          - C_M,i m_l,i dV_i/dt - (1/2) m_l,i V_i^2 dC_M,i/dh_i          added mass: 1/2 and the wall's image
          - sum_j Mx_ij(s) dV_j/dt + F_v,i                                the pair's added mass (potential flow)
          - 6 pi mu a_i K_i sum_k w_k(Re_i) z_i,k                        history (Mei & Adrian), as one sphere's

with Mx = M(s) - diag(m_l,i / 2) the pair's added-mass matrix less the isolated spheres' (pair_theory,
PairContactModel.added_mass) and F_v its Lagrangian velocity terms; K_i = 1, or with
contact.history_wall_factor = "drag-scaled" lambda_i + X_ii(s) - 1 (the wall's and the pair's excess).
The wall and the pair are added, not solved as three bodies, and each sphere's history sees only its own
velocity (docs/physics.md section 6).  A held ("fixed") or prescribed sphere follows its motion (sphere 1:
scene [motion]; sphere 2: second_sphere.mode and .velocity).

The state is y = [h1, V1, s, V2, z1..., z2...]: the pair gap, not h2, is integrated, so that the relative
tolerance governs it near contact as it governs the wall gap of one sphere (an error of rtol h2 would
exceed the film); z_i are sphere i's history modes, z' = dV_i/dt - z / T_k (theory.history_modes), carried
only without a resolved flow and with contact.history on.

TS events: the pair gap crossing its contact gap (contact.ContactLaw: h_c or delta_ss 2a*, what the contact
keeps fixed from the relative speed there) and delta_sl 2a*, the relative velocity changing sign (the
collision's minimum gap, or the gap's maximum), the pair gap reaching the law's floor (penetration: sphere
2 can never pass sphere 1); and the same for sphere 1 and the wall when the wall is present.  Two
BounceRecords (bounces.py) keep the collisions of the pair and of the wall.
"""
from __future__ import annotations

import dataclasses
import math
from typing import Callable

import numpy as np
from petsc4py import PETSc

from .bounces import BounceRecord
from .contact import ContactModel
from .motion import prescribed_velocity, start_velocities
from .pair_contact import PairContactModel
from .scene import Scene, SceneError
from .sphere import AdvancingTS, FluidForce, PenetrationError, penetration_message, rosw_solver
from .theory import TheoryForces

# The turning-point events watch a rate (in velocity units) minus this offset, not the rate itself: two
# spheres moving together, or one resting on the wall, have a rate of round-off size whose flicker about
# zero made PETSc locate a "turning point" every step until the steps collapsed (a pair creeping together
# in 0.8 Pa s stalled at t = 0.51 s).  A real turning point passes the offset a vanishing time after zero.
TURNING_OFFSET = 1e-9


def sphere_scene(scene: Scene, k: int) -> Scene:
    """The scene as seen by sphere k alone (0: sphere 1, 1: the second sphere): its material as `sphere`,
    its initial gap, no second sphere.  For the per-sphere theory forces; never run or validated."""
    if k == 0:
        return dataclasses.replace(scene, second_sphere=None)
    return dataclasses.replace(scene, sphere=scene.second_sphere, initial_gap=scene.initial_gaps[1],
                               second_sphere=None)


class PairIntegrator(AdvancingTS):
    """Advances a pair of spheres; the same object serves the ODE and the resolved models.  `gap` and
    `velocity` are arrays (sphere 1 first): each sphere's lowest point above z = 0 and its velocity."""

    def __init__(self, scene: Scene, resolved: bool = False, stop_after_impacts: int = 0):
        if not scene.pair:
            raise SceneError("a PairIntegrator needs a pair scene: give [second_sphere]")
        self.scene = scene
        self.resolved = resolved
        self.pair = PairContactModel(scene, resolved)
        self.wall = ContactModel(scene) if scene.wall.present else None
        self.theories = (self.wall.theory if self.wall else TheoryForces(sphere_scene(scene, 0)),
                         TheoryForces(sphere_scene(scene, 1)))
        second = scene.second_sphere
        self.modes = (scene.motion.mode, second.mode)
        self.free = np.array([m == "free" for m in self.modes])
        self.held = np.array([m == "fixed" for m in self.modes])  # its gap does not change
        first_motion = prescribed_velocity(scene)
        self._prescribed = (first_motion, lambda t: (second.velocity if second.mode == "prescribed" else 0.0, 0.0))
        self.diameters = np.array([s.diameter for s in scene.spheres])
        self.masses = np.array([s.mass for s in scene.spheres])
        displaced = np.array([scene.liquid.density * s.volume for s in scene.spheres])
        self.weights = (self.masses - displaced) * scene.gravity  # net, toward z = 0 [N]
        self.fluid = FluidForce(np.zeros(2), np.zeros((2, 2)))
        # the history modes of each sphere (none with a resolved flow: its flow carries the history)
        self.n_history = tuple(0 if resolved else th.n_history for th in self.theories)
        self._drag_scaled_history = scene.contact.history_wall_factor == "drag-scaled"
        self.observers: list[Callable[[dict], None]] = []
        self.pair_record = BounceRecord(scene, self.pair, stop_after_impacts, numbers=self.pair.numbers,
                                        separating=True)
        self.wall_record = BounceRecord(scene, self.wall, stop_after_impacts) if self.wall else None
        self.done = False
        self.stop_reason: str | None = None  # why it is done, when not the collision limit
        self.steps = 0
        self._build_ts()

    @property
    def n(self) -> int:
        return 4 + sum(self.n_history)

    def _history_states(self, y) -> tuple[np.ndarray, np.ndarray]:
        """(z1, z2): each sphere's history modes in the state y."""
        n1 = self.n_history[0]
        return np.asarray(y[4:4 + n1]), np.asarray(y[4 + n1:])

    @property
    def hold_gaps(self) -> tuple[float, float]:
        """(sphere 1's hold above the wall, the pair gap's hold) [m]: delta_sl D1 and delta_sl 2a* under
        contact.near_wall = "correction" with a free sphere, else 0 (flow_model.flow_gaps)."""
        return (self.wall.hold_gap if self.wall else 0.0), self.pair.hold_gap

    # -- the implicit system ------------------------------------------------------------
    def _build_ts(self) -> None:
        scene, opts = self.scene, self.scene.numerics.ode
        v1, v2 = start_velocities(scene)
        v1 = v1 if self.free[0] else self._prescribed[0](0.0)[0]  # a prescribed series' own V(0)
        n = self.n
        self.y = PETSc.Vec().createSeq(n, comm=PETSc.COMM_SELF)
        self.y.setArray(np.r_[scene.initial_gap, v1, scene.second_sphere.gap, v2, np.zeros(n - 4)])
        self._jac = PETSc.Mat().createDense([n, n], comm=PETSc.COMM_SELF)
        self._jac.setUp()
        atol = self._atol = self.y.duplicate()
        atol.set(opts.atol)
        atol.setValue(2, 1e-6 * opts.atol)  # the pair gap: the relative tolerance governs near contact
        if self.wall:
            atol.setValue(0, 1e-6 * opts.atol)
        self._events = self._event_list()
        events = None
        if self._events:
            directions = [direction for _, _, direction, _ in self._events]
            terminal = [terminate for _, _, _, terminate in self._events]
            events = (directions, terminal, self._indicators, self._post_event)
        self.ts = rosw_solver("pair_", self, atol, scene.time_unit, opts.rtol, events)

    def _rates(self, v: np.ndarray) -> np.ndarray:
        """dh_i/dt: a held sphere's gap stays (its surface may still move: motion.mode = "fixed")."""
        return np.where(self.held, 0.0, v)

    def _terms(self, t: float, y) -> dict:
        """Every force term that does not need the accelerations [N], the added masses C_M,i m_l,i [kg] and
        the pair's added-mass matrix less the isolated spheres' [kg]."""
        h1, v1, s, v2 = y[:4]
        gaps = np.array([h1, h1 + self.diameters[0] + s])
        v = np.array([v1, v2])
        rates = self._rates(v)
        pair_engaged = self.pair_record.engaged_now
        pair_gap, pair_film = self.pair.law.film(s, pair_engaged)  # held and fading inside a Hertz contact
        wall_engaged = self.wall_record.engaged_now if self.wall else None
        wall_gap, wall_film = self.wall.law.film(h1, wall_engaged) if self.wall else (h1, 1.0)
        wall_gaps, films = (wall_gap, gaps[1]), (wall_film, 1.0)  # to the wall, as each sphere's drag sees it
        th = self.theories
        terms = dict(
            gaps=gaps, velocities=v, pair_gap=s,
            c_m=np.array([th[k].added_mass(wall_gaps[k])[0] for k in range(2)]),
            drag=np.array([th[k].drag(wall_gaps[k], v[k], films[k]) for k in range(2)]),
            am_velocity=np.array([th[k].added_mass_velocity_term(wall_gaps[k], v[k]) if films[k] == 1.0 else 0.0
                                  for k in range(2)]),  # C_M held inside a Hertz contact
            pair=self.pair.interaction(pair_gap, v, pair_film),
            elastic=np.zeros(2), correction=np.zeros(2), correction_mass=np.zeros(2),
            pair_mass=np.zeros((2, 2)), pair_am_velocity=np.zeros(2), history=np.zeros(2),
            history_coefficients=[np.zeros(0), np.zeros(0)],
        )
        if not self.resolved:  # the pair's added mass, held with the film inside a Hertz contact as C_M is
            terms["pair_mass"] = self.pair.added_mass(pair_gap)[0]
            if pair_film == 1.0:
                terms["pair_am_velocity"] = self.pair.added_mass_velocity_term(pair_gap, v, rates[1] - rates[0])
            for k, z in enumerate(self._history_states(y)):
                if len(z):
                    c = th[k].history_coefficients(wall_gaps[k], v[k], films[k])
                    if self._drag_scaled_history:  # K_H^(3/2): the wall's lambda plus the pair's X_kk - 1
                        wall = th[k].wall_factor(wall_gaps[k], films[k])
                        c = c * (wall + pair_film * (self.pair.resistance(pair_gap)[k, k] - 1.0)) / wall
                    terms["history_coefficients"][k] = c
                    terms["history"][k] = -float(c @ z)
        if pair_engaged is not None:
            push = self.pair.law.force(s, rates[1] - rates[0], pair_engaged)
            terms["elastic"] += (-push, push)
        if wall_engaged is not None:
            terms["elastic"][0] += self.wall.law.force(h1, rates[0], wall_engaged)
        if self.resolved:
            terms["correction"] += self.pair.correction(pair_gap, v, pair_film)
            if self.wall:
                force, mass = self.wall.correction(wall_gap, v1, wall_film)
                terms["correction"][0] += force
                terms["correction_mass"][0] += mass
        return terms

    def _balance(self, t: float, y, terms: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(M, R): the equations of motion read M dV/dt = R (a held or prescribed sphere's row: its
        acceleration)."""
        f = terms or self._terms(t, y)
        if self.resolved:
            mass = np.diag(self.masses + f["correction_mass"]) + np.asarray(self.fluid.added_mass, dtype=float)
            rhs = np.asarray(self.fluid.explicit, dtype=float) + f["correction"]
        else:
            mass = np.diag(self.masses + f["c_m"]) + f["pair_mass"]
            rhs = f["drag"] + f["am_velocity"] + f["pair"] + f["pair_am_velocity"] + f["history"]
        rhs = rhs + f["elastic"] - self.weights
        for k in np.flatnonzero(~self.free):
            mass[k] = np.eye(2)[k]
            rhs[k] = self._prescribed[k](t)[1]
        return mass, rhs

    def _residual(self, t: float, y, ydot) -> np.ndarray:
        mass, rhs = self._balance(t, y)
        rates = self._rates(np.array([y[1], y[3]]))
        force = mass @ np.array([ydot[1], ydot[3]]) - rhs
        out = [np.array([ydot[0] - rates[0], force[0], ydot[2] - (rates[1] - rates[0]), force[1]])]
        for k, (z, zdot) in enumerate(zip(self._history_states(y), self._history_states(ydot))):
            out.append(zdot - ydot[1 + 2 * k] + z / self.theories[k].history_times[: len(z)])
        return np.concatenate(out)

    def _ifunction(self, ts, t, y, ydot, f) -> None:
        f.setArray(self._residual(t, y.array_r, ydot.array_r))

    def _ijacobian(self, ts, t, y, ydot, a, A, P) -> bool:
        y, ydot = np.array(y.array_r), np.array(ydot.array_r)
        base = self._residual(t, y, ydot)
        scales = (self.diameters[0] * 1e-3, 1e-3, self.pair.diameter * 1e-3, 1e-3)
        n = self.n
        jac = np.zeros((n, n))
        for k in range(4):  # d/dy by differences (the rate rows exactly so: they are linear)
            step = 1e-7 * max(abs(y[k]), scales[k])
            shifted = y.copy()
            shifted[k] += step
            jac[:, k] = (self._residual(t, shifted, ydot) - base) / step
        terms = self._terms(t, y)
        mass, _ = self._balance(t, y, terms)
        jac[0, 0] += a
        jac[2, 2] += a
        jac[np.ix_([1, 3], [1, 3])] += a * mass
        start = 4
        for k, count in enumerate(self.n_history):  # the history rows and columns, exactly
            if not count:
                continue
            modes = slice(start, start + count)
            if self.free[k]:
                jac[1 + 2 * k, modes] = terms["history_coefficients"][k]
            jac[modes, 1 + 2 * k] = -a
            jac[modes, modes] = np.diag(a + 1.0 / self.theories[k].history_times[:count])
            start += count
        P.setValues(range(n), range(n), jac.ravel())
        P.assemble()
        if A != P:
            A.assemble()
        return True

    # -- events and records ---------------------------------------------------------------
    def _event_list(self) -> list:
        """(name, indicator(y) dimensionless, direction, terminate) of each event located."""
        if not self.free.any():
            return []
        d1, d_pair, vu = self.diameters[0], self.pair.diameter, self.scene.velocity_unit
        pair_rate = lambda y: float(np.diff(self._rates(np.array([y[1], y[3]])))[0])  # noqa: E731
        wall_rate = lambda y: float(self._rates(np.array([y[1], y[3]]))[0])  # noqa: E731

        def boundary(model, record, rate: float) -> float:
            """Where the contact begins at this approach rate, or ends (ContactLaw.boundary)."""
            return model.law.boundary(max(-rate, 0.0), record.engaged_now)
        events = [
            ("pair_contact", lambda y: (y[2] - boundary(self.pair, self.pair_record, pair_rate(y))) / d_pair, 0, False),
            ("pair_turn", lambda y: pair_rate(y) / vu - TURNING_OFFSET, 0, False),
            ("pair_blend", lambda y: (y[2] - self.pair.blend_gap) / d_pair, 0, False),
            ("pair_penetration", lambda y: (y[2] - self.pair.law.floor) / d_pair, -1, True),
        ]
        if self.wall and self.free[0]:
            events += [
                ("wall_contact", lambda y: (y[0] - boundary(self.wall, self.wall_record, wall_rate(y))) / d1, 0, False),
                ("wall_turn", lambda y: wall_rate(y) / vu - TURNING_OFFSET, 0, False),
                ("wall_blend", lambda y: (y[0] - self.wall.blend_gap) / d1, 0, False),
                ("wall_penetration", lambda y: (y[0] - self.wall.law.floor) / d1, -1, True),
            ]
        return events

    def _indicators(self, ts, t, y, values) -> None:
        y = y.array_r
        for k, (_, indicator, _, _) in enumerate(self._events):
            values[k] = indicator(y)

    def _post_event(self, ts, events, t, y, forward) -> None:
        h1, v1, s, v2 = y.array_r[:4]
        rates = self._rates(np.array([v1, v2]))
        pair_rate = rates[1] - rates[0]
        for event in events:
            name = self._events[event][0]
            if name == "pair_contact":
                self.pair_record.contact_crossing(s, pair_rate)
            elif name == "pair_turn":
                self.pair_record.turning_point(t, s)
            elif name == "pair_blend":
                self.pair_record.blend_crossing(t, pair_rate, s)
            elif name == "wall_contact":
                self.wall_record.contact_crossing(h1, rates[0])
            elif name == "wall_turn":
                self.wall_record.turning_point(t, h1)
            elif name == "wall_blend":
                self.wall_record.blend_crossing(t, rates[0])
            elif name == "pair_penetration":
                raise PenetrationError(penetration_message(
                    self.pair.law, "sphere 2 went through sphere 1", t, s, self.pair_record.contact_speed,
                    "sphere.youngs_modulus, second_sphere.youngs_modulus"))
            else:
                raise PenetrationError(penetration_message(
                    self.wall.law, "sphere 1 went through the wall", t, h1, self.wall_record.contact_speed,
                    "sphere.youngs_modulus, wall.youngs_modulus"))

    def _records(self) -> list[BounceRecord]:
        return [r for r in (self.pair_record, self.wall_record) if r is not None]

    def _log(self, t: float, y, initial: bool = False) -> None:
        h1, v1, s, v2 = y[:4]
        rates = self._rates(np.array([v1, v2]))
        self.pair_record.log(t, s, rates[1] - rates[0], initial=initial)
        if self.wall_record is not None:
            self.wall_record.log(t, h1, rates[0], initial=initial)

    def _post_step(self, ts) -> None:
        t = ts.getTime()
        y = ts.getSolution().array_r
        self.steps += 1
        self._log(t, y)
        if self.observers:
            row = self.row(t, y)
            for observer in self.observers:
                observer(row)
        if self._resting(y):
            self.stop_reason = f"both spheres came to rest on the wall at t = {t:.6g} s"
            self.done = True
        if t >= min(r.stop_at for r in self._records()):
            self.done = True
        if self.done:
            ts.setConvergedReason(PETSc.TS.ConvergedReason.CONVERGED_USER)

    def _resting(self, y) -> bool:
        """A free pair stacked on the wall at rest: each contact, loaded by the net weight above it, passes
        ContactLaw.resting with the kinetic energy of what moves on it (sphere 2 on sphere 1, both on the
        wall)."""
        if not (self.wall and self.free.all() and self.pair_record.in_contact and self.wall_record.in_contact):
            return False
        h1, v1, s, v2 = y[:4]
        return (self.pair.law.resting(s, v2 - v1, self.pair_record.engaged, self.masses[1], self.weights[1])
                and self.wall.law.resting(h1, v1, self.wall_record.engaged, self.masses.sum(), self.weights.sum()))

    def row(self, t: float, y) -> dict:
        """Both spheres' gaps, velocities, accelerations and force terms at one instant [SI]: the
        columns of output.PAIR_TRAJECTORY_COLUMNS (suffix _1: sphere 1, _2: sphere 2).  f_added_mass holds
        the pair's added mass too; the history force has no column of its own: f_theory - f_drag - f_pair -
        f_added_mass."""
        f = self._terms(t, y)
        mass, rhs = self._balance(t, y, f)
        accel = np.linalg.solve(mass, rhs)
        added_mass = -f["c_m"] * accel - f["pair_mass"] @ accel + f["am_velocity"] + f["pair_am_velocity"]
        theory = f["drag"] + f["pair"] + added_mass + f["history"]
        fluid = self.fluid
        sim = (np.asarray(fluid.explicit) - np.asarray(fluid.added_mass) @ accel) if self.resolved else theory
        correction = f["correction"] - f["correction_mass"] * accel
        per_sphere = dict(gap=f["gaps"], velocity=f["velocities"], acceleration=accel, f_drag=f["drag"],
                          f_pair=f["pair"], f_added_mass=added_mass, f_theory=theory, f_sim=sim,
                          f_liquid=sim + correction, f_elastic=f["elastic"], f_correction=correction)
        row = {"t": t, "pair_gap": f["pair_gap"]}
        for name, values in per_sphere.items():
            row[f"{name}_1"], row[f"{name}_2"] = float(values[0]), float(values[1])
        return row

    # -- driving it -----------------------------------------------------------------------------
    def _state(self) -> np.ndarray:
        return np.array(self.y.array_r) if self.ts is not None else self._final

    @property
    def time(self) -> float:
        return self.ts.getTime() if self.ts is not None else self._final_time

    @property
    def gap(self) -> np.ndarray:
        h1, _, s, _ = self._state()[:4]
        return np.array([h1, h1 + self.diameters[0] + s])

    @property
    def velocity(self) -> np.ndarray:
        _, v1, _, v2 = self._state()[:4]
        return np.array([v1, v2])

    @property
    def pair_gap(self) -> float:
        return float(self._state()[2])

    def current_row(self) -> dict:
        return self.row(self.time, self._state())

    def _post_step_initial(self) -> None:
        """Log and report the initial state as the first row (AdvancingTS.advance)."""
        self._log(0.0, self.y.array_r, initial=True)
        for observer in self.observers:
            observer(self.row(0.0, self.y.array_r))

    def finish(self) -> None:
        """Close the records (the rebound means; e = 0 for a collision that never left contact)."""
        for record in self._records():
            record.finish()

    # -- the records ------------------------------------------------------------------------------
    @property
    def impacts(self) -> list:
        """Sphere 1's impacts on the wall (the pair's collisions: `collisions`)."""
        return self.wall_record.impacts if self.wall_record else []

    @property
    def rebounds(self) -> list:
        return self.wall_record.rebounds if self.wall_record else []

    @property
    def blend_crossings(self) -> list[dict]:
        return self.wall_record.blend_crossings if self.wall_record else []

    def collisions(self) -> list[dict]:
        """Every collision, in time order: kind ("pair" or "wall"), time of the minimum gap, min_gap,
        the relative impact speed, Re and St of it, and the restitution e.

        A pair's e and impact speed are taken where the pair gap passes delta_sl 2a* (on the way in, and
        out after the collision): e = separation speed / approach speed there, 0 when the gap does not
        open beyond delta_sl 2a* before the next collision or the end (docs/physics.md section 6: the 2 ms
        means of the wall, also given as *_2ms, lie inside the contact layer at a pendulum's speeds).
        A wall collision's are the wall's 2 ms means (bounces.Rebound).  A pair that comes to rest in
        contact still has minima of its gap; one that did not come in through delta_sl 2a* since the
        previous minimum belongs to the collision before it and is not listed."""
        found = []
        for kind, record in (("pair", self.pair_record), ("wall", self.wall_record)):
            if record is None:
                continue
            for k, impact in enumerate(record.impacts):
                if kind == "pair" and k > 0 and not any(
                        c["direction"] == "in" and record.impacts[k - 1].time < c["time"] <= impact.time
                        for c in record.blend_crossings):
                    continue
                entry = {"kind": kind, **dataclasses.asdict(impact)}
                if k < len(record.rebounds):
                    entry.update(dataclasses.asdict(record.rebounds[k]))
                if kind == "pair":
                    following = record.impacts[k + 1].time if k + 1 < len(record.impacts) else math.inf
                    self._at_blend_gap(entry, record.blend_crossings, following)
                found.append(entry)
        return sorted(found, key=lambda c: c["time"])

    def _at_blend_gap(self, entry: dict, crossings: list[dict], following: float) -> None:
        """Speeds, St, Re and e of a pair collision where its gap passes delta_sl 2a* (collisions)."""
        before = [c for c in crossings if c["direction"] == "in" and c["time"] <= entry["time"]]
        after = [c for c in crossings if c["direction"] == "out" and entry["time"] < c["time"] < following]
        for key in ("impact_speed", "Re", "St", "restitution"):
            entry[f"{key}_2ms"] = entry.get(key)
        if not before:  # it started inside delta_sl 2a*: the 2 ms means stand
            return
        approach = before[-1]["speed"]
        entry["impact_speed"] = approach
        entry["Re"], entry["St"] = self.pair.numbers(approach)
        entry["separation_speed"] = after[0]["speed"] if after else 0.0
        entry["restitution"] = entry["separation_speed"] / approach

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
        for name, record in (("pair", self.pair_record), ("wall", self.wall_record)):
            if record is not None:
                state["records"][name] = {}
                record.save(state["records"][name])
        return state

    def load_state_dict(self, state: dict) -> None:
        self.ts.setTime(state["time"])
        self.ts.setTimeStep(state["step_size"])
        self.y.setArray(state["y"])
        self.done, self.steps = state["machine"]["done"], state["machine"]["steps"]
        for name, record in (("pair", self.pair_record), ("wall", self.wall_record)):
            if record is not None:
                record.load(state["records"][name])
