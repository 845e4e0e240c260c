"""Where a collision's momentum goes: the impulse of every force on the sphere, phase by phase.

For each impact of a sphere on the wall the trajectory (trajectory.csv's rows, one per integrator step) is
cut into three phases by the gap:

    approach   from the gap passing contact.delta_sl D inward to the gap reaching the contact gap h_c,
    contact    from h_c inward to h_c outward (the Hertz contact, the paper's spring, or the film collision),
    rebound    from h_c outward to delta_sl D outward (or to the apex, if the sphere does not get that far),

and each force's impulse over a phase, int f dt [N s] (positive away from the wall, like every force of the
package), is the trapezoidal sum over the rows, the phase's ends interpolated.  The forces are the terms
of the sphere's equation of motion, m_p dV/dt = f_liquid + f_elastic - (m_p - m_l) g (docs/physics.md):

    drag          the free sphere's quasi-steady drag (with its finite-Re factor)
    lubrication   the wall's excess over it (Brenner's lambda - 1; with the liquid's tension limit on rebound)
    history       the Mei & Adrian history force
    added_mass    the liquid's inertia (C_M m_l dV/dt and the closing gap's velocity term)
    resolved_flow a resolved model's force from its flow (fd, ib, ale; held at delta_sl near the wall)
    correction    what a resolved model adds below the hold (the lubrication and added mass the mesh misses)
    contact       the elastic contact force
    weight        the weight less the buoyancy

(the theory terms weighed by the paper's blend where it is used).  Their sum over the three phases is the
sphere's momentum change, m_p (V_out + V_in) for a sphere that arrives at V_in and leaves at V_out:
`imbalance` reports how far the trapezoidal sums are from it, over m_p V_peak (a measure of the audit's own
accuracy; it grows when numerics.ode.output_interval thins the rows).  Shares are impulses over the
momentum the sphere brought in, m_p V_peak, V_peak its fastest approach in the approach phase (its speed
at delta_sl D, or a little more where the approach still accelerates there).  An approach that starts
from an apex below delta_sl D starts there.

An oblique collision (the ode model's, fem_bounce.oblique) adds to each audit `tangential`, the energy of the
motion along the wall and of the spin, E = (m_p + m_l / 2) U^2 / 2 + I Omega^2 / 2 (I = (2/5) m_p a^2; the
added mass along the wall is the model's), over the same three phases: the work [J] of each term of the
tangential equations (oblique.TangentialMotion), the trapezoidal sum of its power over the rows,

    film_force    the wall's film along the wall: (F_liquid - F_free) U, the resistance R(h) less the free sphere's
    film_torque   its torque: (T_liquid - T_free) Omega
    far_field     the free sphere's drag and torque: F_free U + T_free Omega, F_free = -3 pi mu D phi(Re_t) U,
                  T_free = -8 pi mu a^3 Omega
    weight        the weight less the buoyancy along an inclined wall, (m_p - m_l) g sin(theta) U
    sliding       minus the power the contact dissipates while it slides (Coulomb's mu F_n on the slip the
                  spring does not take; tangential_contact.TangentialContact.energy)
    sticking      minus the power it dissipates while it sticks (the damper, and the spring's rescaling as the
                  stiffness changes)
    spring        minus the change of the Mindlin spring's stored energy k_t xi^2 / 2 (zero once the contact
                  has ended: k_t falls to zero with the overlap)

sliding + sticking + spring is the friction's work on the sphere, int F_friction (U - a Omega) dt: each step's
loss in the contact is that work less the spring's gain, shared between sliding and sticking as the rows'
dissipation rates share it (`contact_losses`).  The sum of the terms over the phases is the change of E:
`imbalance` is the trapezoidal sums' miss of it, over the energy brought in along the wall, E at the approach's
start (`energy_in`; half m_p V_peak^2 for a sphere that brings none), the denominator of the shares too; the
peak of the spring's stored energy in the contact is `spring_peak` [J].

An impact that cannot be audited gets, instead of `losses`, the reason as `losses_skipped`: a release inside
delta_sl D (no approach phase), rows that never reach the contact gap, or sums that miss the momentum change
by more than AUDIT_TOLERANCE (rows too far apart to resolve the contact: numerics.ode.output_interval).
"""
from __future__ import annotations


