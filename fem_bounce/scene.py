"""What is simulated: a scene is everything a run needs, in SI units.

A scene is a tree of frozen dataclasses loaded from TOML (a shipped preset or a
user's file), checked on load, and written back resolved beside every result.
Each field declares its allowed range once (`_positive`, `_between`, `_choice`),
so the error for a bad value names the field and the range.  Dimensionless
groups (Re, St, density ratio) are derived here and never typed in twice.

Conventions: z points away from the wall, velocity is positive upward, the gap
`h` is the distance from the sphere's lowest point to the wall and
`delta = h / D` (paper section 4).
"""
from __future__ import annotations

import csv
import dataclasses
import difflib
import hashlib
import json
import math
import numbers
import os
import re
import tomllib
import typing
import warnings
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from typing import Any

from . import numerics, reference
from .errors import Error
from .materials import elastohydrodynamic_gap, reduced_modulus

AXISYMMETRIC_RE_LIMIT = 250.0  # paper section 2.1: axisymmetric flow below Re ~ 210-250
# An unbounded scene's largest initial gap, in diameters: far beyond any wall effect (Brenner's correction
# ~ (9/16) D / h is then 1e-10) and still far from overflow in the force formulas (1e300 m overflowed).
MAX_GAP_DIAMETERS = 1e10
# A free sphere released from rest this close to neutral buoyancy barely moves: its velocity stays inside
# the integrator's event tolerance for ~0.015 / |ratio - 1| steps of 1e-7 sqrt(D/g) (measured: 1e-6 took
# 6,314 steps where 1e-5 took 966 on li2011-case3; 1e-7 reached 0.19 ms in 50,000; ratio 1 never ends:
# benchmarks/neutral_buoyancy.py).
NEUTRAL_BUOYANCY = 1e-5
# Where the material bounds come from (each also keeps every formula finite in double precision):
DIAMETER_NOTE = ("below 1 um Brownian motion, not modelled, moves the sphere; 1e3 m lets a second sphere stand in "
                 "for a wall (the pair's wall limit)")
SOLID_DENSITY_NOTE = "the densest solid, osmium, is 2.26e4 kg/m3"
MODULUS_NOTE = "from the softest gels, ~1e2 Pa, to beyond diamond, the stiffest solid, 1.2e12 Pa"
MODULUS_MIN = 1e2
LIQUID_DENSITY_NOTE = ("the densest liquid, mercury, is 1.35e4 kg/m3; down to 1e-30 for near-dry checks, below "
                       "which the flow's kinematic viscosity overflows the solvers")
ROUGHNESS_NOTE = "the height of the surface's asperities; Li et al. (2011) section 3.1 give 0.02 um (2e-8 m)"
VISCOSITY_NOTE = ("pitch is ~1e8 Pa s; above it the sphere's viscous relaxation time m / (6 pi mu a) falls below "
                  "the integrator's smallest step and a run stops advancing")
# The contact gap h_c (lubricated-hertz: contact_gap_factor x the larger of the roughness and the elastohydrodynamic gap
# x_d at the impact speed) must stay thin against the spheres: below this fraction of the reduced radius a*, where
# Hertz's small-strain contact holds (contact.MAX_OVERLAP), and below delta_sl times the gap scale, where the contact
# takes over from the lubrication.  Softer solids start their contact a sizeable part of a diameter away (Young's
# modulus 1e-10 Pa: 1.6 D above the wall).
FILM_GAP_FRACTION = 0.1
# ... and no thinner than a continuum film: a few molecular diameters (water 0.28 nm, glycerol ~0.5 nm), below which
# a confined liquid is molecular layers, not Reynolds' film (Israelachvili 2011, Intermolecular and Surface Forces,
# 3rd ed., ch. 15), nor than the surfaces' combined roughness, where their asperities already touch.
MOLECULAR_GAP = 1e-9
# A run's end time, in time units (sqrt(D/g), or D over the launch speed without gravity), when nothing ends it earlier
# (free spheres over a wall come to rest on it, or stall in its film: integrator.py; a pair without a wall drifts on,
# a held or prescribed sphere goes on): the ode model's largest step is 0.02 of them, so 1e5 is 5e6 steps (~40 min).
MAX_END_TIME_UNITS = 1e5
# contact.model = "ehd": the gap where the film collision takes over (docs/ehd.md), and its bounds
EHD_HANDOVER = 20e-6
EHD_HANDOVER_NOTE = ("the film collision's handover gap h0: thin against the sphere's radius (below 0.1 a, and "
                     "below contact.delta_sl D, for Reynolds' film) and at least 10 elastohydrodynamic gaps x_d "
                     "at the estimated impact speed (the surfaces still rigid at h0: DSH's epsilon below 0.003)")
# the most tension a liquid film has been reported to hold is of the order of -30 MPa (water in
# Briggs' (1950) spinning tube); the bound only keeps the number physical
CAVITATION_PRESSURE_MIN = -1e8
CAVITATION_WORDS = ("auto", "liquid", "off")
CAVITATION_ALLOWED = (f"{', '.join(repr(w) for w in CAVITATION_WORDS)} or a number in [{CAVITATION_PRESSURE_MIN:g}, 0] "
                      "Pa")
ONE_ATMOSPHERE = 101325.0  # Pa, the standard atmosphere
# water's vapour pressure at 20 C (Wagner & Pruss 2002, J. Phys. Chem. Ref. Data 31, 387: IAPWS-95), the
# largest an aqueous liquid has at room temperature; the presets give their liquid's own (docs/physics.md 3.5)
WATER_VAPOUR_PRESSURE_20C = 2339.0
PRESSURE_NOTE = "absolute; from a vacuum to 1e9 Pa (10,000 atm)"
# keys that were renamed: what a scene file written before says now
# (numerics.fd.cfl and numerics.fd3d.cfl: the same number under a name that says it is not ale's and ib's cfl)
_PEAK_CFL = ("the same number: the Courant number at the peak fluid speed 1.5 U (numerics.ale.cfl and "
             "numerics.ib.cfl are at the speed scale U)")
RENAMED = {"contact.ehd_cavitation": "contact.cavitation_pressure (\"off\", \"liquid\", \"auto\" or a pressure; the "
                                     "default \"auto\" now limits every film's tension, the ehd film's included)",
           "numerics.fd.cfl": f"numerics.fd.peak_cfl, {_PEAK_CFL}",
           "numerics.fd3d.cfl": f"numerics.fd3d.peak_cfl, {_PEAK_CFL}"}
_PLAIN_NAME = re.compile(r"[^/\\\x00-\x1f\x7f.][^/\\\x00-\x1f\x7f]{0,99}")


class SceneError(Error, ValueError):
    """A scene value is missing, unknown or out of range; the message names the key."""


# -- declarative field ranges ------------------------------------------------------------


def _positive(default: Any = dataclasses.MISSING, unit: str = "", hi: float | None = None, note: str = "") -> Any:
    """> 0, and <= hi when given (`note` says where the bound comes from)."""
    return _between(0.0, hi, default, unit, open_low=True, note=note)


