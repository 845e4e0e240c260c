"""Friction in a Hertz contact, a tangential spring with Coulomb's limit, and the rigid theory of an oblique impact.

The tangential spring (`TangentialContact`).  While two surfaces touch, the contact point's tangential slip s (the
sphere's contact-point velocity relative to the wall, m/s) stretches a spring: the stretch xi [m] is the contact's
tangential displacement history, zero when the contact begins.  Its stiffness follows the normal one (Mindlin 1949,
as used by Thornton, Cummins & Cleary 2011, Powder Technol. 210, 189):

    k_t = kappa k_n,   kappa = 2 (1 - nu) / (2 - nu)   (`mindlin_ratio`, like materials),

k_n = dF/dx = (3/2) k x^(1/2) the Hertz contact's incremental normal stiffness at the overlap x
(k = (4/3) E* a*^(1/2), fem_bounce.contact.hertz_stiffness), so that k_t = 8 G* (a* x)^(1/2).  The force on the sphere:

    F_t = -k_t xi - eta_t s,   its size held to mu F_n,

F_n >= 0 the normal contact force, mu the friction coefficient: sticking or sliding, one force (continuous where
the two meet); in gross sliding the spring sits at its cap and |F_t| = mu F_n.  The stretch's rate (what an
integrator advances) is what tells them apart:
- sticking: d xi/dt = s while the contact unloads (k_t falling: the spring keeps its stretch and its force falls with
  k_t), and d xi/dt = s - xi (dk_t/dt) / k_t while it loads (k_t rising: the force changes by -k_t s dt, the
  stiffening adds none).  This is the update Thornton et al. (2011, 2013) use so that a varying stiffness never creates
  energy (their papers as the reference note summarises them, not read here; LAMMPS's `tangential mindlin_rescale`
  implements the same unloading rule);
- sliding: the stretch is held at the cap mu F_n / k_t in the direction it points, d xi/dt = (d cap/dt) xi / |xi|,
  plus the slip across that direction (which turns it toward the slip in two dimensions).  The contact slides while
  the stretch is at the cap and sticking would make the spring's force grow faster than mu dF_n/dt; else it sticks.
  The caller supplies dF_n/dt (for a sphere on a wall the normal motion does not depend on the tangential force).
`TangentialContact.jacobian` gives the force's and the rate's derivatives in every input, within the state found.

With these rules the kinetic energy plus the stored k_t |xi|^2 / 2 never rises (the argument in
`TangentialContact.rates`; tests/test_tangential_contact.py).  The tangential damping eta_t has the normal damping's
ratio for the tangential oscillation of a sticking sphere (`matched_damping`; after Thornton et al. 2013, Powder
Technol. 233, 30, whose tangential damping the reference note describes as matched to the normal one).

The rigid-body theory (`oblique_rigid_theory`): Coulomb friction on a rigid sphere without spin meeting a wall with
the normal restitution e_n (the rigid limit of Maw, Barber & Fawcett 1976, Wear 38, 101, as the reference note gives
it; Foerster, Louge, Chang & Allia 1994, Phys. Fluids 6, 1108 measured dry glass against it).  With psi = v_t / v_n
of the contact point (v_n the approach speed), a solid sphere (I = 2/5 m a^2) slides through the whole impact when
psi_in >= (7/2) mu (1 + e_n), and then psi_out = psi_in - (7/2) mu (1 + e_n); below, its contact point ends at rest
(rolling): psi_out = 0.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


def mindlin_ratio(poisson: float) -> float:
    """kappa = k_t / k_n = 2 (1 - nu) / (2 - nu): Mindlin's tangential over normal stiffness of a Hertz contact of two
    bodies of one material with Poisson's ratio nu (0.876 for glass, nu = 0.22)."""
    if not -1.0 < poisson < 0.5:
        raise ValueError(f"Poisson's ratio must lie in (-1, 0.5) (got {poisson})")
    return 2.0 * (1.0 - poisson) / (2.0 - poisson)


def hertz_tangential_stiffness(hertz_constant: float, overlap: float, ratio: float) -> tuple[float, float]:
    """(k_t [N/m], dk_t/dx [N/m^2]): kappa (3/2) k x^(1/2) for the Hertz constant k [N/m^1.5], the overlap x [m] and
    the ratio kappa; zero without overlap."""
    if overlap <= 0.0:
        return 0.0, 0.0
    root = math.sqrt(overlap)
    return 1.5 * ratio * hertz_constant * root, 0.75 * ratio * hertz_constant / root


