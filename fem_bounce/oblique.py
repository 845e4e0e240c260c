"""The tangential motion of a sphere at a wall in an oblique collision (the reduced model): its velocity U along
the wall (x, in the plane of incidence), its spin Omega about y (positive in the rolling sense of +x motion: the
point nearest the wall moves at the slip s = U - a Omega) and the stretch xi of the contact's tangential spring.

    dx/dt = U,   (m + m_l / 2) dU/dt = F_liquid + F_friction + (m - m_l) g sin(theta),
    I dOmega/dt = T_liquid - a F_friction,   dxi/dt = the spring's rate (tangential_contact),

I = (2/5) m a^2.  The normal motion (equations.BodyEquations) is that of a head-on collision but for the lift of
the sphere sliding along the wall (contact.lift, fem_bounce.wall_lift) and, with contact.inertial_speed = "whole",
its drag's inertial factor, the whole speed's (below): nothing else acts back on it, while the tangential motion
reads the normal one's gap, velocity and contact force.

- The liquid: [F, T] = -R(h) [U, Omega], the Stokes resistance of a sphere sliding and spinning near the wall, one
  symmetric matrix (wall_tangential), at the gap where the normal film is evaluated (its contact gap inside a Hertz
  contact); the free sphere's inertial excess -3 pi mu D (phi(Re) - 1) U with Schiller & Naumann's (1933) phi at Re =
  rho_l |U| D / mu, as the normal drag takes it at its own speed (contact.inertial_speed = "whole": both at the whole
  speed's Re, rho_l |(U, V)| D / mu, theory.TheoryForces.drag_slopes; docs/validation.md section 14 measures both
  against the 3-D model); the added mass m_l / 2 of a sphere far from walls (the wall raises it by O((a/h)^3)); the
  history force along the wall, -sum_i c_i(Re_t) z_i, with the normal motion's kernel (theory.TheoryForces: Mei &
  Adrian's, as an exponential sum) and its own modes z_i' = dU/dt - z_i / T_i, the free sphere's (no wall factor), as
  the normal history's default (contact.history "mei-adrian" carries it, "off" leaves it out); the 3-D resolved flow
  showed it needed (docs/validation.md section 14).  The spin's history torque likewise, -(8/3) pi mu a^3 sum_i w_i
  zeta_i with zeta_i' = dOmega/dt - zeta_i / T_i, the unsteady Stokes kernel of a spinning sphere
  (theory.rotation_kernel, no finite-Re correction): the friction spins the sphere up within the contact, and the
  boundary layer it leaves slows the spin after it.  And the sliding sphere's torque at finite Re beyond the film's
  (contact.wall_torque, wall_lift.WallTorque: measured with the 3-D model, against the rolling sense where the
  film's turns it toward rolling).
- The contact: Coulomb friction mu F_n with a tangential spring of Mindlin's stiffness k_t = kappa (3/2) k x^(1/2)
  (x the Hertz overlap, k its constant, kappa = 4 G*/E*) and a damper with the normal one's damping ratio
  (tangential_contact.TangentialContact, matched_damping); the spring starts unstretched at each contact.  The
  normal force's rate the spring reads is its elastic part's, (dF_n/dh) dh/dt: the damping part's would need the
  acceleration.

The Jacobian block (`jacobian`) holds the terms that make the tangential system stiff (the friction in the slip and
the stretch, the spring, the film's resistance, the masses) and the coupling through the gap's resistance; it
leaves out how the friction's inputs (F_n, k_t, their rates) move with the normal state.  The Rosenbrock-W
integrator (PETSc TSROSW) keeps its order with an approximate Jacobian; only its step control sees the difference.
"""
from __future__ import annotations

import math

import numpy as np

from .contact import ContactLaw
from .kinematics import PlaneForce
from .scene import Scene
from .tangential_contact import TangentialContact, matched_damping, oblique_record
from .theory import TheoryForces, rotation_history_modes
from .wall_lift import WallTorque
from .wall_tangential import wall_tangential_resistance

