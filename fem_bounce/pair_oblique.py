"""Two spheres meeting off their line of centres (the reduced model): the motion across the line of centres, the
spins, the line's turning, and the friction of their contact.

The pair moves in the plane x-z.  Its normal motion is the head-on pair's (equations.BodyEquations: the gap s
between the surfaces along the line of centres n, from sphere 1 to sphere 2, and each sphere's velocity V_k along
n), read in the frame that turns with n; this module gives the rest: each sphere's velocity U_k along t = y x n
(t = x at the start, n = z), its spin Omega_k about y (the sign of oblique.TangentialMotion's), the angle theta of n
from z, sphere 1's centre (x_1, z_1) and the stretch xi of the contact's tangential spring.  With r = a_1 + a_2 + s
the distance of the centres, n = (sin theta, cos theta) and t = (cos theta, -sin theta),

    dtheta/dt = (U_2 - U_1) / r,   d(x_1, z_1)/dt = V_1 n + U_1 t,   sphere 2's centre (x_1, z_1) + r n,

and each sphere's acceleration in the turning frame is (dV_k/dt - theta' U_k) along n and (dU_k/dt + theta' V_k)
along t: its mass and added mass, and its history modes, take those (the normal rows' share is added by
BodyEquations with `frame_terms`).  Along t and about y

    (m_k + m_l,k / 2) (dU_k/dt + theta' V_k) = F_k + f_k,   I_k dOmega_k/dt = T_k + a_k f_k,

f_1 = f, f_2 = -f the friction (oblique.ContactFriction on the pair's Hertz contact, against the slip of sphere 1's
contact point over sphere 2's, s = U_1 - U_2 + a_1 Omega_1 + a_2 Omega_2), F_k and T_k the liquid's:

- each sphere alone: the drag -3 pi mu D_k phi(Re) U_k at the Re of U_k (contact.inertial_speed = "component", as
  the normal drag takes V_k's), the added mass m_l,k / 2, the history force along t with Mei & Adrian's kernel as
  along n (theory.TheoryForces), the torque -8 pi mu a_k^3 Omega_k with the spin's history (theory.rotation_kernel),
  as for a sphere at a wall (oblique.py);
- the pair's film, its lubrication limit (`pair_lubrication`): the terms in ln(1/xi) of Jeffrey & Onishi (1984, J.
  Fluid Mech. 139, 261) for Y^A_11, Y^B_11 and Y^C_11 with the others that locality (the film's forces on the two
  spheres equal and opposite), reciprocity and a rigid rotation of the pair (which the film does not resist)
  give, xi = 2 s / (a_1 + a_2).  Their O(1) constants, and the far-field interaction across the line of centres, are
  left out: the film's resistance is zero from xi = 1 (the gap the mean radius) outward.  The pair's added mass
  across the line of centres (and the turning of its added mass along it) is left out too.

Friction inside the pair's Hertz contact as at the wall: Mindlin's stiffness ratio for the two materials, the
spring unstretched at each contact.  The Jacobian block holds the stiff terms (the masses, the film, the friction and
the spring, the drag and the modes) and the frame's terms; it leaves out, as oblique.TangentialMotion does, how the
friction's inputs move with the normal state.
"""
from __future__ import annotations

import math

import numpy as np

from .contact import ContactLaw
from .oblique import (ADDED_MASS, INERTIA_FACTOR, ContactFriction, contact_stiffness_ratio, drag_excess,
                      mode_tolerances, spin_sensitivity)
from .scene import Scene
from .tangential_contact import oblique_record
from .theory import TheoryForces, rotation_history_modes

SLIP = np.array([1.0, -1.0])  # d slip / d(U_1, U_2); the spins' are the radii