def matched_damping(normal_damping: float, ratio: float, inertia_factor: float = 0.4) -> float:
    """eta_t [N s/m]: the tangential damping coefficient with the damping ratio of the normal one, `normal_damping`
    [N s/m] (dF_n / d(closing speed): c (m k)^(1/2) x^(1/4) for fem_bounce.contact's Tsuji law).  A sticking sphere of
    mass m and moment of inertia j m a^2 (j = `inertia_factor`) oscillates tangentially with the mass
    m_t = m j / (1 + j) on the stiffness kappa k_n, so that
    eta_t / eta_n = (m_t k_t / (m k_n))^(1/2) = (kappa j / (1 + j))^(1/2)."""
    return normal_damping * math.sqrt(ratio * inertia_factor / (1.0 + inertia_factor))


@dataclass(frozen=True)
class FrictionState:
    """What `TangentialContact.rates` finds: the tangential force on the sphere [N] (a vector like the slip), the
    stretch's rate [m/s], whether the contact slides, and the stretch the force is from [m] (sliding, the cap's)."""
    force: np.ndarray
    stretch_rate: np.ndarray
    sliding: bool
    stretch: np.ndarray | None = None


@dataclass(frozen=True)
class TangentialContact:
    """Coulomb friction `friction` (mu) in a contact whose tangential spring has the stiffness ratio
    `stiffness_ratio` (kappa, `mindlin_ratio`) to the normal one (module docstring)."""
    friction: float
    stiffness_ratio: float

    def __post_init__(self):
        if self.friction < 0.0:
            raise ValueError(f"the friction coefficient must be >= 0 (got {self.friction})")
        if self.stiffness_ratio <= 0.0:
            raise ValueError(f"the tangential stiffness ratio must be > 0 (got {self.stiffness_ratio})")

    def stiffness(self, hertz_constant: float, overlap: float) -> tuple[float, float]:
        """(k_t [N/m], dk_t/dx [N/m^2]) of this contact at the overlap x [m] of a Hertz law f = k x^(3/2)."""
        return hertz_tangential_stiffness(hertz_constant, overlap, self.stiffness_ratio)

    def cap(self, normal_force: float, stiffness: float) -> float:
        """The largest stretch the spring holds, mu F_n / k_t [m] (0 without normal force or stiffness)."""
        if normal_force <= 0.0 or stiffness <= 0.0:
            return 0.0
        return self.friction * normal_force / stiffness

    def rates(self, normal_force: float, normal_force_rate: float, stiffness: float, stiffness_rate: float,
              slip, stretch, damping: float = 0.0) -> FrictionState:
        """The tangential force and the stretch's rate for the normal force F_n [N] and its rate [N/s], the tangential
        stiffness k_t [N/m] and its rate [N/(m s)], the contact point's slip s [m/s] and the stretch xi [m] (scalars,
        or vectors in the wall's plane), and the tangential damping eta_t [N s/m].

        Energy, E = k_t |xi|^2 / 2 and P = -F_t . s the power the sphere gives the contact: sticking while loading,
        dE/dt - P = -eta_t |s|^2 - |xi|^2 (dk_t/dt) / 2 (the size limit clipping a damping force only lowers it);
        sticking while unloading, dE/dt - P = -eta_t |s|^2 + |xi|^2 (dk_t/dt) / 2; sliding, dE/dt - P <=
        -|xi|^2 |dk_t/dt| / 2 by the sliding condition (less with the damper; shown in one dimension, checked
        numerically in two).  None is positive."""
        slip, stretch = np.asarray(slip, dtype=float), np.asarray(stretch, dtype=float)
        zero = np.zeros_like(slip)
        if normal_force <= 0.0 or stiffness <= 0.0:  # nothing holds the spring (a new contact starts it at zero)
            return FrictionState(zero, zero, False, zero)
        limit = self.friction * normal_force
        cap = limit / stiffness
        size = float(np.linalg.norm(stretch))
        loading = stiffness_rate > 0.0
        sliding, rate = False, None
        if size >= cap * (1.0 - 1e-12):
            if size > 0.0:
                direction = stretch / size
            else:
                speed = float(np.linalg.norm(slip))
                direction = slip / speed if speed > 0.0 else zero
            along = float(np.sum(slip * direction))
            # how fast the spring's force would grow if the contact stuck, against how fast the limit grows
            growth = stiffness * along + (0.0 if loading else stiffness_rate * size)
            if np.any(direction) and growth >= self.friction * normal_force_rate:
                cap_rate = self.friction * (normal_force_rate - normal_force * stiffness_rate / stiffness) / stiffness
                sliding, rate = True, cap_rate * direction + (slip - along * direction)
                stretch = cap * direction
        if not sliding:
            rate = slip - stretch * (stiffness_rate / stiffness) if loading else slip
        # one force in both states, so that it is continuous where they meet: spring and damper, held to mu F_n
        force = -stiffness * stretch - damping * slip
        size_force = float(np.linalg.norm(force))
        if size_force > limit:
            force = force * (limit / size_force)
        return FrictionState(force, rate, sliding, stretch)

    def jacobian(self, normal_force: float, normal_force_rate: float, stiffness: float, stiffness_rate: float,
                 slip, stretch, damping: float = 0.0) -> dict[str, dict[str, np.ndarray]]:
        """The derivatives of `rates`'s force and stretch rate within the state it finds (sticking or sliding, the
        size limit active or not; the switches between them are not differentiable):
        {"force": {...}, "stretch_rate": {...}}, each keyed by the input ("slip", "stretch": d x d matrices;
        "normal_force", "normal_force_rate", "stiffness", "stiffness_rate", "damping": d-vectors), d the slip's
        dimension (1 for scalars).  For an integrator's exact Jacobian: chain them through F_n, k_t and their rates."""
        state = self.rates(normal_force, normal_force_rate, stiffness, stiffness_rate, slip, stretch, damping)
        slip, stretch = np.atleast_1d(np.asarray(slip, dtype=float)), np.atleast_1d(np.asarray(stretch, dtype=float))
        d = slip.size
        eye, none = np.eye(d), np.zeros(d)
        keys = ("normal_force", "normal_force_rate", "stiffness", "stiffness_rate", "damping")
        force = {"slip": np.zeros((d, d)), "stretch": np.zeros((d, d)), **{key: none.copy() for key in keys}}
        rate = {"slip": np.zeros((d, d)), "stretch": np.zeros((d, d)), **{key: none.copy() for key in keys}}
        if normal_force <= 0.0 or stiffness <= 0.0:
            return {"force": force, "stretch_rate": rate}
        mu = self.friction
        size = float(np.linalg.norm(stretch))
        if state.sliding:
            direction = stretch / size if size > 0.0 else slip / float(np.linalg.norm(slip))
            across = eye - np.outer(direction, direction)  # d direction / d stretch = across / |stretch|
            turn = across / size if size > 0.0 else np.zeros((d, d))
            along = float(slip @ direction)
            cap_rate = mu * (normal_force_rate - normal_force * stiffness_rate / stiffness) / stiffness
            raw = -mu * normal_force * direction - damping * slip
            force.update(slip=-damping * eye, stretch=-mu * normal_force * turn, normal_force=-mu * direction,
                         damping=-slip)
            rate.update(slip=across, stretch=(cap_rate * eye - along * eye - np.outer(direction, slip)) @ turn,
                        normal_force=-mu * stiffness_rate / stiffness**2 * direction,
                        normal_force_rate=mu / stiffness * direction,
                        stiffness=mu * (2.0 * normal_force * stiffness_rate / stiffness - normal_force_rate)
                        / stiffness**2 * direction,
                        stiffness_rate=-mu * normal_force / stiffness**2 * direction)
        else:
            raw = -stiffness * stretch - damping * slip
            force.update(slip=-damping * eye, stretch=-stiffness * eye, stiffness=-stretch, damping=-slip)
            rate["slip"] = eye.copy()
            if stiffness_rate > 0.0:
                rate.update(stretch=-stiffness_rate / stiffness * eye,
                            stiffness=stretch * stiffness_rate / stiffness**2, stiffness_rate=-stretch / stiffness)
        size_force = float(np.linalg.norm(raw))
        limit = mu * normal_force
        if size_force > limit:  # F = limit u, u = raw / |raw|: dF = limit (I - u u^T) d raw / |raw| + u d limit
            unit = raw / size_force
            project = limit / size_force * (eye - np.outer(unit, unit))
            for key, value in force.items():
                force[key] = project @ value
            force["normal_force"] = force["normal_force"] + mu * unit
        return {"force": force, "stretch_rate": rate}

    def stored_energy(self, stiffness: float, stretch) -> float:
        """k_t |xi|^2 / 2 [J]: the spring's elastic energy."""
        return 0.5 * stiffness * float(np.sum(np.asarray(stretch, dtype=float) ** 2))

    def energy(self, normal_force: float, normal_force_rate: float, stiffness: float, stiffness_rate: float,
               slip, stretch, damping: float = 0.0, force_rate: float | None = None) -> tuple[float, float, bool]:
        """(E [J], D [W], sliding) for `rates`'s inputs: the spring's stored energy k_t |xi|^2 / 2 of the stretch
        the force is from, the power the contact dissipates, D = P - dE/dt with P = -F_t . s the power the sphere
        gives it and dE/dt = k_t xi . dxi/dt + |xi|^2 (dk_t/dt) / 2 along the stretch's rate (never negative:
        `rates`), and whether it slides (the loss audit, fem_bounce.losses).  `force_rate`, the normal force's
        actual rate where the spring reads another (the elastic part's): a sliding contact's stretch is the cap
        mu F_n / k_t, which moves with it, whatever the rate the spring is given."""
        state = self.rates(normal_force, normal_force_rate, stiffness, stiffness_rate, slip, stretch, damping)
        held, slip = state.stretch, np.asarray(slip, dtype=float)
        squared = float(np.sum(held**2))
        stored_rate = stiffness * float(np.sum(held * state.stretch_rate)) + 0.5 * squared * stiffness_rate
        if state.sliding and force_rate is not None:  # k_t |xi| d cap/dt, the cap's rate from the actual one
            stored_rate += math.sqrt(squared) * self.friction * (force_rate - normal_force_rate)
        power = -float(np.sum(state.force * slip))
        return 0.5 * stiffness * squared, power - stored_rate, state.sliding