def _between(lo, hi, default: Any = dataclasses.MISSING, unit: str = "", open_ends=False, open_low=None,
             note: str = "", kw_only: bool = False) -> Any:
    """[lo, hi], or (lo, hi) with open_ends; open_low alone opens only the lower end.  `note` says
    what the value means, after a range error."""
    low = open_ends if open_low is None else open_low
    return field(default=default, kw_only=kw_only,
                 metadata={"range": (lo, hi, low, open_ends), "unit": unit, "note": note})


def _choice(*options: str) -> Any:
    return field(default=options[0], metadata={"choices": options})


def _allowed(lo, hi, lo_open, hi_open) -> str:
    if hi is None:
        return f"{'>' if lo_open else '>='} {lo:g}"
    return f"in {'(' if lo_open else '['}{lo:g}, {hi:g}{')' if hi_open else ']'}"


def _check_fields(obj: Any, prefix: str) -> None:
    """Check every declared range of a dataclass tree; raise SceneError naming the key."""
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        key = f"{prefix}{f.name}"
        if dataclasses.is_dataclass(value):
            _check_fields(value, key + ".")
            continue
        if isinstance(value, tuple):  # an array of tables ([[further_spheres]])
            for k, item in enumerate(value):
                _check_fields(item, f"{key}[{k}].")
            continue
        if isinstance(value, str) and any("\ud800" <= ch <= "\udfff" for ch in value):
            raise SceneError(f"{key} = {value!r} holds bytes that are not UTF-8 text (a lone surrogate): give it as "
                             "UTF-8 text")
        if "choices" in f.metadata and value not in f.metadata["choices"]:
            allowed = ", ".join(repr(c) for c in f.metadata["choices"])
            raise SceneError(f"{key} = {value!r} is not one of {allowed}")
        if "range" in f.metadata and value is not None:
            lo, hi, lo_open, hi_open = f.metadata["range"]
            unit = (" " + f.metadata["unit"]) if f.metadata.get("unit") else ""
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise SceneError(f"{key} = {value!r} must be a finite number")
            below = value <= lo if lo_open else value < lo
            above = hi is not None and (value >= hi if hi_open else value > hi)
            if below or above:
                note = f" ({f.metadata['note']})" if f.metadata.get("note") else ""
                raise SceneError(f"{key} = {value!r}{unit} is out of range: allowed "
                                 f"{_allowed(lo, hi, lo_open, hi_open)}{unit}{note}")


# -- the scene -------------------------------------------------------------------------


@dataclass(frozen=True)
class Sphere:
    diameter: float = _between(1e-6, 1e3, unit="m", note=DIAMETER_NOTE)
    density: float = _positive(unit="kg/m3", hi=1e5, note=SOLID_DENSITY_NOTE)
    youngs_modulus: float = _between(MODULUS_MIN, 1e13, unit="Pa", note=MODULUS_NOTE)
    poisson_ratio: float = _between(-1.0, 0.5, open_ends=True, note="an isotropic solid's range")
    # keyword-only so that SecondSphere's own required fields may follow it
    roughness: float = _between(0.0, 1e-3, 0.0, unit="m", note=ROUGHNESS_NOTE, kw_only=True)

    @property
    def radius(self) -> float:
        return 0.5 * self.diameter

    @property
    def volume(self) -> float:
        return math.pi * self.diameter**3 / 6.0

    @property
    def mass(self) -> float:
        return self.density * self.volume


def reduced_radius(a1: float, a2: float) -> float:
    """a* = a1 a2 / (a1 + a2) [m]: the radius of the sphere whose wall-lubrication equals the pair's."""
    return a1 * a2 / (a1 + a2)


def pair_diameter(first: Sphere, second: Sphere) -> float:
    """2 a*, the pair's reduced diameter [m]: the length that scales the gap of a pair (delta = h / (2 a*)),
    as D scales a sphere's gap to a wall (a2 -> infinity gives D1)."""
    return 2.0 * reduced_radius(first.radius, second.radius)


@dataclass(frozen=True)
class Liquid:
    """The liquid's density and viscosity, and the two pressures that bound the tension a film of it can
    hold (contact.cavitation_pressure): the ambient pressure above the liquid and its vapour pressure."""

    density: float = _between(1e-30, 1e5, unit="kg/m3", note=LIQUID_DENSITY_NOTE)
    viscosity: float = _positive(unit="Pa s", hi=1e8, note=VISCOSITY_NOTE)
    ambient_pressure: float = _between(0.0, 1e9, ONE_ATMOSPHERE, unit="Pa",
                                       note="the pressure above the liquid, " + PRESSURE_NOTE)
    vapour_pressure: float = _between(0.0, 1e9, WATER_VAPOUR_PRESSURE_20C, unit="Pa",
                                      note="the liquid's vapour pressure, " + PRESSURE_NOTE)

    @property
    def kinematic_viscosity(self) -> float:
        return self.viscosity / self.density


@dataclass(frozen=True)
class SecondSphere(Sphere):
    """A second sphere on the axis above the first (a head-on pair): its own material, the initial gap
    between the two surfaces and its initial velocity (positive away from the wall).  free: moves under
    the liquid, gravity and contact; fixed: held at its initial position, its surface moving at `velocity`
    (as motion.mode = "fixed" holds sphere 1: a quasi-steady approach); prescribed: moves at `velocity`
    throughout."""

    gap: float = _positive(unit="m")
    velocity: float = _between(-100.0, 100.0, 0.0, unit="m/s")
    mode: str = _choice("free", "fixed", "prescribed")
    # a pair meeting off its line of centres (the ode model; docs/physics.md, "Oblique collisions"): the motion stays
    # in the plane x-z, the line of centres along z at the start
    tangential_velocity: float = _between(-100.0, 100.0, 0.0, unit="m/s",
                                          note="a free second sphere's velocity across the line of centres (x) at "
                                               "the start")
    spin: float = _between(-1e6, 1e6, 0.0, unit="1/s",
                           note="a free second sphere's angular velocity about y at the start (the sign of the "
                                "scene's spin)")


@dataclass(frozen=True)
class Wall:
    """The plane z = 0.  Without it (present = false) z = 0 is only the origin (and the bottom of the
    domain a resolved model meshes, an open boundary there); its elastic constants are then unused."""

    youngs_modulus: float | None = _between(MODULUS_MIN, 1e13, None, unit="Pa", note=MODULUS_NOTE)
    poisson_ratio: float | None = _between(-1.0, 0.5, None, open_ends=True, note="an isotropic solid's range")
    present: bool = True
    roughness: float = _between(0.0, 1e-3, 0.0, unit="m", note=f"{ROUGHNESS_NOTE} for their Zerodur block")


@dataclass(frozen=True)
class Container:
    """The axisymmetric domain's walls; both None means unbounded (slip far field)."""

    radius: float | None = _positive(None, unit="m")
    height: float | None = _positive(None, unit="m")

    @property
    def unbounded(self) -> bool:
        return self.radius is None