def pair_lubrication(a1: float, a2: float, viscosity: float, gap: float) -> tuple[np.ndarray, np.ndarray]:
    """(R, dR/d gap) [SI] of the pair's film across the line of centres (module docstring), the liquid's forces and
    torques [F_1, F_2, T_1, T_2] = -R [U_1, U_2, Omega_1, Omega_2].  With lambda = a_2 / a_1 and L = ln(1/xi), the
    coefficients of Jeffrey & Onishi (1984), section 4 (their F, L the forces the spheres exert on the liquid):
    Y^A_11 = 4 lambda (2 + lambda + 2 lambda^2) / (15 (1 + lambda)^3) L in 6 pi mu a_1, Y^B_11 = -lambda (4 + lambda) /
    (5 (1 + lambda)^2) L in 4 pi mu a_1^2, Y^C_11 = 2 lambda / (5 (1 + lambda)) L in 8 pi mu a_1^3; sphere 2's with
    1 / lambda and a_2, and Y^C_12 = 4 lambda^2 / (5 (1 + lambda)^4) L in pi mu (a_1 + a_2)^3, which a rigid rotation's
    zero film force and torque also give.  For lambda -> infinity they are the wall's 8/15, 1/10 and 2/5
    (wall_tangential.py)."""
    mean = 0.5 * (a1 + a2)
    xi = gap / mean
    if xi >= 1.0 or gap <= 0.0:
        return np.zeros((4, 4)), np.zeros((4, 4))
    size, slope = math.log(1.0 / xi), -1.0 / gap
    ratio = a2 / a1
    mu = viscosity

    def translation_rotation(lam: float) -> float:  # |Y^B_11| of the sphere whose neighbour is lam times larger
        return lam * (4.0 + lam) / (5.0 * (1.0 + lam) ** 2)

    def rotation(lam: float) -> float:
        return 2.0 * lam / (5.0 * (1.0 + lam))

    sliding = 6.0 * math.pi * mu * a1 * 4.0 * ratio * (2.0 + ratio + 2.0 * ratio**2) / (15.0 * (1.0 + ratio) ** 3)
    b1 = 4.0 * math.pi * mu * a1**2 * translation_rotation(ratio)
    b2 = 4.0 * math.pi * mu * a2**2 * translation_rotation(1.0 / ratio)
    c11 = 8.0 * math.pi * mu * a1**3 * rotation(ratio)
    c22 = 8.0 * math.pi * mu * a2**3 * rotation(1.0 / ratio)
    c12 = math.pi * mu * (a1 + a2) ** 3 * 4.0 * ratio**2 / (5.0 * (1.0 + ratio) ** 4)
    unit = np.array([[sliding, -sliding, b1, b2],
                     [-sliding, sliding, -b1, -b2],
                     [b1, -b1, c11, c12],
                     [b2, -b2, c12, c22]])
    return size * unit, slope * unit