INERTIA_FACTOR = 0.4  # I / (m a^2) of a solid sphere
ADDED_MASS = 0.5  # C_M along the wall


def stiffness_ratio(e1: float, nu1: float, e2: float, nu2: float) -> float:
    """kappa = k_t / k_n = 4 G* / E* of a Hertz contact of two isotropic solids (Mindlin 1949; Johnson 1985,
    Contact Mechanics, sections 4.2 and 7.2): 1/E* = sum (1 - nu^2) / E, 1/G* = sum (2 - nu) / G, G = E / (2 (1 + nu));
    2 (1 - nu) / (2 - nu) for one material."""
    e_star = 1.0 / ((1.0 - nu1**2) / e1 + (1.0 - nu2**2) / e2)
    g_star = 1.0 / ((2.0 - nu1) * 2.0 * (1.0 + nu1) / e1 + (2.0 - nu2) * 2.0 * (1.0 + nu2) / e2)
    return 4.0 * g_star / e_star


def contact_stiffness_ratio(scene: Scene, first, second) -> float:
    """kappa of the contact between the solids `first` and `second` (a Sphere or the Wall): the scene's
    contact.tangential_stiffness if set, else Mindlin's (`stiffness_ratio`)."""
    if scene.contact.tangential_stiffness is not None:
        return scene.contact.tangential_stiffness
    return stiffness_ratio(first.youngs_modulus, first.poisson_ratio, second.youngs_modulus, second.poisson_ratio)


def drag_excess(velocity: float, normal: float, density: float, diameter: float,
                viscosity: float) -> tuple[float, float, float]:
    """(-3 pi mu D (phi - 1) U [N], its derivatives in U and in the normal velocity V [N s/m]): a free sphere's
    inertial excess along U, Schiller & Naumann's phi at Re of the speed |(U, V)| (V = 0: at |U| alone)."""
    speed = math.hypot(velocity, normal)
    reynolds = density * speed * diameter / viscosity
    if reynolds == 0.0:
        return 0.0, 0.0, 0.0
    stokes = 3.0 * math.pi * viscosity * diameter
    excess = 0.15 * reynolds**0.687
    # -3 pi mu D U d(phi - 1)/d|u| / |u|: times U or V, the excess's derivative through |u|
    growth = -stokes * 0.687 * excess * velocity / speed**2
    return -stokes * excess * velocity, -stokes * excess + growth * velocity, growth * normal


def mode_tolerances(speed: float, sensitivity: np.ndarray) -> np.ndarray:
    """History modes' absolute tolerances (integrator._build_ts, as for the normal modes): the error in each that
    moves its velocity (or spin) by `speed`, shared among the modes, each mode's `sensitivity` what one unit of its
    error moves."""
    sensitivity = np.maximum(np.asarray(sensitivity, dtype=float), 1e-30)
    return speed / (len(sensitivity) * sensitivity)


def spin_sensitivity(weights: np.ndarray, times: np.ndarray, time_unit: float, inertia: float) -> np.ndarray:
    """The spin [1/s] that one unit of error in each spin history mode moves: w_i min(T_i, t) / I."""
    return weights * np.minimum(times, time_unit) / inertia