@dataclass(frozen=True)
class Contact:
    """The contact model (docs/physics.md sections 2-4; fem_bounce.contact).

    model: "lubricated-hertz" (default): lubrication down to a contact gap computed from the scene (the
      surfaces' roughness or the elastohydrodynamic gap), then a damped Hertz contact with the real E*;
      "li2011": the paper's model as written (eq. 4.5-4.9: the blend, f_thr with the multiplied
      Schiller-Naumann drag and the spring e_d W_o F(delta/delta_ss)).
    near_wall: how a resolved model's force meets the near-wall theory below delta_sl.
      "correction": the flow's sphere stops approaching at delta_sl and the unresolved part of the
      lubrication force, -6 pi mu a V [lambda(delta) - lambda(delta_sl)], is added to the resolved
      force (Costa et al. 2015, with the resolved geometry held);  "blend": the paper's eq. 4.5,
      f_sl = H f_thr + (1 - H) f_sim;  "auto": the model's own (correction; blend for li2011 with one
      sphere, Scene.near_wall_law).  The ODE
      model uses f_thr everywhere under either.
    inertial_factor: "auto" is "screened" (lubricated-hertz, ehd) or "schiller-naumann" (li2011); "additive" adds
      the inertial excess to the wall's unscreened: theory.py, docs/physics.md 3.7.
    inertial_speed: in an oblique collision, the speed whose Re sets the drag's inertial factor: "component",
      the normal drag the normal speed's and the drag along the wall the speed along it; "whole", both the whole
      speed's |u| (the quasi-steady drag of a free sphere, along its velocity): measured against the 3-D model in
      docs/validation.md section 14, where it does worse on the rebound.
    lift: in an oblique collision at a wall, the lift of the sphere sliding along it (fem_bounce.wall_lift: the
      3-D model's steady lift on a sphere translating parallel to a wall at finite Re), on the normal motion of the
      reduced model (and of a resolved model's "blend"): "steady" or "off".
    wall_torque: in an oblique collision at a wall, the torque of the sphere sliding along it at finite Re beyond
      the Stokes film's (fem_bounce.wall_lift.WallTorque, measured with the 3-D model as the lift is), on the
      reduced model's spin: "steady" or "off".
    delta_ss: the paper's elastic layer, li2011 only.
    tangential_stiffness: in an oblique collision, the ratio k_t / k_n of the sticking contact's tangential spring
      to the Hertz contact's normal stiffness (fem_bounce.tangential_contact); unset (the default): Mindlin's
      4 G*/E* from the materials (0.74-0.88 for the presets' solids); 1e4: the contact point stops dead while it
      sticks, the rigid-body theory's rolling (docs/validation.md section 13).
    "ehd" (one sphere and a wall): lubricated-hertz's lubrication down to the handover gap
      ehd_handover [m], where the elastohydrodynamic film collision of Davis, Serayssol & Hinch (1986)
      (fem_bounce.ehd, docs/ehd.md) takes the sphere to its rebound at the same gap, or to rest.
    history_across_contact: "keep": the history force's memory takes in the whole path, the contact's
      reversal included; "pause": it does not take in a sphere's acceleration while the sphere is in a
      contact (its memory only decays there; docs/physics.md 3.6).
    cavitation_pressure: the lowest (gauge) pressure a lubrication film holds as the surfaces separate
      (fem_bounce.cavitation, docs/physics.md section 3.5): "liquid" computes it from the liquid,
      vapour - ambient - rho_l g (container height); a number in [-1e8, 0] Pa sets it (sensitivity);
      "off": the film holds any tension (the rigid film's full suction); "auto": "liquid", or "off" for
      the paper's model (li2011), which stays as written."""

    model: str = _choice("lubricated-hertz", "li2011", "ehd")
    near_wall: str = _choice("auto", "correction", "blend")
    delta_sl: float = _between(0.0, 0.5, 0.2, open_low=True,
                               note="the gap, in diameters, below which the contact model supplies the near-wall force")
    delta_ss: float = _positive(0.017)
    dry_restitution: float = _between(0.0, 1.0, 0.97)
    contact_gap_factor: float = _between(0.0, 1e3, 1.0, open_low=True,
                                         note="multiplies the computed contact gap h_c (lubricated-hertz): "
                                              "1 is the physical value; others are for sensitivity studies")
    wall_drag: str = _choice("brenner", "simple")
    inertial_factor: str = _choice("auto", "additive", "screened", "schiller-naumann", "none")
    inertial_speed: str = _choice("component", "whole")
    lift: str = _choice("steady", "off")
    wall_torque: str = _choice("steady", "off")
    added_mass: str = _choice("first-image", "exact")
    history: str = _choice("mei-adrian", "off")
    history_wall_factor: str = _choice("one", "drag-scaled")
    history_across_contact: str = _choice("keep", "pause")
    history_c1: float = _between(0.1, 100.0, 2.0, note="Mei & Adrian's (1992) constant is 2; the history kernel's "
                                 "exponential fit (theory.history_modes) is built and checked for 0.1-100")
    history_c2: float = _between(0.0, 10.0, 0.105)
    ehd_handover: float = _positive(EHD_HANDOVER, unit="m", note=EHD_HANDOVER_NOTE)
    cavitation_pressure: str | float = field(default="auto", metadata={"allowed": CAVITATION_ALLOWED})
    friction: float | None = _between(0.0, 2.0, None, note="the sphere-wall pair's Coulomb coefficient, for an "
                                      "oblique collision (Scene.oblique)")
    tangential_stiffness: float | None = _between(0.0, 1e6, None, open_low=True,
                                                  note="k_t / k_n of the friction's tangential spring; unset: "
                                                       "Mindlin's 4 G*/E* from the two solids' E and nu")

    @property
    def paper(self) -> bool:
        """The paper's model as written (contact.model = "li2011")."""
        return self.model == "li2011"

    @property
    def inertial_law(self) -> str:
        """inertial_factor with "auto" resolved."""
        if self.inertial_factor != "auto":
            return self.inertial_factor
        return "schiller-naumann" if self.paper else "screened"


@dataclass(frozen=True)
class Motion:
    """free: falls and bounces.  fixed: held at the initial gap, its surface moving at
    `velocity` (a quasi-steady approach) in a stream of `stream_velocity` entering
    through z = 0.  prescribed: moves with `velocity`, or along the (t, velocity) CSV
    `series` when one is given."""

    mode: str = _choice("free", "fixed", "prescribed")
    velocity: float = _between(-100.0, 100.0, 0.0, unit="m/s")
    stream_velocity: float = _between(-100.0, 100.0, 0.0, unit="m/s")
    series: str = ""


def read_series(path: str) -> tuple[list[float], list[float]]:
    """(t [s], velocity [m/s]) of a prescribed motion's CSV (columns t and velocity, '#' lines skipped),
    checked: UTF-8, finite numbers, two rows or more, t increasing and starting at or before 0."""
    what = f"motion.series = {path!r}"
    file = Path(path)
    if not file.is_file():
        raise SceneError(f"{what}: no such file" if not file.exists() else f"{what}: not a regular file")
    try:
        lines = [line for line in file.read_bytes().decode("utf-8-sig").splitlines() if not line.startswith("#")]
    except (OSError, UnicodeDecodeError) as err:
        raise SceneError(f"{what}: cannot be read as UTF-8 text ({err})") from None
    rows = list(csv.DictReader(lines))
    try:
        times = [float(row["t"]) for row in rows]
        velocity = [float(row["velocity"]) for row in rows]
    except (KeyError, TypeError, ValueError):
        raise SceneError(f"{what}: needs a header t,velocity and a number in both columns of every row") from None
    if len(times) < 2:
        raise SceneError(f"{what}: has {len(times)} row(s); a series needs at least 2")
    if not all(math.isfinite(x) for x in times + velocity):
        raise SceneError(f"{what}: holds a value that is not finite (nan or inf)")
    if any(later <= earlier for earlier, later in zip(times, times[1:])):
        raise SceneError(f"{what}: the times t must increase from row to row")
    if times[0] > 0.0:
        raise SceneError(f"{what}: starts at t = {times[0]:g} s; it must cover the start of the run, t = 0")
    return times, velocity


