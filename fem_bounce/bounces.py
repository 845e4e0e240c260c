"""The run's account of the bounces: the sphere integrator's events (the gap crossing the contact gap
and delta_sl, the velocity changing sign) turned into Impact and Rebound records, with the step log the
paper's 2 ms means are taken from, and the list of collisions.  The equations of motion (equations.py) read
only the contact state (in contact? what the contact fixed when it began: contact.ContactLaw.engage) from here.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from .pair_contact import PairContactModel

IMPACT_WINDOW = 2e-3  # s: the paper's impact speed is the mean over the 2 ms before the minimum gap


@dataclass
class Impact:
    time: float  # of the minimum gap [s]
    impact_speed: float  # mean speed over the 2 ms before the minimum gap [m/s]
    peak_speed: float  # largest approach speed since the previous apex [m/s]
    contact_speed: float  # speed when the gap fell to the contact gap [m/s]
    Re: float  # from impact_speed
    St: float  # from impact_speed
    min_gap: float  # [m]; below 0 inside a Hertz contact (the overlap beyond the contact gap); ehd: the
    #                 film's smallest thickness anywhere over the collision (> 0)
    contact_gap: float = 0.0  # where the contact began: h_c (lubricated-hertz), delta_ss D (li2011), h0 (ehd) [m]
    film_time: float | None = None  # ehd: the film collision's duration t_c, h0 back to h0 (or to rest) [s]
    film_restitution: float | None = None  # ehd: V_out / V_in of the film collision at h0 (0: no rebound)
    film_outcome: str | None = None  # ehd: "rebound", "stopped" or "held" (fem_bounce.ehd.FilmResult.outcome)


@dataclass
class Rebound:
    """What follows an impact.  `restitution` compares like with like as a camera sees it:
    rebound_speed (mean over the 2 ms after the minimum gap) / impact_speed (mean over the
    2 ms before it, as the paper's Table 2), and 0 when the sphere did not rebound: its apex
    stayed below contact.REBOUND_MIN_APEX of the gap scale (or it never left contact).
    `peak_restitution` is the ratio of the peak speeds, after leaving contact and on approach."""

    restitution: float  # 0: no rebound
    rebound_speed: float  # mean over the 2 ms after the minimum gap [m/s], >= 0
    peak_rebound_speed: float  # largest speed away from the wall after the impact [m/s]
    peak_restitution: float
    apex_gap: float | None  # [m]; None when the sphere never left contact
    apex_time: float | None  # [s]
    rebounded: bool = False  # the apex rose above the contact layer (see restitution)


class BounceRecord:
    """A small state machine over the events: approach -> (contact) -> impact at the minimum gap ->
    rebound -> apex -> approach ...  PETSc may report one crossing more than once; the phases make that
    harmless.  `stop_at` is when the run may stop: the bounce limit's apex plus the rebound's 2 ms window.

    The gap h and its rate v = dh/dt are a sphere's to the wall, or a pair's (fem_bounce.integrator: the gap
    between the two surfaces and the relative velocity), with `numbers(speed) -> (Re, St)` of an impact.
    `separating` (a pair, which gravity need not bring back): a rebound also ends when the gap passes
    the contact model's blend gap (delta_sl) outward, and a rebound still opening at the end counts with
    its last gap."""

    STATE = ("in_contact", "engaged", "_contact_speed", "_phase", "_entered_contact", "_left_contact",
             "_peak_speed", "_rebound_speed", "stop_at")

    def __init__(self, scene, contact, stop_after_impacts: int = 0, numbers=None, separating: bool = False):
        self.scene, self.contact = scene, contact
        self.numbers = numbers or (lambda speed: (scene.reynolds(speed), scene.stokes(speed)))
        self.separating = separating
        self.stop_after_impacts = stop_after_impacts
        self.stop_at = math.inf
        self.impacts: list[Impact] = []
        self.rebounds: list[Rebound] = []
        self.blend_crossings: list[dict] = []  # the gap passing delta_sl: time, "in"/"out", speed
        self.in_contact = False
        self.engaged = 0.0  # what the current contact fixed when it began: W_o [N] or h_c [m]
        self.resting = False  # came to rest in a contact (contact.ContactLaw.resting)
        self._contact_speed = 0.0
        self._phase = "approach"  # or "rebound"
        self._entered_contact = False  # during this approach
        self._left_contact = False  # since the last impact
        self._peak_speed = 0.0
        self._rebound_speed = 0.0
        self._log_t: list[float] = []
        self._log_h: list[float] = []
        self._log_v: list[float] = []

    def log(self, t: float, h: float, v: float, initial: bool = False) -> None:
        """One integrator step's end state (or the initial state) [s, m, m/s]."""
        self._log_t.append(t)
        self._log_h.append(h)
        self._log_v.append(v)
        if initial:
            return
        if self._phase == "approach":
            self._peak_speed = max(self._peak_speed, -v)
        else:
            self._rebound_speed = max(self._rebound_speed, v)

    # -- events -------------------------------------------------------------------------------------
    def contact_crossing(self, h: float, v: float, landing: bool = False) -> None:
        """The gap crossing the contact gap; `landing`: the sphere settles into the contact rather than strikes
        it (contact.ContactLaw.landing), which makes no impact."""
        if not self.in_contact and v < 0.0:
            self.in_contact = True
            self._entered_contact = self._entered_contact or not landing
            self._contact_speed = -v
            self.engaged = self.contact.law.engage(-v)
        elif self.in_contact and v > 0.0:
            self.in_contact = False
            self._left_contact = True

    def blend_crossing(self, t: float, v: float, h: float | None = None) -> None:
        """The gap passing delta_sl, where f_thr and f_sim weigh equally (recorded once per crossing);
        for a `separating` record, passing it outward after an impact ends the rebound there."""
        direction = "in" if v < 0.0 else "out"
        if not self.blend_crossings or self.blend_crossings[-1]["direction"] != direction:
            self.blend_crossings.append({"time": t, "direction": direction, "speed": abs(v)})
        if self.separating and direction == "out" and self._phase == "rebound" and self._left_contact:
            self._end_rebound(t, h)

    def turning_point(self, t: float, h: float) -> None:
        """A sign change of V: the minimum gap of an impact, or the apex of a rebound."""
        if self._phase == "approach" and self._entered_contact:
            self._impact(t, self._peak_speed, min_gap=h, contact_gap=self.contact.law.boundary(self._contact_speed))
            self._phase, self._left_contact, self._rebound_speed = "rebound", False, 0.0
        elif self._phase == "rebound" and self._left_contact:
            self._end_rebound(t, h)

    def film_collision(self, t: float, h0: float, speed: float, result) -> tuple[float, float, float]:
        """contact.model = "ehd": the film collision (fem_bounce.ehd.FilmResult, lengths in h0, times in
        h0 / speed) of a sphere that reached the handover gap `h0` [m] at time `t` [s] approaching at
        `speed` [m/s].  Its path goes into the step log (the 2 ms means see it), the impact is recorded at
        the film's turning point, and the rebound starts at h0 with e * speed; without a rebound the sphere
        rests.  Returns (time, gap, velocity) [s, m, m/s] where the integrator continues."""
        time_unit = h0 / speed
        end = result.end_time
        keep = result.time < end
        times = t + result.time[keep] * time_unit
        for tk, xk, vk in zip(times[1:], result.separation[keep][1:], result.velocity[keep][1:]):
            self.log(float(tk), float(xk) * h0, float(vk) * speed)
        rebound = result.outcome == "rebound"
        t_end = t + end * time_unit
        h_end, v_end = (h0, result.restitution * speed) if rebound else (float(result.separation[-1]) * h0, 0.0)
        turn = np.flatnonzero(result.velocity >= 0.0)
        t_turn = t + float(result.time[turn[0]] if turn.size else end) * time_unit
        self.log(t_end, h_end, v_end, initial=True)  # the resumed state; the peak speeds are set below
        self._entered_contact = True
        self._contact_speed = speed
        self._impact(t_turn, max(self._peak_speed, speed), min_gap=float(result.min_gap) * h0, contact_gap=h0,
                     film_time=end * time_unit, film_restitution=float(result.restitution) if rebound else 0.0,
                     film_outcome=result.outcome)
        self._phase, self._rebound_speed, self._left_contact = "rebound", v_end, rebound
        if not rebound:
            self.resting = True
            self.stop_at = t_end
        return t_end, h_end, v_end

    def _impact(self, t: float, peak_speed: float, **details) -> None:
        """Record the impact whose minimum gap is at t [s], its speed the 2 ms mean before it (Impact's
        fields `details`); the run may stop there after stop_after_impacts impacts."""
        impact_speed = self._mean_speed_before(t)
        reynolds, stokes = self.numbers(impact_speed)
        self.impacts.append(Impact(time=t, impact_speed=impact_speed, peak_speed=peak_speed,
                                   contact_speed=self._contact_speed, Re=reynolds, St=stokes, **details))
        if self.stop_after_impacts and len(self.impacts) >= self.stop_after_impacts:
            self.stop_at = t

    @property
    def phase(self) -> str:
        """"approach" (towards the next impact) or "rebound" (after an impact, until the apex)."""
        return self._phase

    @property
    def engaged_now(self) -> float | None:
        """What the contact in progress fixed when it began (ContactLaw.engage), None outside a contact."""
        return self.engaged if self.in_contact else None

    @property
    def contact_speed(self) -> float:
        """The approach speed where the current (or last) contact began [m/s]."""
        return self._contact_speed

    def rest(self, t: float, h: float) -> None:
        """The sphere came to rest in the contact: the impact it made (at rest now if it never turned) has
        no rebound, and the run may stop."""
        if self._phase == "approach" and self._entered_contact:
            self.turning_point(t, h)
        self.resting = True
        self.stop_at = t

    def _end_rebound(self, t: float, h: float) -> None:
        """The rebound's apex (or a pair's separation) at (t, h): the next approach begins."""
        self.rebounds.append(self._rebound(apex_gap=h, apex_time=t))
        self._phase, self._entered_contact, self._peak_speed = "approach", False, 0.0
        self.stop_at = min(self.stop_at, self._limit_stop())

    def _limit_stop(self) -> float:
        """When the scene's limits stop the run [s]: the bounce limit's last impact plus the rebound's 2 ms window,
        or stop_after_impacts' last impact; infinity while neither is reached."""
        stops, bounces, impacts = [math.inf], self.scene.run.bounces, self.stop_after_impacts
        if bounces and len(self.rebounds) >= bounces:
            stops.append(self.impacts[bounces - 1].time + IMPACT_WINDOW)  # complete the rebound's 2 ms window
        if impacts and len(self.impacts) >= impacts:
            stops.append(self.impacts[impacts - 1].time)
        return min(stops)

    def _rebound(self, apex_gap: float | None, apex_time: float | None) -> Rebound:
        impact = self.impacts[-1]
        return Rebound(restitution=0.0, rebound_speed=0.0, peak_rebound_speed=self._rebound_speed,
                       peak_restitution=self._rebound_speed / impact.peak_speed, apex_gap=apex_gap,
                       apex_time=apex_time)

    def _gap_at(self, t: float) -> float:
        return _hermite(self._log_t, self._log_h, self._log_v, t)

    def _mean_speed_before(self, t: float) -> float:
        """(h(t - 2 ms) - h(t)) / 2 ms from the step log (cubic Hermite between steps)."""
        t0 = max(t - IMPACT_WINDOW, self._log_t[0])
        return (self._gap_at(t0) - self._gap_at(t)) / max(t - t0, 1e-300)

    def finish(self) -> None:
        """Close the records: 2 ms rebound means, and restitution 0 for an impact that never left contact."""
        if len(self.rebounds) < len(self.impacts) and not self._left_contact:
            self.rebounds.append(self._rebound(None, None))
        elif len(self.rebounds) < len(self.impacts) and self.separating:  # still opening: its last gap
            self.rebounds.append(self._rebound(self._log_h[-1], None))
        min_apex = self.contact.law.rebound_apex
        for impact, rebound in zip(self.impacts, self.rebounds):
            if rebound.apex_gap is None:
                continue
            t1 = min(impact.time + IMPACT_WINDOW, self._log_t[-1])
            # a film collision's min_gap is the film's thickness, not the separation at the turning point
            start = impact.min_gap if impact.film_time is None else self._gap_at(impact.time)
            speed = max((self._gap_at(t1) - start) / max(t1 - impact.time, 1e-300), 0.0)
            rebound.rebound_speed = speed
            rebound.rebounded = bool(rebound.apex_gap > min_apex)
            rebound.restitution = speed / impact.impact_speed if rebound.rebounded else 0.0

    # -- checkpoints --------------------------------------------------------------------------------
    def save(self, state: dict) -> None:
        """Into an integrator's checkpoint state (its keys kept from before the split)."""
        machine = state.setdefault("machine", {})
        machine.update({("_stop_at" if k == "stop_at" else k): getattr(self, k) for k in self.STATE})
        state.update(log=[self._log_t, self._log_h, self._log_v],
                     impacts=[dataclasses.asdict(i) for i in self.impacts],
                     rebounds=[dataclasses.asdict(r) for r in self.rebounds],
                     blend_crossings=self.blend_crossings)

    def load(self, state: dict) -> None:
        for key in self.STATE:
            setattr(self, key, state["machine"]["_stop_at" if key == "stop_at" else key])
        self._log_t, self._log_h, self._log_v = (list(x) for x in state["log"])
        self.impacts = [Impact(**i) for i in state["impacts"]]
        self.rebounds = [Rebound(**r) for r in state["rebounds"]]
        self.blend_crossings = list(state["blend_crossings"])
        if not self.resting:  # a restart may change run.bounces: the limit is this scene's, not the checkpoint's
            self.stop_at = self._limit_stop()


def _hermite(ts: list[float], hs: list[float], vs: list[float], t: float) -> float:
    """Gap at time t, cubic Hermite between logged steps (h and dh/dt = V are both known)."""
    if len(ts) == 1:
        return hs[0]
    k = int(np.clip(np.searchsorted(ts, t) - 1, 0, len(ts) - 2))
    t0, t1 = ts[k], ts[k + 1]
    dt = t1 - t0
    if dt <= 0.0:
        return hs[k + 1]
    s = (t - t0) / dt
    h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
    return h00 * hs[k] + h10 * dt * vs[k] + h01 * hs[k + 1] + h11 * dt * vs[k + 1]


# -- a checkpoint's record, checked before a restart loads it ------------------------------------------


def _kind_error(value, kind: str) -> str | None:
    """What is wrong with a saved value of the annotated `kind` ("float", "float | None", "bool", "str | None",
    or the allowed words joined by "|" in quotes), or None."""
    if value is None and kind.endswith("| None"):
        return None
    if kind == "bool":
        return None if isinstance(value, bool) else "is not true or false"
    if kind.startswith("str"):
        return None if isinstance(value, str) else "is not a text"
    if kind.startswith('"'):
        words = [word.strip(' "') for word in kind.split("|")]
        return None if value in words else f"is not one of {', '.join(words)}"
    number = isinstance(value, (int, float)) and not isinstance(value, bool) and not math.isnan(value)
    return None if number and (math.isfinite(value) or kind == "time") else "is not a finite number"


# BounceRecord.STATE's kinds, as saved under "machine" (stop_at: a time, or infinity while nothing stops the run)
_MACHINE = {"in_contact": "bool", "engaged": "float", "_contact_speed": "float", "_phase": '"approach" | "rebound"',
            "_entered_contact": "bool", "_left_contact": "bool", "_peak_speed": "float", "_rebound_speed": "float",
            "_stop_at": "time"}
_CROSSING = {"time": "float", "direction": '"in" | "out"', "speed": "float"}


def state_error(state: dict) -> tuple[str, str] | None:
    """What is wrong with a checkpoint's record of one contact (BounceRecord.save's state), as (entry, what), or
    None: every field's type and allowed values, checked before a restart loads it."""
    machine, log = state.get("machine"), state.get("log")
    if not isinstance(machine, dict):
        return "machine", "is not a table"
    for key, kind in _MACHINE.items():
        if (wrong := _kind_error(machine.get(key), kind)) is not None:
            return f"machine.{key}", f"= {machine.get(key)!r} {wrong}"
    if not (isinstance(log, list) and len(log) == 3 and all(isinstance(column, list) for column in log)
            and len({len(column) for column in log}) == 1
            and all(_kind_error(value, "float") is None for column in log for value in column)):
        return "log", "is not three columns of finite numbers (times, gaps, rates)"
    outcomes = '"rebound" | "stopped" | "held" | None'  # fem_bounce.ehd.FilmResult.outcome
    tables = {"impacts": {**{f.name: f.type for f in dataclasses.fields(Impact)}, "film_outcome": outcomes},
              "rebounds": {f.name: f.type for f in dataclasses.fields(Rebound)}, "blend_crossings": _CROSSING}
    for entry, kinds in tables.items():
        rows = state.get(entry)
        if not (isinstance(rows, list) and all(isinstance(row, dict) and set(row) == set(kinds) for row in rows)):
            return entry, f"is not a list of tables of {', '.join(kinds)}"
        for k, row in enumerate(rows):
            for key, kind in kinds.items():
                if (wrong := _kind_error(row[key], kind)) is not None:
                    return f"{entry}[{k}].{key}", f"= {row[key]!r} {wrong}"
    return None


def collisions(contacts) -> list[dict]:
    """Every collision, in time order: kind (the contact's name: "pair" or "wall"; "pair_12", ... for
    three spheres or more), time of the minimum gap, min_gap, the relative impact speed, Re and St of
    it, and the restitution e.

    A pair's e and impact speed are taken where the pair gap passes delta_sl 2a* (on the way in, and
    out after the collision): e = separation speed / approach speed there, 0 when the gap does not
    open beyond delta_sl 2a* before the next collision or the end (docs/physics.md section 6: the 2 ms
    means of the wall, also given as *_2ms, lie inside the contact layer at a pendulum's speeds).
    A wall collision's are the wall's 2 ms means (bounces.Rebound).  A pair that comes to rest in
    contact still has minima of its gap; one that did not come in through delta_sl 2a* since the
    previous minimum belongs to the collision before it and is not listed.  `contacts`: the
    integrator's (equations.Contact), each with its record, model, name and `lower` body."""
    found = []
    for contact in contacts:
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