class ContactFriction:
    """The friction of one Hertz contact (the wall's or a pair's, `law`): tangential_contact.TangentialContact with
    the contact's normal force, its Mindlin stiffness and the damper matched to the normal one, at the contact's gap
    and its rate (module docstring)."""

    def __init__(self, law: ContactLaw, friction: float, ratio: float):
        self.law, self.ratio = law, ratio
        self.contact = TangentialContact(friction, ratio)

    def _inputs(self, gap: float, rate: float, engaged: float | None, slip: float, stretch: float) -> tuple | None:
        """TangentialContact.rates's arguments at the gap and its rate, or None while nothing holds the spring."""
        law = self.law
        if engaged is None:
            return None
        push, d_gap, d_rate = law.force_slopes(gap, rate, engaged)
        overlap = engaged - gap
        stiffness, stiffening = self.contact.stiffness(law.stiffness, overlap)
        if push <= 0.0 or stiffness <= 0.0:
            return None
        elastic_rate = 1.5 * law.stiffness * math.sqrt(overlap) * -rate  # d(k x^1.5)/dt
        damping = matched_damping(-d_rate, self.ratio, INERTIA_FACTOR)
        return push, elastic_rate, stiffness, stiffening * -rate, slip, stretch, damping

    def slopes(self, gap: float, rate: float, engaged: float | None, slip: float, stretch: float):
        """(friction force [N], the stretch's rate [m/s], d force/d slip, d force/d stretch, d rate/d slip,
        d rate/d stretch) at the contact's gap and rate, the contact point's slip [m/s] and the stretch [m]."""
        arguments = self._inputs(gap, rate, engaged, slip, stretch)
        if arguments is None:
            return 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        state = self.contact.rates(*arguments)
        slopes = self.contact.jacobian(*arguments)
        force, spring = slopes["force"], slopes["stretch_rate"]
        return (float(state.force), float(state.stretch_rate), float(force["slip"][0, 0]),
                float(force["stretch"][0, 0]), float(spring["slip"][0, 0]), float(spring["stretch"][0, 0]))

    def energy(self, gap: float, rate: float, engaged: float | None, slip: float, stretch: float,
               acceleration: float) -> tuple[float, float, bool]:
        """(the spring's stored energy [J], the power the contact dissipates [W], sliding): TangentialContact.energy
        with the normal force's actual rate from the gap's `acceleration` [m/s^2]."""
        arguments = self._inputs(gap, rate, engaged, slip, stretch)
        if arguments is None:
            return 0.0, 0.0, False
        _, d_gap, d_rate = self.law.force_slopes(gap, rate, engaged)
        return self.contact.energy(*arguments, force_rate=d_gap * rate + d_rate * acceleration)