@dataclass(frozen=True)
class Run:
    end_time: float = _positive(1.0, unit="s")
    bounces: int = _between(0, 1000, 0)  # stop at the apex after this many impacts; 0: no limit


@dataclass(frozen=True)
class Reference:
    """Measured values to compare with, where the scene has them."""

    impact_speed: float | None = _positive(None, unit="m/s")  # first impact, 2 ms mean
    re_first: float | None = _positive(None)
    re_second: float | None = _positive(None)
    peak_speed: float | None = _positive(None, unit="m/s")
    velocity_curve: str = ""  # name of a packaged CSV (t_s, u_m_per_s)
    source: str = ""


@dataclass(frozen=True)
class Numerics:
    ode: numerics.OdeNumerics = field(default_factory=numerics.OdeNumerics)
    fd: numerics.FdNumerics = field(default_factory=numerics.FdNumerics)
    ib: numerics.IbNumerics = field(default_factory=numerics.IbNumerics)
    ale: numerics.AleNumerics = field(default_factory=numerics.AleNumerics)
    fd3d: numerics.Fd3dNumerics = field(default_factory=numerics.Fd3dNumerics)


@dataclass(frozen=True)
class Scene:
    sphere: Sphere
    liquid: Liquid
    wall: Wall
    initial_gap: float = _positive(unit="m")
    initial_velocity: float = _between(-100.0, 100.0, 0.0, unit="m/s",
                                       note="a free sphere's velocity at the start, positive away from the wall: "
                                            "a sphere launched at the wall, as on Joseph et al.'s (2001) pendulum")
    gravity: float = _between(0.0, 1000.0, 9.81, unit="m/s2",
                              note="it pulls the sphere to the wall and sets the time unit sqrt(D/g); 0 only "
                                   "for a sphere launched by initial_velocity or a pair set in motion by "
                                   "second_sphere.velocity")
    # an oblique collision (the ode model; docs/physics.md, "Oblique collisions"): the motion stays in the plane of
    # incidence x-z by symmetry, so the wall-parallel velocity, the spin and gravity's tilt are each one number
    tangential_velocity: float = _between(-100.0, 100.0, 0.0, unit="m/s",
                                          note="a free sphere's velocity along the wall (x) at the start")
    spin: float = _between(-1e6, 1e6, 0.0, unit="1/s",
                           note="a free sphere's angular velocity about y at the start, positive in the rolling sense "
                                "of motion along +x")
    gravity_angle: float = _between(-89.0, 89.0, 0.0, unit="degrees",
                                    note="gravity's angle to the wall's normal: an inclined wall, gravity's "
                                         "wall-parallel part along +x for a positive angle")
    name: str = "scene"
    description: str = ""
    container: Container = field(default_factory=Container)
    contact: Contact = field(default_factory=Contact)
    motion: Motion = field(default_factory=Motion)
    run: Run = field(default_factory=Run)
    reference: Reference = field(default_factory=Reference)
    numerics: Numerics = field(default_factory=Numerics)
    second_sphere: SecondSphere | None = None
    # the spheres above the second, lowest first ([[further_spheres]], each with the second_sphere fields,
    # its gap measured from the sphere below it): a column of three or more (fem_bounce.bodies)
    further_spheres: tuple[SecondSphere, ...] = ()

    # -- derived quantities (never typed in) --
    @property
    def oblique(self) -> bool:
        """The sphere moves along the wall or spins, or gravity is tilted, or a sphere above it moves across the line
        of centres or spins: the motion leaves the axis."""
        return (self.tangential_velocity != 0.0 or self.spin != 0.0 or self.gravity_angle != 0.0
                or any(s.tangential_velocity != 0.0 or s.spin != 0.0 for _, s in self._upper_spheres()))

    @property
    def pair(self) -> bool:
        """More than one sphere on the axis (second_sphere given): the pair's outputs (collisions, the
        columns with suffixes)."""
        return self.second_sphere is not None

    @property
    def cavitation_pressure(self) -> float | None:
        """The lowest gauge pressure a lubrication film holds [Pa, <= 0] (contact.cavitation_pressure resolved),
        None when it holds any.  From the liquid: its vapour pressure less the absolute pressure at the wall,
        the ambient pressure plus the head rho_l g H of a container of height H (unbounded: the ambient
        pressure alone)."""
        setting = self.contact.cavitation_pressure
        if setting == "auto":
            setting = "off" if self.contact.paper else "liquid"
        if setting == "off":
            return None
        if setting != "liquid":
            return float(setting)
        head = self.liquid.density * self.gravity * (self.container.height or 0.0)
        return min(self.liquid.vapour_pressure - self.liquid.ambient_pressure - head, 0.0)

    @property
    def near_wall_law(self) -> str:
        """contact.near_wall with "auto" resolved: "blend" for the paper's model (li2011) with one sphere,
        else "correction" (a pair has only the correction)."""
        c = self.contact
        if c.near_wall != "auto":
            return c.near_wall
        return "blend" if c.paper and not self.pair else "correction"

    @property
    def spheres(self) -> tuple[Sphere, ...]:
        """Sphere 1 (nearest z = 0), then the second sphere and the further ones if there are."""
        return (self.sphere, *(sphere for _, sphere in self._upper_spheres()))

    @property
    def initial_gaps(self) -> tuple[float, ...]:
        """Each sphere's lowest point above z = 0 at the start [m]."""
        gaps = [self.initial_gap]
        for below, sphere in zip(self.spheres, self.spheres[1:]):
            gaps.append(gaps[-1] + below.diameter + sphere.gap)
        return tuple(gaps)

    @property
    def density_ratio(self) -> float:
        return self.sphere.density / self.liquid.density

    @property
    def displaced_mass(self) -> float:
        """m_l: the mass of liquid the sphere displaces [kg]."""
        return self.liquid.density * self.sphere.volume

    @property
    def time_unit(self) -> float:
        """sqrt(D/g), the paper's time unit [s]; without gravity D over the launch speed."""
        if self.gravity == 0.0:
            return self.sphere.diameter / self.launch_speed
        return math.sqrt(self.sphere.diameter / self.gravity)

    @property
    def velocity_unit(self) -> float:
        """sqrt(g D), the paper's velocity unit [m/s]; without gravity the launch speed."""
        return self.sphere.diameter / self.time_unit

    def reynolds(self, speed: float) -> float:
        return self.liquid.density * self.sphere.diameter * abs(speed) / self.liquid.viscosity

    def drag_coefficient(self, force, speed: float):
        """Cd = F / (rho_l U^2 pi a^2 / 2) of a force F [N] (a number or an array) at the speed U [m/s]."""
        return force / (0.5 * self.liquid.density * speed**2 * math.pi * self.sphere.radius**2)

    def stokes(self, speed: float) -> float:
        """St = (1/9) (rho_p / rho_l) Re (paper section 1)."""
        return self.density_ratio * self.reynolds(speed) / 9.0

    def terminal_speed(self) -> float:
        """Unbounded settling speed with Schiller-Naumann drag [m/s]."""
        weight = abs(self.sphere.mass - self.displaced_mass) * self.gravity
        drag_unit = 3.0 * math.pi * self.liquid.viscosity * self.sphere.diameter
        speed = weight / drag_unit
        for _ in range(100):  # fixed point on the inertial factor; converges in a few
            speed = weight / (drag_unit * (1.0 + 0.15 * self.reynolds(speed) ** 0.687))
        return speed

    def estimated_impact_speed(self) -> float:
        """Upper estimate: inviscid fall over the initial gap from the launch speed, capped by the larger of
        the terminal and the launch speed."""
        m_eff = self.sphere.mass + 0.5 * self.displaced_mass
        accel = abs(self.sphere.mass - self.displaced_mass) * self.gravity / m_eff
        launch = abs(self.initial_velocity)
        return min(math.sqrt(launch**2 + 2.0 * accel * self.initial_gap), max(self.terminal_speed(), launch))

    def validate(self) -> "Scene":
        """Check every range and the relations between fields; return self."""
        _check_fields(self, "")
        if not _PLAIN_NAME.fullmatch(self.name):
            raise SceneError(f"name = {self.name!r} must be a plain name of 1-100 printable characters, without '/' "
                             "and not starting with '.': it names the run directory runs/NAME-MODEL")
        diameter, free = self.sphere.diameter, self.motion.mode == "free"
        if free and abs(self.density_ratio - 1.0) < NEUTRAL_BUOYANCY:
            if self.sphere.density == self.liquid.density:
                raise SceneError(f"sphere.density = {self.sphere.density:g} kg/m3 equals liquid.density: a neutrally "
                                 "buoyant sphere released from rest never moves; make it heavier or lighter")
            raise SceneError(f"sphere.density = {self.sphere.density:.8g} kg/m3 is within {NEUTRAL_BUOYANCY:g} of "
                             f"liquid.density = {self.liquid.density:.8g} kg/m3 "
                             f"(density ratio {self.density_ratio:.8g}): "
                             "so nearly neutrally buoyant a sphere barely moves and its integration crawls; make "
                             f"|density ratio - 1| at least {NEUTRAL_BUOYANCY:g}")
        lengths = [("initial_gap", self.initial_gap),
                   *((f"{key}.gap", sphere.gap) for key, sphere in self._upper_spheres()),
                   ("container.radius", self.container.radius or 0.0),
                   ("container.height", self.container.height or 0.0)]
        for key, length in lengths:
            if length > MAX_GAP_DIAMETERS * diameter:
                raise SceneError(f"{key} = {length:.4g} m is {length / diameter:.3g} diameters: allowed up to "
                                 f"{MAX_GAP_DIAMETERS:g} D = {MAX_GAP_DIAMETERS * diameter:.4g} m (D of sphere 1; far "
                                 "beyond any wall effect, and the force formulas overflow further out)")
        wall = self.wall
        if wall.present and (wall.youngs_modulus is None or wall.poisson_ratio is None):
            missing = [f"wall.{key} ({allowed})" for key, allowed in
                       (("youngs_modulus", f"in [{MODULUS_MIN:g}, 1e+13] Pa"), ("poisson_ratio", "in (-1, 0.5)"))
                       if getattr(wall, key) is None]
            raise SceneError(f"{' and '.join(missing)} {'are' if len(missing) > 1 else 'is'} required when "
                             "wall.present = true (or set wall.present = false)")
        second = self.second_sphere
        if self.further_spheres and second is None:
            raise SceneError(f"further_spheres ({len(self.further_spheres)} given) are the spheres above the second: "
                             "give [second_sphere] first")
        if self.gravity == 0.0 and self.launch_speed == 0.0:
            raise SceneError("gravity = 0 moves nothing: allowed only for a free sphere launched by initial_velocity "
                             "!= 0 or a pair set in motion by second_sphere.velocity != 0 (in [-100, 100] m/s) with "
                             "second_sphere.mode free or prescribed; or give gravity in (0, 1000] m/s2, e.g. 9.81")
        if self.initial_velocity != 0.0 and not free:
            raise SceneError(f"initial_velocity = {self.initial_velocity:g} m/s launches a free sphere: with "
                             f"motion.mode = {self.motion.mode!r} give motion.velocity instead")
        self._check_start_outside_contact()
        if self.oblique:
            self._check_oblique()
        end_units = self.run.end_time / self.time_unit
        resting = self.wall.present and free and all(s.mode == "free" for _, s in self._upper_spheres())
        if end_units > MAX_END_TIME_UNITS and not resting:
            unit = "D / launch speed" if self.gravity == 0.0 else "sqrt(D/g)"
            raise SceneError(f"run.end_time = {self.run.end_time:.4g} s is {end_units:.3g} time units ({unit} = "
                             f"{self.time_unit:.3g} s): allowed up to {MAX_END_TIME_UNITS:g} of them, "
                             f"{MAX_END_TIME_UNITS * self.time_unit:.4g} s, for a scene that nothing ends earlier (no "
                             "wall to come to rest on, or a held or prescribed sphere): the ode model's largest step "
                             "is 0.02 time units, so that is 5e6 steps, about 40 minutes")
        c = self.contact
        if second is not None and self.near_wall_law != "correction":
            raise SceneError(f"contact.near_wall = {c.near_wall!r} is not implemented for a pair of spheres: use "
                             '"correction"')
        if c.model == "ehd":
            self._check_ehd()
        self._check_cavitation()
        self._check_contact_gaps()
        if c.delta_ss >= c.delta_sl:
            raise SceneError(f"contact.delta_ss = {c.delta_ss:g} must be smaller than contact.delta_sl = "
                             f"{c.delta_sl:g}")
        box = self.container
        if (box.radius is None) != (box.height is None):
            raise SceneError("container needs both radius and height, or neither (unbounded)")
        if box.radius is not None:
            if box.radius <= self.sphere.radius:
                raise SceneError(f"container.radius = {box.radius:g} m must exceed the sphere radius")
            top = self.initial_gaps[-1] + self.spheres[-1].diameter
            if box.height <= top:
                raise SceneError(f"container.height = {box.height:g} m must exceed the top of the highest sphere "
                                 f"at the start, {top:g} m")
            for key, sphere in self._upper_spheres():
                if box.radius <= sphere.radius:
                    raise SceneError(f"container.radius = {box.radius:g} m must exceed {key}'s radius "
                                     f"{sphere.radius:g} m")
        if self.motion.mode == "prescribed" and self.motion.series:
            read_series(self.motion.series)
        curve = self.reference.velocity_curve
        if curve and curve not in (names := reference.velocity_curve_names()):
            raise SceneError(f"reference.velocity_curve = {curve!r} is not one of the package's velocity curves: "
                             f"{', '.join(repr(n) for n in names)} (or \"\" for none)")
        speed = max(abs(self.motion.velocity), abs(self.motion.stream_velocity),
                    *(abs(sphere.velocity) for _, sphere in self._upper_spheres()))
        re_max = self.reynolds(max(self.estimated_impact_speed(), speed) if free else speed)
        if re_max > AXISYMMETRIC_RE_LIMIT:
            warnings.warn(f"scene {self.name!r}: estimated Re = {re_max:.3g} exceeds ~{AXISYMMETRIC_RE_LIMIT:.0f}, "
                          "where the flow stops being axisymmetric (paper section 2.1)", stacklevel=2)
        return self

    def _check_oblique(self) -> None:
        """An oblique collision: one free sphere and the wall, the Hertz contact (its overlap carries the friction's
        tangential spring) and a friction coefficient for the material pair."""
        across = [f"{key}.{name}" for key, sphere in self._upper_spheres() for name in ("tangential_velocity", "spin")
                  if getattr(sphere, name)]
        what = ("tangential_velocity, spin or gravity_angle" if self.tangential_velocity or self.spin
                else ", ".join(across) if across else "gravity_angle")
        where = ("is modelled for one free sphere and a wall, or for two free spheres meeting off their line of "
                 "centres without a wall or gravity")
        if self.second_sphere is not None:
            if (self.further_spheres or self.wall.present or self.gravity != 0.0 or self.motion.mode != "free"
                    or self.second_sphere.mode != "free"):
                raise SceneError(f"{what} != 0 (an oblique collision) {where}: not with further_spheres, "
                                 "wall.present = true, gravity != 0 or a sphere's mode fixed or prescribed")
            if self.contact.inertial_speed != "component":
                raise SceneError('contact.inertial_speed = "whole" is modelled for a sphere at a wall: a pair off its '
                                 'line of centres takes each component\'s drag at its own Re ("component")')
        elif not self.wall.present or self.motion.mode != "free":
            raise SceneError(f"{what} != 0 (an oblique collision) {where}: not with wall.present = false or "
                             "motion.mode fixed or prescribed")
        if self.contact.model != "lubricated-hertz":
            raise SceneError(f'{what} != 0 (an oblique collision) needs contact.model = "lubricated-hertz": its Hertz '
                             f'contact carries the friction (not {self.contact.model!r})')
        if self.contact.friction is None:
            raise SceneError(f"{what} != 0 (an oblique collision) needs contact.friction, the material pair's Coulomb "
                             "coefficient in [0, 2] (dry glass on glass 0.11-0.125, Foerster et al. 1994; wet, Joseph "
                             "& Hunt 2004: steel 0.02, glass 0.15)")
        if self.gravity_angle != 0.0 and self.gravity == 0.0:
            raise SceneError("gravity_angle tilts gravity, which is 0: set gravity_angle = 0 or give gravity")

    def _check_ehd(self) -> None:
        """contact.model = "ehd": one sphere and a wall, and a handover gap where the film is thin and still
        rigid (the cavitation pressure: _check_cavitation)."""
        c = self.contact
        if self.second_sphere is not None:
            raise SceneError('contact.model = "ehd" is not implemented for a pair of spheres (second_sphere): the film '
                             'collision is integrated for one sphere and a wall only; use "lubricated-hertz"')
        radius = self.sphere.radius
        high = min(0.1 * radius, c.delta_sl * self.sphere.diameter)
        low = 0.0
        if self.wall.present:
            e_star = reduced_modulus(self.sphere.youngs_modulus, self.sphere.poisson_ratio,
                                     self.wall.youngs_modulus, self.wall.poisson_ratio)
            speed = max(self.estimated_impact_speed(), abs(self.initial_velocity))
            low = 10.0 * elastohydrodynamic_gap(radius, e_star, self.liquid.viscosity, speed)
        if not low < c.ehd_handover < high:
            raise SceneError(f"contact.ehd_handover = {c.ehd_handover!r} m is out of range: allowed in ({low:.3g}, "
                             f"{high:.3g}) m for this scene ({EHD_HANDOVER_NOTE})")

    def _check_cavitation(self) -> None:
        """contact.cavitation_pressure is one of its words or a tension; the liquid does not boil."""
        cav = self.contact.cavitation_pressure
        allowed = f"allowed {CAVITATION_ALLOWED}"
        if isinstance(cav, str):
            if cav not in CAVITATION_WORDS:
                raise SceneError(f"contact.cavitation_pressure = {cav!r} is not a choice nor a pressure: {allowed} "
                                 "(gauge: the film's most negative pressure)")
        elif isinstance(cav, bool) or not (math.isfinite(cav) and CAVITATION_PRESSURE_MIN <= cav <= 0.0):
            raise SceneError(f"contact.cavitation_pressure = {cav!r} Pa is out of range: {allowed} (gauge: e.g. "
                             "-101325 for a film that cavitates at zero absolute pressure)")
        liquid = self.liquid
        if liquid.vapour_pressure > liquid.ambient_pressure:
            raise SceneError(f"liquid.vapour_pressure = {liquid.vapour_pressure:g} Pa exceeds liquid.ambient_pressure "
                             f"= {liquid.ambient_pressure:g} Pa: the liquid would boil; allowed up to the ambient "
                             "pressure")

    def _check_start_outside_contact(self) -> None:
        """Each contact starts open: the gap above the paper's elastic layer delta_ss (li2011) or above the
        surfaces' combined roughness, which must lie below the resolved flow's hold delta_sl."""
        pairs = [("initial_gap", self.initial_gap, "sphere.diameter", self.sphere.diameter,
                  self.sphere.roughness + self.wall.roughness, "sphere.roughness + wall.roughness")]
        lower = "sphere"
        for (key, sphere), below in zip(self._upper_spheres(), self.spheres):
            pairs.append((f"{key}.gap", sphere.gap, "the pair's reduced diameter 2a*", pair_diameter(below, sphere),
                          below.roughness + sphere.roughness, f"{lower}.roughness + {key}.roughness"))
            lower = key
        c = self.contact
        for key, gap, scale_name, scale, roughness, roughness_name in pairs:
            if c.paper and gap <= c.delta_ss * scale:
                raise SceneError(f"{key} = {gap:g} m is out of range: allowed > contact.delta_ss * {scale_name} = "
                                 f"{c.delta_ss:g} * {scale:.4g} m = {c.delta_ss * scale:.4g} m: start outside contact")
            if roughness >= c.delta_sl * scale:
                raise SceneError(f"{roughness_name} = {roughness:g} m is out of range: allowed < contact.delta_sl * "
                                 f"{scale_name} = {c.delta_sl * scale:.4g} m, where the resolved flow hands over")
            if not c.paper and gap <= roughness:
                raise SceneError(f"{key} = {gap:g} m is out of range: allowed > {roughness_name} = {roughness:g} m: "
                                 "start outside contact")

    def _check_contact_gaps(self) -> None:
        """contact.model = "lubricated-hertz": each contact's gap h_c = contact_gap_factor x max(roughness, x_d), x_d
        the elastohydrodynamic gap at the estimated impact speed, thin against the two surfaces (FILM_GAP_FRACTION
        a*, and below delta_sl times the gap scale): else the solids are too soft for a contact that starts at a
        gap, and the lubrication before it, to mean anything; and no thinner than a continuum film or the
        roughness (MOLECULAR_GAP)."""
        c = self.contact
        if c.model != "lubricated-hertz":
            return
        speed = max(self.estimated_impact_speed(), self.launch_speed)
        contacts = []
        if self.wall.present:
            contacts.append(("sphere", self.sphere, "wall", None, self.sphere.diameter,
                             self.sphere.roughness + self.wall.roughness))
        lower = ("sphere", self.sphere)
        for key, sphere in self._upper_spheres():
            contacts.append((lower[0], lower[1], key, sphere, pair_diameter(lower[1], sphere),
                             lower[1].roughness + sphere.roughness))
            lower = (key, sphere)
        for first_key, first, second_key, second, scale, roughness in contacts:
            partner = self.wall if second is None else second  # the wall: a partner of infinite radius
            e_star = reduced_modulus(first.youngs_modulus, first.poisson_ratio, partner.youngs_modulus,
                                     partner.poisson_ratio)
            a_star = 0.5 * scale
            film = elastohydrodynamic_gap(a_star, e_star, self.liquid.viscosity, speed)
            gap = c.contact_gap_factor * max(roughness, film)
            thinnest = max(MOLECULAR_GAP, roughness)
            if gap < thinnest:
                source = ("the surfaces' combined roughness, where their asperities touch" if roughness > MOLECULAR_GAP
                          else "a few molecular diameters, below which the film is no continuum (Israelachvili 2011)")
                raise SceneError(
                    f"contact.contact_gap_factor = {c.contact_gap_factor:g} is out of range: the "
                    f"{'wall' if second is None else 'pair'} contact would begin {gap:.3g} m apart, below "
                    f"{thinnest:.3g} m ({source}); allowed >= {thinnest / max(roughness, film):.3g} for this scene")
            allowed = min(FILM_GAP_FRACTION * a_star, c.delta_sl * scale)
            if gap >= allowed:
                raise SceneError(
                    f"{first_key}.youngs_modulus = {first.youngs_modulus:g} Pa and {second_key}.youngs_modulus = "
                    f"{(second or self.wall).youngs_modulus:g} Pa are too soft for this scene: its "
                    f"{'wall' if second is None else 'pair'} contact would begin {gap:.3g} m apart "
                    f"(contact_gap_factor {c.contact_gap_factor:g} x the elastohydrodynamic gap {film:.3g} m at "
                    f"{speed:.3g} m/s), allowed below {allowed:.3g} m ({FILM_GAP_FRACTION:g} a* and delta_sl times the "
                    "gap scale: a thin film and Hertz's small strain); give stiffer solids")

    def _upper_spheres(self) -> list[tuple[str, SecondSphere]]:
        """(scene key, sphere) of each sphere above the first, lowest first."""
        if self.second_sphere is None:
            return []
        return [("second_sphere", self.second_sphere),
                *((f"further_spheres[{k}]", s) for k, s in enumerate(self.further_spheres))]

    @property
    def launch_speed(self) -> float:
        """The largest speed a sphere starts with [m/s]: initial_velocity, or a pair's projectile."""
        upper_speed = max((abs(s.velocity) for _, s in self._upper_spheres() if s.mode != "fixed"), default=0.0)
        free_speed = abs(self.initial_velocity) if self.motion.mode == "free" else 0.0
        return max(free_speed, upper_speed)

    def replace(self, **changes: Any) -> "Scene":
        """A copy with dotted keys changed, e.g. replace(**{"sphere.density": 8000.0})."""
        return from_dict(_set_dotted(to_dict(self), changes), name=self.name)