@dataclass(frozen=True)
class ObliqueImpact:
    """The rigid-body theory's outcome (`oblique_rigid_theory`): psi_out = v_t,out / v_n,in of the contact point, the
    tangential restitution e_t = v_t,out / v_t,in of the contact point (0 for psi_in = 0), the spin after as
    a Omega / v_n,in (positive in the rolling sense), the centre's tangential velocity after over v_n,in, and whether
    the sphere slid throughout."""
    psi_out: float
    tangential_restitution: float
    spin_out: float
    tangential_velocity_out: float
    sliding: bool


def sliding_threshold(normal_restitution: float, friction: float, inertia_factor: float = 0.4) -> float:
    """psi_in above which a sphere without spin slides through the whole impact: (1 + 1/j) mu (1 + e_n),
    j = I / (m a^2) ((7/2) mu (1 + e_n) for a solid sphere)."""
    return (1.0 + 1.0 / inertia_factor) * friction * (1.0 + normal_restitution)


def oblique_rigid_theory(psi_in: float, normal_restitution: float, friction: float,
                         inertia_factor: float = 0.4) -> ObliqueImpact:
    """Coulomb's rigid-body oblique impact of a sphere without initial spin on a wall (module docstring):
    psi_in = v_t,in / v_n,in of the contact point (either sign), e_n, mu and j = I / (m a^2) (2/5, a solid sphere)."""
    if normal_restitution < 0.0 or friction < 0.0 or inertia_factor <= 0.0:
        raise ValueError("the restitution and friction must be >= 0 and the inertia factor > 0 "
                         f"(got {normal_restitution}, {friction}, {inertia_factor})")
    sign, size = math.copysign(1.0, psi_in), abs(psi_in)
    threshold = sliding_threshold(normal_restitution, friction, inertia_factor)
    if size >= threshold and size > 0.0:
        impulse = friction * (1.0 + normal_restitution)  # the tangential impulse over m v_n,in
        psi_out = size - threshold
        restitution, sliding = psi_out / size, True
    else:
        impulse = size * inertia_factor / (1.0 + inertia_factor)  # what brings the contact point to rest
        psi_out, restitution, sliding = 0.0, 0.0, False
    return ObliqueImpact(sign * psi_out, restitution, sign * impulse / inertia_factor, sign * (size - impulse),
                         sliding)