class PairTangentialMotion:
    """The pair's unknowns across its line of centres (x_1, z_1, theta, U_1, U_2, Omega_1, Omega_2, xi, then the
    history modes: along t of sphere 1 and of sphere 2, of the spin of sphere 1 and of sphere 2): their residual and
    Jacobian rows (module docstring)."""

    names = ("x_1", "z_1", "theta", "tangential_velocity_1", "tangential_velocity_2", "spin_1", "spin_2", "stretch")
    STRETCH = 7  # where the stretch is in the unknowns
    VELOCITIES = slice(3, 7)  # U_1, U_2, Omega_1, Omega_2

    def __init__(self, scene: Scene, law: ContactLaw, bodies, theories: tuple[TheoryForces, ...]):
        first, second = scene.sphere, scene.second_sphere
        liquid = scene.liquid
        self.radii = np.array([first.radius, second.radius])
        self.diameters = 2.0 * self.radii
        self.viscosity, self.density = liquid.viscosity, liquid.density
        self._displaced = np.array([b.displaced_mass for b in bodies])
        self.masses = np.array([b.mass for b in bodies]) + ADDED_MASS * self._displaced  # along t
        self.inertias = INERTIA_FACTOR * np.array([b.mass for b in bodies]) * self.radii**2
        self.inertia_diagonal = np.r_[self.masses, self.inertias]
        self.friction = ContactFriction(law, scene.contact.friction, contact_stiffness_ratio(scene, first, second))
        self.theories = theories
        self.n_history = tuple(th.n_history for th in theories)
        theta, weights = rotation_history_modes(scene.numerics.ode.history_modes_per_decade)
        spinning = 0 if scene.contact.history == "off" else len(theta)
        self.spin_weights = [8.0 / 3.0 * math.pi * self.viscosity * a**3 * weights[:spinning] for a in self.radii]
        self.spin_times = [theta[:spinning] * a**2 / liquid.kinematic_viscosity for a in self.radii]
        sizes = [*self.n_history, spinning, spinning]
        ends = len(self.names) + np.cumsum(sizes)
        self.modes = [slice(int(end) - size, int(end)) for end, size in zip(ends, sizes)]  # U_1, U_2, Omega_1, Omega_2
        self.mode_times = np.concatenate([*(th.history_times[:m] for th, m in zip(theories, self.n_history)),
                                          *self.spin_times])
        self._times = [self.mode_times[m.start - len(self.names):m.stop - len(self.names)] for m in self.modes]
        self.size = int(ends[-1])
        self.start = np.zeros(self.size)
        self.start[1] = scene.initial_gap + first.radius
        self.start[3:7] = (scene.tangential_velocity, second.tangential_velocity, scene.spin, second.spin)

    # -- the terms ------------------------------------------------------------------------------------------------
    def _turning(self, state, gap: float) -> tuple[float, float]:
        """(theta' [1/s], r [m])."""
        distance = float(self.radii.sum()) + gap
        return (state[4] - state[3]) / distance, distance

    def slip(self, state) -> float:
        """The slip of sphere 1's contact point over sphere 2's [m/s]."""
        return self._slip(state[self.VELOCITIES])

    def _slip(self, velocities) -> float:
        """`slip` from (U_1, U_2, Omega_1, Omega_2)."""
        return float(velocities[0] - velocities[1] + self.radii @ np.asarray(velocities[2:4], dtype=float))

    def _history(self, state, coefficients: bool = False) -> tuple[np.ndarray, np.ndarray, list[np.ndarray]]:
        """(the history forces along t and the spins' history torques [N, N m], the forces' derivatives in U_k
        [N s/m], and with `coefficients` each sphere's c_i, for the Jacobian)."""
        forces, slopes, found = np.zeros(4), np.zeros(2), []
        for k, theory in enumerate(self.theories):
            if coefficients:
                found.append(theory.history_coefficients(float(state[3 + k]))[:self.n_history[k]])
            if self.n_history[k]:
                memory, slope = theory.history_memory(float(state[3 + k]), np.asarray(state[self.modes[k]], float))
                forces[k], slopes[k] = -memory, -slope
        for k in range(2):
            forces[2 + k] = -float(self.spin_weights[k] @ np.asarray(state[self.modes[2 + k]], dtype=float))
        return forces, slopes, found

    def _drag(self, state) -> tuple[np.ndarray, np.ndarray]:
        """(each sphere alone: drag along t and torque [N, N m], d/d(U_1, U_2, Omega_1, Omega_2) on the diagonal)."""
        values, slopes = np.zeros(4), np.zeros(4)
        for k in range(2):
            stokes = 3.0 * math.pi * self.viscosity * self.diameters[k]
            excess, d_excess, _ = drag_excess(float(state[3 + k]), 0.0, self.density, self.diameters[k],
                                              self.viscosity)
            values[k], slopes[k] = -stokes * state[3 + k] + excess, -stokes + d_excess
            rotating = 8.0 * math.pi * self.viscosity * self.radii[k] ** 3
            values[2 + k], slopes[2 + k] = -rotating * state[5 + k], -rotating
        return values, slopes

    def terms(self, state, gap: float, rate: float, film_gap: float, engaged: float | None) -> dict:
        """The forces along t and torques [F_1, F_2, T_1, T_2] of the liquid (each sphere alone, with its history,
        and the film), the friction on sphere 1 [N] and the spring's rate [m/s]."""
        velocities = np.asarray(state[self.VELOCITIES], dtype=float)
        alone, _ = self._drag(state)
        history, _, _ = self._history(state)
        film, _ = pair_lubrication(*self.radii, self.viscosity, film_gap)
        friction, stretch_rate, *_ = self.friction.slopes(gap, rate, engaged, self.slip(state), state[self.STRETCH])
        return {"alone": alone + history, "film": -film @ velocities, "friction": friction,
                "stretch_rate": stretch_rate}

    def generalised(self, friction: float) -> np.ndarray:
        """The friction's forces and torques on the spheres [N, N m], [f, -f, a_1 f, a_2 f], for the friction f on
        sphere 1."""
        return friction * np.r_[SLIP, self.radii]

    def residual(self, state, rates, gap: float, rate: float, film_gap: float, engaged: float | None,
                 normal) -> np.ndarray:
        """The rows at the unknowns `state` and their `rates`, the gap [m] and its rate, the gap the film is
        evaluated at, the contact's engaged gap and the spheres' velocities along n (`normal`, [V_1, V_2])."""
        found = self.terms(state, gap, rate, film_gap, engaged)
        turning, distance = self._turning(state, gap)
        theta, velocity_1 = state[2], state[3]
        normal = np.asarray(normal, dtype=float)
        accelerations = np.asarray(rates[self.VELOCITIES], dtype=float) + np.r_[turning * normal, 0.0, 0.0]
        loads = found["alone"] + found["film"] + self.generalised(found["friction"])
        out = np.empty(self.size)
        out[0] = rates[0] - (normal[0] * math.sin(theta) + velocity_1 * math.cos(theta))
        out[1] = rates[1] - (normal[0] * math.cos(theta) - velocity_1 * math.sin(theta))
        out[2] = rates[2] - turning
        out[self.VELOCITIES] = self.inertia_diagonal * accelerations - loads
        out[self.STRETCH] = rates[self.STRETCH] - found["stretch_rate"]
        for k, modes in enumerate(self.modes):
            out[modes] = rates[modes] - accelerations[k] + state[modes] / self._times[k]
        return out

    def jacobian(self, state, gap: float, rate: float, film_gap: float, film_slope: float, engaged: float | None,
                 shift: float, normal) -> tuple[np.ndarray, np.ndarray]:
        """(d G / d(unknowns) + shift d G / d(rates), d G / d(gap, V_1, V_2)) of these rows (module docstring for what
        it leaves out)."""
        theta, velocity_1 = state[2], state[3]
        normal = np.asarray(normal, dtype=float)
        turning, distance = self._turning(state, gap)
        velocities = np.asarray(state[self.VELOCITIES], dtype=float)
        _, f_slip, f_stretch, r_slip, r_stretch = self.friction.slopes(gap, rate, engaged, self.slip(state),
                                                                       state[self.STRETCH])[1:]
        film, film_rate = pair_lubrication(*self.radii, self.viscosity, film_gap)
        _, drag_slopes = self._drag(state)
        _, history_slopes, coefficients = self._history(state, coefficients=True)
        lever = np.r_[SLIP, self.radii]  # d slip / d velocities, and the friction's share of each row
        own = np.zeros((self.size, self.size))
        np.fill_diagonal(own, shift)
        own[0, 2] = -(normal[0] * math.cos(theta) - velocity_1 * math.sin(theta))
        own[0, 3] = -math.cos(theta)
        own[1, 2] = normal[0] * math.sin(theta) + velocity_1 * math.cos(theta)
        own[1, 3] = math.sin(theta)
        turn = np.array([-1.0, 1.0]) / distance  # d theta' / d(U_1, U_2)
        own[2, 3:5] = -turn
        rows = self.VELOCITIES
        block = np.diag(shift * self.inertia_diagonal - drag_slopes - np.r_[history_slopes, 0.0, 0.0]) + film
        block -= f_slip * np.outer(lever, lever)
        block[:2, :2] += np.outer(self.masses * normal, turn)  # the frame's theta' V_k
        own[rows, rows] = block
        own[rows, self.STRETCH] = -f_stretch * lever
        own[self.STRETCH, rows] = -r_slip * lever
        own[self.STRETCH, self.STRETCH] = shift - r_stretch
        normal_block = np.zeros((self.size, 3))
        normal_block[0, 1] = -math.sin(theta)
        normal_block[1, 1] = -math.cos(theta)
        normal_block[2, 0] = turning / distance
        normal_block[rows, 0] = film_slope * (film_rate @ velocities)
        normal_block[3, 0] -= self.masses[0] * normal[0] * turning / distance
        normal_block[4, 0] -= self.masses[1] * normal[1] * turning / distance
        normal_block[3, 1], normal_block[4, 2] = self.masses * turning
        for k, modes in enumerate(self.modes):
            if modes.stop == modes.start:
                continue
            if k < 2:
                own[3 + k, modes] = coefficients[k]  # -d f_H / dz_i
                own[modes, 3:5] = -np.outer(np.full(modes.stop - modes.start, normal[k]), turn)
                normal_block[modes, 1 + k] = -turning
                normal_block[modes, 0] = normal[k] * turning / distance
            else:
                own[3 + k, modes] = self.spin_weights[k - 2]
            own[modes, 3 + k] -= shift
            own[modes, modes] = np.diag(shift + 1.0 / self._times[k])
        return own, normal_block

    def frame_terms(self, state, gap: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(theta' U_k [m/s^2], what the normal accelerations dV_k/dt lack in the turning frame; its derivatives in
        (U_1, U_2) (2, 2) and in the gap (2,))."""
        turning, distance = self._turning(state, gap)
        velocities = np.asarray(state[3:5], dtype=float)
        turn = np.array([-1.0, 1.0]) / distance
        return turning * velocities, turning * np.eye(2) + np.outer(velocities, turn), -turning * velocities / distance

    def mode_tolerances(self, speed: float, time_unit: float) -> np.ndarray:
        """Each history mode's absolute tolerance: the error that moves its velocity (or a_k times its spin) by
        `speed` [m/s], shared among the sphere's modes (integrator._build_ts, as for the normal modes)."""
        found = np.zeros(self.size - len(self.names))
        for k, modes in enumerate(self.modes):
            if modes.stop == modes.start:
                continue
            where = slice(modes.start - len(self.names), modes.stop - len(self.names))
            if k < 2:
                found[where] = mode_tolerances(speed, self.theories[k].history_sensitivity(self.masses[k], time_unit))
            else:
                found[where] = mode_tolerances(speed / self.radii[k - 2], spin_sensitivity(
                    self.spin_weights[k - 2], self.spin_times[k - 2], time_unit, self.inertias[k - 2]))
        return found

    def kinetic_energy(self, state, displaced: np.ndarray | None = None) -> float:
        """sum_k (m_k + m_l,k) U_k^2 / 2 + I_k Omega_k^2 / 2 [J] with each sphere's `displaced` liquid mass m_l,k (none
        when not given): the energy across the line of centres and in the spins."""
        bare = self.masses - ADDED_MASS * self._displaced
        liquid = np.zeros(2) if displaced is None else np.asarray(displaced)
        velocities = np.asarray(state[self.VELOCITIES], dtype=float)
        return float(0.5 * (bare + liquid) @ velocities[:2]**2 + 0.5 * self.inertias @ velocities[2:]**2)

    # -- outputs --------------------------------------------------------------------------------------------------
    def positions(self, state, gap: float) -> tuple[float, float, float, float]:
        """(x_1, z_1, x_2, z_2) [m], the centres."""
        distance = float(self.radii.sum()) + gap
        theta = state[2]
        return (float(state[0]), float(state[1]), float(state[0] + distance * math.sin(theta)),
                float(state[1] + distance * math.cos(theta)))

    def row(self, state, gap: float, rate: float, film_gap: float, engaged: float | None,
            acceleration: float) -> dict:
        """The trajectory's columns across the line of centres (output.PAIR_TANGENTIAL_COLUMNS); `acceleration` the
        gap's [m/s^2], for the power the contact dissipates."""
        found = self.terms(state, gap, rate, film_gap, engaged)
        x1, z1, x2, z2 = self.positions(state, gap)
        stored, lost, sliding = self.friction.energy(gap, rate, engaged, self.slip(state), state[self.STRETCH],
                                                     acceleration)
        liquid = found["alone"] + found["film"]
        return {"x_1": x1, "z_1": z1, "x_2": x2, "z_2": z2, "theta": float(state[2]),
                "tangential_velocity_1": float(state[3]), "tangential_velocity_2": float(state[4]),
                "spin_1": float(state[5]), "spin_2": float(state[6]),
                "f_tangential_liquid_1": float(liquid[0]), "f_tangential_liquid_2": float(liquid[1]),
                "torque_liquid_1": float(liquid[2]), "torque_liquid_2": float(liquid[3]),
                "f_tangential_film_1": float(found["film"][0]), "f_friction": float(found["friction"]),
                "stretch": float(state[self.STRETCH]), "spring_energy": stored,
                "dissipation_sliding": lost if sliding else 0.0, "dissipation_sticking": 0.0 if sliding else lost}

    def station(self, state) -> tuple:
        """What an impact's record reads where the collision passes a station: (U_1, U_2, Omega_1, Omega_2)."""
        return tuple(float(v) for v in state[self.VELOCITIES])

    def record(self, entry: tuple, end: float, rate: float, station: tuple) -> dict:
        """One impact at one station (tangential_contact.oblique_record; `entry` (t, normal speed, *station) on the
        way in) from sphere 2's view (the projectile of a launched pair), as if sphere 1 were its wall: its velocity
        along t relative to sphere 1's, U_2 - U_1, as the tangential velocity, the slip of its contact point over
        sphere 1's (-s) as the contact velocity (v_t of psi = v_t / v_n,in), and each sphere's spin, [Omega_1,
        Omega_2] (sphere 2's positive in its rolling sense over sphere 1)."""
        start, speed_in, *before = entry
        found = oblique_record(start, speed_in, before[1] - before[0], 0.0, end, rate, station[1] - station[0], 0.0,
                               0.0)
        contact_in, contact_out = (-self._slip(values) for values in (before, station))
        found.update(spin_in=list(before[2:]), spin_out=list(station[2:]), contact_velocity_in=contact_in,
                     contact_velocity_out=contact_out, psi_in=contact_in / speed_in, psi_out=contact_out / speed_in,
                     tangential_restitution=contact_out / contact_in if contact_in != 0.0 else None)
        return found