# -- TOML in and out -------------------------------------------------------------------


def _build(cls, data: dict, prefix: str):
    if not isinstance(data, dict):
        keys = ", ".join(f.name for f in dataclasses.fields(cls))
        unbounded = " (leave [container] out for an unbounded liquid)" if cls is Container else ""
        raise SceneError(f"{prefix.rstrip('.')} = {data!r} must be a table of {keys}{unbounded}")
    fields = {f.name: f for f in dataclasses.fields(cls)}
    hints = typing.get_type_hints(cls)
    kwargs = {}
    for key, value in data.items():
        if f"{prefix}{key}" in RENAMED:
            raise SceneError(f"{prefix}{key} is now {RENAMED[prefix + key]}")
        if key not in fields:
            near = difflib.get_close_matches(key, list(fields), n=1)
            hint = f"; did you mean {prefix}{near[0]}?" if near else f"; known: {', '.join(fields)}"
            raise SceneError(f"unknown key {prefix}{key}{hint}")
        table = _table_type(hints[key])
        if table is not None and typing.get_origin(hints[key]) is tuple:  # an array of tables
            if not isinstance(value, (list, tuple)) or not all(isinstance(item, dict) for item in value):
                raise SceneError(f"{prefix}{key} must be an array of tables ([[{prefix}{key}]] in TOML), each with "
                                 f"{', '.join(f.name for f in dataclasses.fields(table))}")
            kwargs[key] = tuple(_build(table, item, f"{prefix}{key}[{k}].") for k, item in enumerate(value))
        elif table is not None:
            kwargs[key] = _build(table, value, f"{prefix}{key}.")
        else:
            kwargs[key] = _coerce(value, hints[key], prefix + key, fields[key].metadata.get("allowed"))
    for name, f in fields.items():
        if name not in kwargs and f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING:
            raise SceneError(f"missing key {prefix}{name}")
    return cls(**kwargs)