import math
from dataclasses import dataclass

import numpy as np

from .oblique import ADDED_MASS, INERTIA_FACTOR

PHASES = ("approach", "contact", "rebound")
# Of m_p V_peak: the shares are read to a few per cent of the momentum (docs/losses.md's tables), so an audit
# whose sums miss the momentum change by more than this cannot place the losses; every step's rows give 4e-4
# (ode) to 4e-3 (ale) on case 3.
AUDIT_TOLERANCE = 0.05
TERMS = ("drag", "lubrication", "history", "added_mass", "lift", "resolved_flow", "correction", "contact", "weight")


def force_terms(trajectory: dict, net_weight: float) -> dict[str, np.ndarray]:
    """The audit's terms [N] at every row of one sphere's trajectory columns (module docstring)."""
    blend = trajectory["blend"]
    lubrication = trajectory.get("f_lubrication", np.zeros_like(blend))
    return {"drag": blend * (trajectory["f_drag"] - lubrication), "lubrication": blend * lubrication,
            "history": blend * trajectory["f_history"], "added_mass": blend * trajectory["f_added_mass"],
            "lift": blend * trajectory.get("f_lift", np.zeros_like(blend)),
            "resolved_flow": (1.0 - blend) * trajectory["f_sim"], "correction": trajectory["f_correction"],
            "contact": trajectory["f_elastic"], "weight": np.full_like(blend, -net_weight)}


TANGENTIAL_TERMS = ("film_force", "film_torque", "far_field", "weight", "sliding", "sticking", "spring")


@dataclass(frozen=True)
class AlongWall:
    """What the tangential audit needs of the sphere: its mass along the wall (with the added mass, for the ode
    model's theory forces) [kg], its moment of inertia [kg m^2], radius [m] and the net weight's part along the
    wall [N]."""
    mass: float
    inertia: float
    radius: float
    weight: float


def tangential_powers(trajectory: dict, along: AlongWall) -> dict[str, np.ndarray]:
    """The power [W] of the liquid's and the weight's tangential terms at every row (module docstring), and the
    friction's (`friction`, which the contact's terms split), from the trajectory's oblique columns."""
    velocity, spin = trajectory["tangential_velocity"], trajectory["spin"]
    drag, torque = trajectory["f_tangential_drag"], trajectory["torque_drag"]
    return {"film_force": (trajectory["f_tangential_liquid"] - drag) * velocity,
            "film_torque": (trajectory["torque_liquid"] - torque) * spin,
            "far_field": drag * velocity + torque * spin, "weight": along.weight * velocity,
            "friction": trajectory["f_friction"] * (velocity - along.radius * spin)}