class TangentialMotion:
    """The tangential unknowns (x, U, Omega, xi) of sphere 1 at the wall: their residual and Jacobian rows."""

    names = ("x", "tangential_velocity", "spin", "stretch")  # then the history modes: along the wall, of the spin
    STRETCH = 3  # where the stretch is in the tangential unknowns

    def __init__(self, scene: Scene, law: ContactLaw, mass: float, displaced_mass: float,
                 hold_gap: float | None = None):
        sphere, wall, liquid = scene.sphere, scene.wall, scene.liquid
        self.radius, self.diameter = sphere.radius, sphere.diameter
        self.viscosity, self.density = liquid.viscosity, liquid.density
        # a resolved flow's force (its added mass within it) replaces the theory's liquid (module docstring)
        self.resolved, self.hold_gap = hold_gap is not None, hold_gap or 0.0
        self.fluid: PlaneForce | None = None  # the resolved flow's, set for each fluid step
        self._held = (wall_tangential_resistance(self.radius, self.viscosity, self.hold_gap)[0] if self.hold_gap
                      else None)  # R at the hold
        self.mass = mass + (0.0 if self.resolved else ADDED_MASS * displaced_mass)  # along the wall
        self.inertia = INERTIA_FACTOR * mass * sphere.radius**2
        self.weight = (mass - displaced_mass) * scene.gravity * math.sin(math.radians(scene.gravity_angle))
        self.law = law
        self.friction = ContactFriction(law, scene.contact.friction, contact_stiffness_ratio(scene, sphere, wall))
        # the history modes along the wall (none with a resolved flow: its flow carries the history)
        self.theory = TheoryForces(scene)
        self.n_history = 0 if self.resolved else self.theory.n_history
        theta, weights = rotation_history_modes(scene.numerics.ode.history_modes_per_decade)
        spinning = 0 if self.resolved or scene.contact.history == "off" else len(theta)
        self.spin_weights = 8.0 / 3.0 * math.pi * self.viscosity * self.radius**3 * weights[:spinning]  # [N m s]
        self.mode_times = np.concatenate([self.theory.history_times[:self.n_history],
                                          theta[:spinning] * self.radius**2 / liquid.kinematic_viscosity])
        self.translation = slice(len(self.names), len(self.names) + self.n_history)  # the modes of each
        self.rotation = slice(self.translation.stop, self.translation.stop + spinning)
        self.size = self.rotation.stop  # the tangential unknowns
        self.start = (0.0, scene.tangential_velocity, scene.spin, 0.0, *np.zeros(self.size - len(self.names)))
        self.whole_speed = scene.contact.inertial_speed == "whole"  # the drag's inertia at |(U, V)|'s Re
        # the sliding sphere's torque at finite Re beyond the film's (contact.wall_torque; none with a resolved flow)
        self.wall_torque = (WallTorque(sphere.diameter, liquid.density, liquid.viscosity)
                            if scene.contact.wall_torque == "steady" and not self.resolved else None)

    def mode_tolerances(self, speed: float, time_unit: float) -> np.ndarray:
        """Each history mode's absolute tolerance (integrator._build_ts, as for the normal modes): along the wall on
        its mass, the spin's on its inertia, each the error that moves U (or a Omega) by `speed` [m/s], shared among
        the modes."""
        found = np.zeros(self.size - len(self.names))
        if self.n_history:
            found[:self.n_history] = mode_tolerances(speed, self.theory.history_sensitivity(self.mass, time_unit))
        spinning = slice(self.rotation.start - len(self.names), self.rotation.stop - len(self.names))
        if spinning.stop > spinning.start:
            found[spinning] = mode_tolerances(speed / self.radius, spin_sensitivity(
                self.spin_weights, self.mode_times[spinning], time_unit, self.inertia))
        return found

    def station(self, state) -> tuple[float, float]:
        """What an impact's record reads where the collision passes a station: (U, Omega)."""
        return float(state[1]), float(state[2])

    def record(self, entry: tuple, end: float, rate: float, station: tuple) -> dict:
        """One impact at one station (tangential_contact.oblique_record), `entry` (t, normal speed, U, Omega) on the
        way in."""
        return oblique_record(*entry, end, rate, *station, self.radius)

    def _drag_excess(self, velocity: float, normal: float) -> tuple[float, float, float]:
        """`drag_excess` of this sphere, phi at |U| or, with contact.inertial_speed = "whole", at |(U, V)|."""
        return drag_excess(velocity, normal if self.whole_speed else 0.0, self.density, self.diameter, self.viscosity)

    def free_resistance(self, state, normal: float) -> tuple[float, float]:
        """(F [N], T [N m]) of the free sphere (far from walls) at the tangential `state` and the normal velocity
        `normal` [m/s]: the drag -3 pi mu D phi(Re) U and the torque -8 pi mu a^3 Omega with their history terms,
        the far field the loss audit tells apart from the wall's film (R(h) less the steady part)."""
        velocity, spin = state[1], state[2]
        excess, _, _ = self._drag_excess(velocity, normal)
        history, _ = self._history(state)
        return (-3.0 * math.pi * self.viscosity * self.diameter * velocity + excess + history,
                -8.0 * math.pi * self.viscosity * self.radius**3 * spin + self._spin_history(state))

    def _history(self, state) -> tuple[float, float]:
        """(f_H = -sum_i c_i(Re_t) z_i [N], d f_H / dU [N s/m] through c_i's Re_t) of the modes along the wall."""
        if not self.n_history:
            return 0.0, 0.0
        memory, slope = self.theory.history_memory(state[1], np.asarray(state[self.translation], dtype=float))
        return -memory, -slope

    def _spin_history(self, state) -> float:
        """T_H = -(8/3) pi mu a^3 sum_i w_i zeta_i [N m] of the spin's modes."""
        return -float(self.spin_weights @ np.asarray(state[self.rotation], dtype=float))

    def _torque_excess(self, film_gap: float, velocity: float) -> tuple[float, float, float]:
        """(T, dT/d gap, dT/dU) of the sliding sphere's torque beyond the film's (wall_lift.WallTorque), or zeros."""
        if self.wall_torque is None:
            return 0.0, 0.0, 0.0
        return self.wall_torque.torque_slopes(film_gap, velocity)

    def _liquid(self, film_gap: float, state, normal: float):
        """(F, T, R, dR/d gap, d (excess + history)/dU, d excess/dV, (dT/d gap, dT/dU) of the finite-Re torque) of the
        liquid at the film's gap, the tangential `state` and the normal velocity `normal` [m/s]; with a resolved flow
        F and T are the flow's explicit part and what the held flow misses, R the film's resistance below the hold
        less the hold's."""
        velocity, spin = state[1], state[2]
        if self.resolved:
            explicit = self.fluid.explicit if self.fluid is not None else np.zeros(2)
            if film_gap >= self.hold_gap:
                return float(explicit[0]), float(explicit[1]), np.zeros((2, 2)), np.zeros((2, 2)), 0.0, 0.0, (0.0, 0.0)
            resistance, slope = wall_tangential_resistance(self.radius, self.viscosity, film_gap)
            missed = resistance - self._held
            force, torque = explicit - missed @ np.array([velocity, spin])
            return float(force), float(torque), missed, slope, 0.0, 0.0, (0.0, 0.0)
        resistance, slope = wall_tangential_resistance(self.radius, self.viscosity, film_gap)
        excess, d_excess, d_normal = self._drag_excess(velocity, normal)
        history, d_history = self._history(state)
        force, torque = -resistance @ np.array([velocity, spin])
        sliding_torque, *torque_slopes = self._torque_excess(film_gap, velocity)
        torque += self._spin_history(state) + sliding_torque
        return force + excess + history, torque, resistance, slope, d_excess + d_history, d_normal, torque_slopes

    def terms(self, state, gap: float, rate: float, film_gap: float, engaged: float | None) -> dict:
        """The forces along the wall [N], the liquid's torque [N m] and the spring's rate [m/s] at the tangential
        `state`, the wall's `gap` [m] and its rate [m/s], the gap the film is evaluated at and the contact's engaged
        gap (the trajectory's columns f_tangential_liquid, f_friction, torque_liquid, and stretch_rate)."""
        velocity, spin, stretch = state[1], state[2], state[self.STRETCH]
        friction, stretch_rate, *_ = self.friction.slopes(gap, rate, engaged, velocity - self.radius * spin, stretch)
        force, torque, *_ = self._liquid(film_gap, state, rate)
        return {"f_tangential_liquid": force, "f_friction": friction, "torque_liquid": torque,
                "stretch_rate": stretch_rate}

    def row(self, state, gap: float, rate: float, film_gap: float, engaged: float | None,
            acceleration: float, along_accelerations=None) -> dict:
        """The trajectory's tangential columns but x, U and Omega (output.TANGENTIAL_COLUMNS): `terms`'s forces and
        torque, the free sphere's part of them (`free_resistance`; with a resolved flow the flow's force with its
        added mass's, and the liquid's that and what the held flow misses), the stretch, the spring's stored energy
        [J] and the power the contact dissipates [W] while it slides and while it sticks (TangentialContact.energy, with
        the normal force's actual rate from the gap's `acceleration` [m/s^2]; `along_accelerations`: dU/dt and
        dOmega/dt, which a resolved flow's added mass needs)."""
        velocity, spin, stretch = state[1], state[2], state[self.STRETCH]
        found = self.terms(state, gap, rate, film_gap, engaged)
        drag, torque = self.free_resistance(state, rate)
        if self.resolved and self.fluid is not None:  # the flow's whole force: its explicit part less its added mass's
            held = self.fluid.mass[1:] @ np.r_[acceleration, along_accelerations]
            drag, torque = self.fluid.explicit - held  # the flow's part (the correction below the hold apart)
            missed = np.array([found["f_tangential_liquid"], found["torque_liquid"]]) - self.fluid.explicit
            found["f_tangential_liquid"], found["torque_liquid"] = drag + missed[0], torque + missed[1]
        stored, lost, sliding = self.friction.energy(gap, rate, engaged, velocity - self.radius * spin, stretch,
                                                     acceleration)
        return {"f_tangential_liquid": found["f_tangential_liquid"], "f_friction": found["f_friction"],
                "torque_liquid": found["torque_liquid"], "f_tangential_drag": drag, "torque_drag": torque,
                "stretch": float(stretch), "spring_energy": stored, "dissipation_sliding": lost if sliding else 0.0,
                "dissipation_sticking": 0.0 if sliding else lost}

    def residual(self, state, rates, gap: float, rate: float, film_gap: float, engaged: float | None,
                 acceleration: float = 0.0) -> np.ndarray:
        """The rows G = (x' - U, M U' - F, I Omega' - T, xi' - rate, z_i' - U' + z_i / T_i) at the tangential `state`
        and its `rates` (`terms` for the rest; a resolved flow's added mass reads the normal `acceleration` dV/dt
        too)."""
        found = self.terms(state, gap, rate, film_gap, engaged)
        friction = found["f_friction"]
        modes = slice(len(self.names), self.size)
        driven = np.repeat([rates[1], rates[2]], [self.n_history, self.rotation.stop - self.rotation.start])
        out = np.concatenate([[rates[0] - state[1],
                               self.mass * rates[1] - (found["f_tangential_liquid"] + friction + self.weight),
                               self.inertia * rates[2] - (found["torque_liquid"] - self.radius * friction),
                               rates[3] - found["stretch_rate"]],
                              np.asarray(rates[modes]) - driven + np.asarray(state[modes]) / self.mode_times])
        if self.resolved and self.fluid is not None:  # the flow's added mass
            out[1:3] += self.fluid.mass[1:] @ np.r_[acceleration, rates[1:3]]
        return out

    def jacobian(self, state, gap: float, rate: float, film_gap: float, film_slope: float, engaged: float | None,
                 shift: float) -> tuple[np.ndarray, np.ndarray]:
        """(d G / d(x, U, Omega, xi, z) + shift d G / d(rates), d G / d(gap, V) of the wall): the block of the
        tangential rows (module docstring for what it leaves out)."""
        velocity, spin, stretch = state[1], state[2], state[self.STRETCH]
        a, n = self.radius, len(self.names)
        slip = velocity - a * spin
        _, _, f_slip, f_stretch, r_slip, r_stretch = self.friction.slopes(gap, rate, engaged, slip, stretch)
        _, _, resistance, slope, d_excess, d_normal, (d_gap, d_velocity) = self._liquid(film_gap, state, rate)
        own = np.zeros((self.size, self.size))
        own[0, 0], own[0, 1] = shift, -1.0
        own[1, 1] = shift * self.mass + resistance[0, 0] - d_excess - f_slip
        own[1, 2] = resistance[0, 1] + a * f_slip
        own[1, 3] = -f_stretch
        own[2, 1] = resistance[1, 0] + a * f_slip
        own[2, 2] = shift * self.inertia + resistance[1, 1] - a * a * f_slip
        own[2, 3] = a * f_stretch
        own[3, 1], own[3, 2], own[3, 3] = -r_slip, a * r_slip, shift - r_stretch
        along, spinning = self.translation, self.rotation
        own[1, along] = self.theory.history_coefficients(velocity)[:self.n_history]  # -d f_H / dz_i = c_i
        own[2, spinning] = self.spin_weights  # -d T_H / dzeta_i
        own[along, 1] = own[spinning, 2] = -shift  # the modes' own rows
        own[n:, n:] = np.diag(shift + 1.0 / self.mode_times)
        normal = np.zeros((self.size, 2))
        normal[1:3, 0] = film_slope * (slope @ np.array([velocity, spin]))
        own[2, 1] -= d_velocity  # the finite-Re torque's
        normal[2, 0] -= film_slope * d_gap
        normal[1, 1] = -d_normal  # the drag's inertia through the normal speed (the gap's rate is V)
        if self.resolved and self.fluid is not None:
            own[1:3, 1:3] += shift * self.fluid.mass[1:, 1:]
            normal[1:3, 1] += shift * self.fluid.mass[1:, 0]
        return own, normal