def _table_type(hint: Any):
    """The dataclass a key's value is built as (a table, also an optional one like second_sphere), or None."""
    if dataclasses.is_dataclass(hint):
        return hint
    tables = [t for t in typing.get_args(hint) if dataclasses.is_dataclass(t)]
    return tables[0] if tables else None


def _coerce(value: Any, expected: Any, key: str, allowed_text: str | None = None) -> Any:
    """TOML writes 1 for 1.0 and users write 8000 for 8000.0: accept both, reject the rest.  NumPy's numbers
    (np.float32(8000.0), np.int64(2): numbers.Real and numbers.Integral) are numbers too.  `allowed_text`: what
    a refusal says is allowed, for a field whose type alone does not say it (a number or some words)."""
    allowed = typing.get_args(expected) or (expected,)
    if isinstance(value, numbers.Integral) and not isinstance(value, (bool, int)):
        value = int(value)
    elif isinstance(value, numbers.Real) and not isinstance(value, (bool, int, float)):
        value = float(value)
    if (isinstance(value, bool) and bool not in allowed) or not isinstance(value, allowed):
        if float in allowed and isinstance(value, int) and not isinstance(value, bool):
            return float(value)
        if int in allowed and isinstance(value, float) and value.is_integer():
            return int(value)
        kind = allowed_text or ("a string" if str in allowed else "true or false" if bool in allowed
                                else "an integer" if float not in allowed else "a number")
        raise SceneError(f"{key} = {value!r} must be {kind}")
    return value