def contact_losses(t: np.ndarray, friction: np.ndarray, stored: np.ndarray, sliding: np.ndarray,
                   sticking: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The energy [J] the contact has dissipated sliding and sticking by each row, from the friction's power on
    the sphere, the spring's stored energy and the dissipation rates the rows give [W, J, W, W] (module
    docstring): each step's loss is the friction's work less the spring's gain (trapezoidal; both continuous),
    shared as the trapezoidal sums of the two rates share it.  Summed directly the rates would miss it where
    the contact switches between sticking and sliding within a step: the rate jumps there (a sliding contact
    dissipates what a sticking one stores), by the jump times the step."""
    steps = np.diff(t)
    lost = -0.5 * (friction[1:] + friction[:-1]) * steps - np.diff(stored)
    slid = 0.5 * (sliding[1:] + sliding[:-1]) * steps
    both = slid + 0.5 * (sticking[1:] + sticking[:-1]) * steps
    share = np.divide(slid, both, out=np.zeros_like(both), where=both > 0.0)
    return np.r_[0.0, np.cumsum(lost * share)], np.r_[0.0, np.cumsum(lost * (1.0 - share))]


def tangential_audit(trajectory: dict, along: AlongWall, bounds: list[float], powers: dict[str, np.ndarray],
                     normal_energy: float) -> dict:
    """The energy audit along the wall over the phases between `bounds` (module docstring); `normal_energy`
    m_p V_peak^2 / 2, the reference when the sphere brings no energy along the wall."""
    t = trajectory["t"]
    energy = 0.5 * (along.mass * trajectory["tangential_velocity"]**2 + along.inertia * trajectory["spin"]**2)
    phases = list(zip(bounds[:-1], bounds[1:]))

    def change(values: np.ndarray) -> list[float]:  # over each phase, of a quantity given at the rows
        at = [float(np.interp(b, t, values)) for b in bounds]
        return [after - before for before, after in zip(at[:-1], at[1:])]

    work = {name: [impulse(t, powers[name], a, b) for a, b in phases] for name in TANGENTIAL_TERMS[:4]}
    slid, stuck = contact_losses(t, powers["friction"], trajectory["spring_energy"],
                                 trajectory["dissipation_sliding"], trajectory["dissipation_sticking"])
    work["sliding"] = [-value for value in change(slid)]
    work["sticking"] = [-value for value in change(stuck)]
    work["spring"] = [-value for value in change(trajectory["spring_energy"])]
    kinetic = [float(np.interp(b, t, energy)) for b in bounds]
    reference = kinetic[0] if kinetic[0] > 0.0 else normal_energy
    inside = (t >= bounds[1]) & (t <= bounds[2])
    total = sum(sum(values) for values in work.values())
    return {"energy_in": reference, "kinetic": dict(zip(("start", "contact_in", "contact_out", "end"), kinetic)),
            "work": work, "share": {name: [value / reference for value in values] for name, values in work.items()},
            "spring_peak": float(trajectory["spring_energy"][inside].max()) if inside.any() else 0.0,
            "imbalance": (total - (kinetic[-1] - kinetic[0])) / reference}


def _at_level(t: np.ndarray, gap: np.ndarray, level: float, k: int) -> float:
    """When the gap passes `level` between rows k and k + 1, interpolated linearly."""
    return float(t[k] + (level - gap[k]) * (t[k + 1] - t[k]) / (gap[k + 1] - gap[k]))


def _crossing(t: np.ndarray, gap: np.ndarray, level: float, start: int, stop: int, inward: bool) -> float | None:
    """The first time in rows [start, stop) that the gap passes `level` inward (or outward), interpolated."""
    # outward, a run that stops where the gap reaches the level (a sweep's rebound) ends on it: it counts
    above = gap[start:stop] > level if inward else gap[start:stop] >= level * (1.0 - 1e-9)
    change = np.flatnonzero(above[:-1] & ~above[1:]) if inward else np.flatnonzero(~above[:-1] & above[1:])
    return _at_level(t, gap, level, start + int(change[0])) if change.size else None


def _last_crossing_in(t: np.ndarray, gap: np.ndarray, level: float, start: int, stop: int) -> float | None:
    """The last time in rows [start, stop] that the gap passes `level` inward, interpolated."""
    above = gap[start:stop + 1] > level
    change = np.flatnonzero(above[:-1] & ~above[1:])
    return _at_level(t, gap, level, start + int(change[-1])) if change.size else None


def impulse(t: np.ndarray, force: np.ndarray, start: float, end: float) -> float:
    """int_start^end force dt [N s]: the trapezoidal rule on the rows, the force interpolated linearly at the
    two ends."""
    if end <= start:
        return 0.0
    inside = (t > start) & (t < end)
    times = np.concatenate(([start], t[inside], [end]))
    values = np.interp(times, t, force)
    return float(np.sum(0.5 * (values[1:] + values[:-1]) * np.diff(times)))


def _apex(t: np.ndarray, velocity: np.ndarray, turn: int, stop: int) -> float:
    """The first time after row `turn` that a rising sphere stops rising (the last row if it never does)."""
    rising = np.flatnonzero(velocity[turn:stop] > 0.0)
    if rising.size:
        falling = np.flatnonzero(velocity[turn + rising[0]:stop] <= 0.0)
        if falling.size:
            return float(t[turn + rising[0] + falling[0]])
    return float(t[stop - 1])


def collision_losses(trajectory: dict, impacts: list[dict], mass: float, net_weight: float,
                     blend_gap: float, along: AlongWall | None = None) -> list[dict | str]:
    """The audit of every impact (`impacts`: summary.json's records, each with its time and contact_gap),
    from one sphere's trajectory columns (arrays), its mass m_p [kg], net weight on the wall's normal
    (m_p - m_l) g cos(theta) [N] and the phases' outer gap delta_sl D [m]; for an impact that cannot be
    audited, the reason (module docstring).  A film collision (contact.model = "ehd") is a jump of the
    integrator across the contact, between the rows of the handover and of the resumed state: its impulse is
    the momentum change across it, under the name "film".  With `along` (an oblique collision's sphere) each
    audit has the energy audit along the wall too, `tangential` (or the reason it has none,
    `tangential_skipped`)."""
    t, gap, velocity = trajectory["t"], trajectory["gap"], trajectory["velocity"]
    terms = force_terms(trajectory, net_weight)
    powers = tangential_powers(trajectory, along) if along is not None else {}
    audits: list[dict | str] = []
    previous = 0  # the row where the previous impact's rebound ended
    for k, impact in enumerate(impacts):
        turn = int(np.searchsorted(t, impact["time"]))
        stop = int(np.searchsorted(t, impacts[k + 1]["time"])) if k + 1 < len(impacts) else len(t)
        h_c = impact["contact_gap"]
        start = _last_crossing_in(t, gap, blend_gap, previous, turn)
        if start is None and previous > 0:  # it rose no higher than delta_sl D: from the apex
            start = float(t[previous])
        film = impact.get("film_time") is not None
        if film:  # the rows of the handover (at h_c) and of the resumed state, the film collision's time apart
            jumped = 0 < turn < len(t) and math.isclose(gap[turn - 1], h_c, rel_tol=1e-6) and math.isclose(
                t[turn] - t[turn - 1], impact["film_time"], rel_tol=1e-3)
            contact_in = float(t[turn - 1]) if jumped else None
            contact_out = float(t[turn]) if jumped and impact.get("film_outcome") == "rebound" else None
        else:
            contact_in = _last_crossing_in(t, gap, h_c, previous, turn)
            contact_out = _crossing(t, gap, h_c, turn, stop, inward=False)
        if contact_in is None:
            audits.append(f"the trajectory's rows do not reach the contact gap {h_c:.4g} m before the impact")
            continue
        out = _crossing(t, gap, blend_gap, turn, stop, inward=False) if contact_out is not None else None
        last = float(t[stop - 1])
        end = out if out is not None else _apex(t, velocity, turn, stop) if contact_out is not None else last
        previous = int(np.searchsorted(t, end))
        if start is None:
            audits.append(f"the sphere was released at a gap of {gap[0]:.4g} m, inside delta_sl D = {blend_gap:.4g} "
                          "m: the approach phase has no start")
            continue
        bounds = [start, contact_in, contact_out if contact_out is not None else last, end]
        speed_in, speed_out = -float(np.interp(start, t, velocity)), float(np.interp(end, t, velocity))
        approach = (t >= start) & (t <= contact_in)
        peak = max(speed_in, float(-velocity[approach].min()) if approach.any() else 0.0)
        momentum_in = mass * peak
        impulses = {name: [impulse(t, force, a, b) for a, b in zip(bounds[:-1], bounds[1:])]
                    for name, force in terms.items() if np.any(force)}
        if film:  # the film collision: one jump across the contact phase
            for values in impulses.values():
                values[1] = 0.0
            jump = mass * (np.interp(bounds[2], t, velocity) - np.interp(bounds[1], t, velocity))
            impulses["film"] = [0.0, float(jump), 0.0]
        total = sum(sum(values) for values in impulses.values())
        audit = {
            "speed_in": speed_in, "speed_out": speed_out, "peak_speed": peak, "momentum_in": momentum_in,
            "phases": dict(zip(PHASES, zip(bounds[:-1], bounds[1:]))),
            "left_contact": contact_out is not None, "left_blend_gap": out is not None,
            "impulse": impulses,
            "share": {name: [value / momentum_in for value in values] for name, values in impulses.items()},
            "imbalance": (total - mass * (speed_out + speed_in)) / momentum_in,  # of the trapezoidal sums
        }
        if along is not None and film:
            audit["tangential_skipped"] = "a film collision jumps the contact: its work along the wall is not audited"
        elif along is not None:
            audit["tangential"] = tangential_audit(trajectory, along, bounds, powers, 0.5 * mass * peak**2)
        audits.append(audit)
    return audits


def annotate(summary: dict, trajectory: dict) -> str:
    """Add each wall impact's audit to summary.json's record of it (`losses`, or the reason it is absent as
    `losses_skipped`), from the run's trajectory columns; a free single sphere's runs only (a pair's collisions
    are not audited).  Returns a warning when audits were left out, but for a release inside delta_sl D, else ""."""
    scene = summary["scene"]
    impacts = summary.get("impacts") or []
    if "second_sphere" in scene or not impacts or "f_elastic" not in trajectory:
        return ""
    if scene.get("motion", {}).get("mode", "free") != "free":
        return ""
    diameter = scene["sphere"]["diameter"]
    volume = math.pi * diameter**3 / 6.0
    mass = scene["sphere"]["density"] * volume
    angle = math.radians(scene.get("gravity_angle", 0.0))  # an inclined wall: the weight's part on its normal
    net_weight = (mass - scene["liquid"]["density"] * volume) * scene["gravity"] * math.cos(angle)
    blend_gap = scene["contact"]["delta_sl"] * diameter
    along = None  # an oblique collision's, when its trajectory has the columns the tangential audit reads
    if "spring_energy" in trajectory:
        added = ADDED_MASS if summary.get("model") == "ode" else 0.0  # a resolved flow's force holds its added mass
        along = AlongWall(mass + added * scene["liquid"]["density"] * volume,
                          INERTIA_FACTOR * mass * (diameter / 2.0)**2, diameter / 2.0,
                          (mass - scene["liquid"]["density"] * volume) * scene["gravity"] * math.sin(angle))
    unaudited, first = [], ""  # the impacts left out but for a release inside delta_sl D, and the first reason
    for k, (impact, audit) in enumerate(zip(impacts, collision_losses(trajectory, impacts, mass, net_weight,
                                                                       blend_gap, along)), 1):
        impact.pop("losses", None)
        impact.pop("losses_skipped", None)
        if isinstance(audit, dict) and not abs(audit["imbalance"]) <= AUDIT_TOLERANCE:
            audit = (f"its impulses miss the momentum change by {audit['imbalance']:.3g} of the momentum brought in "
                     f"(allowed {AUDIT_TOLERANCE:g}): the trajectory's rows do not resolve the collision")
        elif isinstance(audit, dict) and "tangential" in audit and not abs(
                audit["tangential"]["imbalance"]) <= AUDIT_TOLERANCE:
            miss = audit.pop("tangential")["imbalance"]
            audit["tangential_skipped"] = (f"its work along the wall misses the energy change by {miss:.3g} of the "
                                           f"energy brought in (allowed {AUDIT_TOLERANCE:g}): the trajectory's rows "
                                           "do not resolve the collision")
        impact["losses" if isinstance(audit, dict) else "losses_skipped"] = audit
        if isinstance(audit, str) and not (k == 1 and trajectory["gap"][0] <= blend_gap):
            unaudited.append(str(k))
            first = first or audit
    if not unaudited:
        return ""
    interval = scene.get("numerics", {}).get("ode", {}).get("output_interval", 0.0) if summary["model"] == "ode" else 0
    thinned = f" (rows thinned to numerics.ode.output_interval = {interval:g} s; 0 writes every step)" * bool(interval)
    return f"no loss audit for impact(s) {', '.join(unaudited)}: {first}{thinned}"