def oblique_record(start: float, speed_in: float, velocity_in: float, spin_in: float, end: float, speed_out: float,
                   velocity_out: float, spin_out: float, radius: float) -> dict:
    """One oblique impact seen at one station, from the centre's normal speed, its velocity along the wall and its
    spin where the collision passes it on the way in and out [s, m/s, 1/s, m]: the contact gap (the collision of the
    solids within the film) or delta_sl D (the collision with its near-wall layer of liquid, where the package's
    restitution is taken).  As Joseph & Hunt (2004) give theirs, with the contact point's
    tangential velocity v_t = U - a Omega, psi = v_t / v_n,in, the normal restitution v_n,out / v_n,in, the
    tangential v_t,out / v_t,in, and the effective friction |U_in - U_out| / (v_n,in + v_n,out) (the tangential
    impulse over the normal one, the liquid's share included)."""
    contact_in, contact_out = velocity_in - radius * spin_in, velocity_out - radius * spin_out
    return {"time": start, "end": end, "incidence_deg": math.degrees(math.atan2(abs(velocity_in), speed_in)),
            "normal_speed_in": speed_in, "normal_speed_out": speed_out, "tangential_velocity_in": velocity_in,
            "tangential_velocity_out": velocity_out, "spin_in": spin_in, "spin_out": spin_out,
            "contact_velocity_in": contact_in, "contact_velocity_out": contact_out,
            "psi_in": contact_in / speed_in, "psi_out": contact_out / speed_in,
            "normal_restitution": speed_out / speed_in,
            "tangential_restitution": contact_out / contact_in if contact_in != 0.0 else None,
            "effective_friction": abs(velocity_in - velocity_out) / (speed_in + speed_out)}