def from_dict(data: dict, name: str | None = None) -> Scene:
    """Build and validate a scene from nested dicts (TOML tables)."""
    data = dict(data)
    if data.get("container") == "unbounded":
        data["container"] = {}
    if name is not None and "name" not in data:
        data["name"] = name
    return _build(Scene, data, "").validate()


def to_dict(scene: Scene) -> dict:
    """Nested dicts with None values left out; the inverse of from_dict."""
    return dataclasses.asdict(scene, dict_factory=lambda items: {k: v for k, v in items if v is not None})


# what a scene holds beside its physics: its names, how long a run goes on, the measurement it is compared with
# and the models' numerical settings
NOT_PHYSICS = ("name", "description", "run", "reference", "numerics")


# fields added after digests were recorded, at the values that do what the scene did before them (the oblique
# fields' head-on values, the drag's inertia per component, the lift, which acts on no head-on scene): left out of
# the digest there
LATER = {"tangential_velocity": 0.0, "spin": 0.0, "gravity_angle": 0.0, "contact.inertial_speed": "component",
         "contact.lift": "steady", "contact.wall_torque": "steady",
         "second_sphere.tangential_velocity": 0.0, "second_sphere.spin": 0.0,
         "further_spheres.tangential_velocity": 0.0, "further_spheres.spin": 0.0}


def _tables(value) -> list[dict]:
    """A table, or each table of a list of them."""
    return [entry for entry in value if isinstance(entry, dict)] if isinstance(value, (list, tuple)) else [value]


def physics_digest(scene: Scene) -> str:
    """A hash of what the scene simulates (to_dict without NOT_PHYSICS, and without the fields of LATER at their
    values there, so that a scene hashes as it did before they existed): equal for two scenes that differ only in
    name, run length or numerics (a speed-accuracy record applies to the scene it was measured on)."""
    physics = {key: value for key, value in to_dict(scene).items() if key not in NOT_PHYSICS}
    for path, value in LATER.items():
        *tables, key = path.split(".")
        found = [physics]
        for name in tables:  # a list of tables (further_spheres): each of them
            found = [entry for table in found for entry in _tables(table.get(name, {}))]
        for table in found:
            if table.get(key, value) == value:
                table.pop(key, None)
    return hashlib.sha256(json.dumps(physics, sort_keys=True).encode()).hexdigest()[:16]


def dumps(scene: Scene) -> str:
    """The scene as TOML that loads back to an equal scene."""
    data = to_dict(scene)
    first = ["name", "description", "initial_gap", "gravity"]
    data = {**{k: data.pop(k) for k in first}, **data}
    lines = [f"{k} = {_toml_value(v)}" for k, v in data.items() if not isinstance(v, (dict, tuple))]
    if scene.container.unbounded:
        lines.append('container = "unbounded"')
        data.pop("container")

    def table(path: str, sub: dict):
        scalars = [(k, v) for k, v in sub.items() if not isinstance(v, dict)]
        if scalars:
            lines.append(f"\n[{path}]")
            lines.extend(f"{k} = {_toml_value(v)}" for k, v in scalars)
        for k, v in sub.items():
            if isinstance(v, dict):
                table(f"{path}.{k}", v)

    for key, value in data.items():
        if isinstance(value, dict):
            table(key, value)
    for item in data.get("further_spheres", ()):  # an array of tables, after every table
        lines.append("\n[[further_spheres]]")
        lines.extend(f"{k} = {_toml_value(v)}" for k, v in item.items())
    return "\n".join(lines) + "\n"


# a TOML basic string's escapes; any other control character is written \\uXXXX (TOML 1.0, "String")
_TOML_ESCAPES = {"\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f", "\r": "\\r", '"': '\\"', "\\": "\\\\"}


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else "inf" if value > 0 else "-inf"
    if isinstance(value, float) and value != 0.0 and not 1e-4 <= abs(value) < 1e5:
        return min((f"{value:.{p}e}" for p in range(17) if float(f"{value:.{p}e}") == value), key=len)
    if isinstance(value, (int, float)):
        return repr(value)
    if isinstance(value, str):
        return '"' + "".join(_TOML_ESCAPES.get(ch) or (f"\\u{ord(ch):04x}" if ord(ch) < 0x20 or ord(ch) == 0x7f else ch)
                             for ch in value) + '"'
    raise TypeError(f"cannot write {value!r} to TOML")


def _set_dotted(data: dict, changes: dict[str, Any]) -> dict:
    for dotted, value in changes.items():
        node = data
        *parents, leaf = dotted.split(".")
        for part in parents:
            if part == "container" and node.get(part) == "unbounded":
                node[part] = {}
            node = node.setdefault(part, {})
            if not isinstance(node, dict):
                raise SceneError(f"{dotted}: {part} is not a table")
        node[leaf] = value
    return data


def parse_override(text: str) -> tuple[str, Any]:
    """'sphere.density=8000' -> ('sphere.density', 8000); values parse as TOML, else as strings."""
    if not isinstance(text, str):
        raise SceneError(f"--set {text!r}: expected a text key=value, e.g. 'sphere.density=8000'")
    key, sep, raw = text.partition("=")
    if not sep or not key.strip():
        raise SceneError(f"--set {text!r}: expected key=value, e.g. sphere.density=8000")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()
    return key.strip(), value


# -- presets and files ---------------------------------------------------------------------


def preset_names() -> list[str]:
    files = resources.files("fem_bounce") / "presets"
    return sorted(p.name[:-5] for p in files.iterdir() if p.name.endswith(".toml"))


def preset_text(name: str) -> str:
    path = resources.files("fem_bounce") / "presets" / f"{name}.toml"
    if not path.is_file():
        near = difflib.get_close_matches(name, preset_names(), n=1)
        hint = f"; did you mean {near[0]}?" if near else "; see `fem-bounce scenes`"
        raise SceneError(f"unknown scene {name!r}: not a preset nor a file{hint}")
    return path.read_text()


def read_scene_file(path: Path) -> str:
    """The text of a scene file, UTF-8 (a byte-order mark is dropped); SceneError naming the file otherwise."""
    if not path.exists():
        raise SceneError(f"scene file {str(path)!r} does not exist"
                         + (" (a symbolic link to a missing file)" if path.is_symlink() else ""))
    if not path.is_file():
        raise SceneError(f"scene file {str(path)!r} is not a regular file (a directory, FIFO or device): "
                         "give a TOML file")
    try:
        data = path.read_bytes()
    except OSError as err:
        raise SceneError(f"scene file {str(path)!r} cannot be read: {err.strerror}") from None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as err:
        raise SceneError(f"scene file {str(path)!r} is not UTF-8 text (byte {err.start}): "
                         "save it as UTF-8 TOML") from None


def load(source: str | Path, overrides: dict[str, Any] | None = None) -> Scene:
    """A scene from a preset name or a TOML file, with dotted-key overrides applied."""
    if not isinstance(source, (str, os.PathLike)):
        raise SceneError(f"scene = {source!r} must be a preset name or a TOML file's path (see `fem-bounce scenes`)")
    if overrides is not None and not (isinstance(overrides, dict) and all(isinstance(k, str) for k in overrides)):
        raise SceneError(f"overrides = {overrides!r} must be a mapping of dotted keys to values, e.g. "
                         "{'sphere.density': 8000.0}")
    path = Path(source)
    if path.suffix == ".toml" or path.exists() or path.is_symlink():
        text, default_name = read_scene_file(path), path.stem
    else:
        text, default_name = preset_text(str(source)), str(source)
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        raise SceneError(f"{source}: not valid TOML ({err})") from None
    except RecursionError:
        raise SceneError(f"{source}: its tables or arrays are nested too deeply to read") from None
    data.setdefault("name", default_name)
    data.pop("uncertain", None)  # the band study's ranges (fem_bounce.uncertain reads them); a run takes the values
    if overrides:
        data = _set_dotted(data, overrides)
    return from_dict(data)


