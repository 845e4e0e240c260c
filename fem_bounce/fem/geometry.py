"""The geometry of a flow as an object: its measure, operators, stress and rigid modes, and its integrals.

    geometry = Axisymmetric(mesh)            # the meridian half-plane x = (r, z), 3-D volume = 2 pi r dA
    geometry = Cartesian(mesh)               # a 3-D mesh, weight 1
    geometry = Cartesian(mesh, mirrored=True)  # half of a domain symmetric about y = 0, weight 2
    a = geometry.stokes_operator(u, p, v, q, rho * c, mu, dx)
    volume = geometry.integrate(geometry.weighted(phi, dx))   # [m^3] on every rank

Every form here is already weighted so that assembling it gives the integral over the physical 3-D volume
(the whole of it when a symmetry removed part of the mesh): the axisymmetric forms are the r-weighted
meridian ones times 2 pi, the mirrored half box's the plain ones times 2 (each integrand even in y for a flow
symmetric about y = 0, so the unmeshed half gives as much).  Scaling a whole system by the same factor changes
none of its solutions (`dirichlet_diagonal` scales its fixed rows with it), so a flow solved with these forms
is the one the plain forms give; its forces, volumes and momenta need no factor typed at the call site.
`integrate` assembles a scalar form and sums the ranks; `weight_at` and `total` do the same for a quadrature
sum made by hand.

Axisymmetric (no swirl; e.g. Deville, Fischer & Mund 2002, section 6.7), u = (u_r, u_z):

    div u = d(u_r)/dr + d(u_z)/dz + u_r / r,   -Lap u . v ~ grad u : grad v + u_r v_r / r^2   (the hoop term),

and the only rigid motion the axis allows is a translation along z.  Cartesian: the plain forms, and the
six rigid motions U + omega x (x - X) (three translations, three rotations about the centre X); the
mirrored half keeps those a flow symmetric about y = 0 can have: U_x, U_z and the rotation about y.

The virtual power of a force density f on a rigid motion m_j is int f . m_j: with the modes above this
generalised force is the force component for a translation and the torque component about X for a rotation,
so one integral gives both (`rigid_modes`).

Forms are pure functions (no assembly) of UFL arguments; a measure `dx` may be passed (a quadrature degree,
a subdomain), otherwise the mesh's plain dx is used.
"""
from __future__ import annotations

import functools
import math
import operator

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI


class Geometry:
    """What the two geometries share: the weighted forms built from `weight`, `divergence` and `viscous`."""

    mesh = None
    weight = None  # the factor [1 or m] that makes an integral over the mesh the physical volume's
    mode_names: tuple[str, ...] = ()

    @property
    def dx(self) -> ufl.Measure:
        return ufl.Measure("dx", domain=self.mesh)

    def _measure(self, dx):
        return self.dx if dx is None else dx

    def weighted(self, integrand, dx=None) -> ufl.Form:
        """integrand * weight * dx: a form whose assembly is the integral over the physical volume."""
        return integrand * self.weight * self._measure(dx)

    def integrate(self, form) -> float:
        """The value of a scalar form (UFL or compiled) summed over the ranks (every rank gets it)."""
        compiled = form if isinstance(form, fem.Form) else fem.form(form)
        return self.mesh.comm.allreduce(fem.assemble_scalar(compiled), op=MPI.SUM)

    def total(self, part: float) -> float:
        """This rank's part of an integral summed by hand (a quadrature sum over `weight_at`) summed over the
        ranks (every rank gets it)."""
        return self.mesh.comm.allreduce(part, op=MPI.SUM)

    def weight_at(self, points: np.ndarray) -> np.ndarray:
        """`weight` at points of shape (..., gdim) [m] (numpy, shape (...)): the weight of a quadrature sum made by
        hand, so that it is the physical integral as an assembled form is."""
        return np.full(np.shape(points)[:-1], float(self.weight))

    @property
    def dirichlet_diagonal(self) -> float:
        """The diagonal of a Dirichlet row in a matrix of these forms, and the factor of that row's value on the
        right-hand side: the weight's constant factor (2 pi on the axis, 2 for a mirrored half, else 1), so that a
        whole system, its fixed rows included, is the plain forms' one times that factor.  A direct solver gives
        the same solution whatever the diagonal; a Krylov solve whose residual has fixed rows beside free ones (a
        start off the Dirichlet values, a field split) weighs them against each other as with the plain forms only
        with this one."""
        return float(self.weight)

    def mass(self, u, v, dx=None) -> ufl.Form:
        """int u . v."""
        return self.weighted(ufl.inner(u, v), dx)

    def pressure_divergence(self, v, p, dx=None) -> ufl.Form:
        """-int p div v: the pressure gradient tested with v (and, transposed, the constraint)."""
        return self.weighted(-p * self.divergence(v), dx)

    def stokes_operator(self, u, p, v, q, mass_coefficient, viscosity, dx=None) -> ufl.Form:
        """mass_coefficient (u, v) + viscosity a(u, v) - (p, div v) - (q, div u), the symmetric saddle point of a
        linearised step; mass_coefficient is rho c for a time step (c = 3 / (2 dt) for BDF2) or 0 for Stokes."""
        return (mass_coefficient * self.mass(u, v, dx) + viscosity * self.viscous(u, v, dx)
                + self.pressure_divergence(v, p, dx) + self.pressure_divergence(u, q, dx))

    def convection(self, w, u, v, dx=None) -> ufl.Form:
        """int ((w . grad) u) . v, the convective term in advective form (no extra term without swirl)."""
        return self.weighted(ufl.inner(ufl.grad(u) * w, v), dx)

    def source(self, f, v, dx=None) -> ufl.Form:
        """int f . v (a body force density f [N/m^3])."""
        return self.weighted(ufl.inner(f, v), dx)

    def traction(self, u, p, viscosity, normal):
        """sigma n [Pa] on a surface of unit normal n (in the mesh's plane for the axisymmetric geometry)."""
        return self.stress(u, p, viscosity) * normal


class Axisymmetric(Geometry):
    """The meridian half-plane x = (r, z) of an axisymmetric flow without swirl: weight 2 pi r.

    Every integral over the 3-D volume is 2 pi times the integral over the half-plane weighted by r.  With
    u = (u_r, u_z) and no swirl (e.g. Deville, Fischer & Mund 2002, section 6.7):

        div u       = d(u_r)/dr + d(u_z)/dz + u_r / r
        (Lap u)_r   = (1/r) d/dr (r d(u_r)/dr) + d2(u_r)/dz2 - u_r / r^2     (the hoop term)
        (Lap u)_z   = (1/r) d/dr (r d(u_z)/dr) + d2(u_z)/dz2
        (u.grad) u  = (u_r d/dr + u_z d/dz) u                                (no extra term without swirl)

    so the weak forms are the planar ones weighted by r plus the terms in 1/r.  On the axis r = 0 the weight
    removes the boundary integrals, and u_r = 0 is imposed.  The convective term is the advective form: the
    skew-symmetric variant adds (1/2)(div w) u, which only helps when the term is implicit (extrapolated
    explicitly it made the flow past a sphere blow up near the shoulder at half the time step the advective
    form tolerates).  `r` is the radial coordinate, a UFL expression."""

    mode_names = ("U_z",)

    def __init__(self, mesh):
        if mesh.geometry.dim != 2:
            raise ValueError(f"the axisymmetric geometry needs a 2-D mesh of the (r, z) half-plane, not a "
                             f"{mesh.geometry.dim}-D one")
        self.mesh = mesh
        self.r = ufl.SpatialCoordinate(mesh)[0]
        self.weight = 2.0 * math.pi * self.r

    def divergence(self, u):
        return u[0].dx(0) + u[1].dx(1) + u[0] / self.r

    # The two forms with a 1/r term keep the r-weighted layout, r times the planar part plus the 1/r part: the
    # same integrand to round-off, and the same estimated quadrature degree (r (u_r / r) would raise it).
    def viscous(self, u, v, dx=None) -> ufl.Form:
        """int (grad u : grad v + u_r v_r / r^2): minus the vector Laplacian, hoop term included."""
        return 2.0 * math.pi * (ufl.inner(ufl.grad(u), ufl.grad(v)) * self.r + u[0] * v[0] / self.r) * self._measure(dx)

    def pressure_divergence(self, v, p, dx=None) -> ufl.Form:
        """-int p div v."""
        return 2.0 * math.pi * (-p * (v[0].dx(0) + v[1].dx(1)) * self.r - p * v[0]) * self._measure(dx)

    def stress(self, u, p, viscosity):
        """The meridian block of the Cauchy stress -p I + mu (grad u + grad u^T) [Pa] (the hoop component
        -p + 2 mu u_r / r acts normal to the meridian plane and enters no traction on a surface of revolution)."""
        return -p * ufl.Identity(2) + viscosity * (ufl.grad(u) + ufl.grad(u).T)

    def rigid_modes(self, center=None) -> list:
        """The rigid motions the axis allows: the translation e_z (a centre changes nothing)."""
        return [ufl.as_vector([0.0, 1.0])]

    @property
    def dirichlet_diagonal(self) -> float:
        """2 pi: the plain forms are the r-weighted ones (Geometry.dirichlet_diagonal)."""
        return 2.0 * math.pi

    def weight_at(self, points: np.ndarray) -> np.ndarray:
        """2 pi r at points (..., 2) = (r, z) [m]."""
        return 2.0 * math.pi * np.asarray(points)[..., 0]

    def vorticity(self, u):
        """The azimuthal vorticity omega_theta = d(u_r)/dz - d(u_z)/dr [1/s] (positive counter-clockwise seen with
        r to the right): the only component of curl u without swirl (a UFL expression)."""
        return u[0].dx(1) - u[1].dx(0)


class Cartesian(Geometry):
    """A 3-D mesh (weight 1), or with `mirrored` the half y >= 0 of a domain symmetric about the plane y = 0
    (weight 2: the integral of an integrand even in y over the whole domain)."""

    ALL_MODES = ("U_x", "U_y", "U_z", "Omega_x", "Omega_y", "Omega_z")
    MIRRORED_MODES = ("U_x", "U_z", "Omega_y")  # the rigid motions symmetric about y = 0

    def __init__(self, mesh, mirrored: bool = False):
        if mesh.geometry.dim != 3:
            raise ValueError(f"the Cartesian geometry needs a 3-D mesh, not a {mesh.geometry.dim}-D one")
        self.mesh = mesh
        self.mirrored = mirrored
        self.weight = 2.0 if mirrored else 1.0
        self.mode_names = self.MIRRORED_MODES if mirrored else self.ALL_MODES

    def divergence(self, u):
        return ufl.div(u)

    def viscous(self, u, v, dx=None) -> ufl.Form:
        """int grad u : grad v, minus the vector Laplacian (its natural condition on a symmetry plane,
        d(u_t)/dn = 0, is the symmetric flow's)."""
        return self.weighted(ufl.inner(ufl.grad(u), ufl.grad(v)), dx)

    def stress(self, u, p, viscosity):
        """The Cauchy stress -p I + mu (grad u + grad u^T) [Pa]."""
        return -p * ufl.Identity(3) + viscosity * (ufl.grad(u) + ufl.grad(u).T)

    def rigid_modes(self, center) -> list:
        """The rigid motions named by `mode_names` about the centre X = `center` (a length-3 sequence or a
        fem.Constant of shape (3,)) [m]: e_k for a translation, e_k x (x - X) for a rotation."""
        arm = ufl.SpatialCoordinate(self.mesh) - ufl.as_vector([center[k] for k in range(3)])
        axes = np.eye(3)
        modes = {f"U_{name}": ufl.as_vector(axes[k]) for k, name in enumerate("xyz")}
        modes |= {f"Omega_{name}": ufl.cross(ufl.as_vector(axes[k]), arm) for k, name in enumerate("xyz")}
        return [modes[name] for name in self.mode_names]

    def rigid_velocity(self, amplitudes, center):
        """sum_j amplitudes_j m_j: U + omega x (x - X) with the amplitudes in `mode_names`' order [m/s, 1/s]."""
        modes = self.rigid_modes(center)
        if len(amplitudes) != len(modes):
            raise ValueError(f"{len(modes)} rigid amplitudes {self.mode_names} expected, got {len(amplitudes)}")
        return functools.reduce(operator.add, [float(s) * m for s, m in zip(amplitudes, modes)])

    def components(self, values) -> tuple[np.ndarray, np.ndarray]:
        """(translational part, rotational part), each of shape (3,), of values over `mode_names` (amplitudes:
        U [m/s] and omega [1/s]; generalised forces: the force [N] and the torque about X [N m]); the modes a
        mirrored half leaves out are 0."""
        values = np.asarray(values, dtype=float)
        if values.shape != (len(self.mode_names),):
            raise ValueError(f"{len(self.mode_names)} values over {self.mode_names} expected, not {values.shape}")
        full = dict(zip(self.mode_names, values))
        return (np.array([full.get(f"U_{k}", 0.0) for k in "xyz"]),
                np.array([full.get(f"Omega_{k}", 0.0) for k in "xyz"]))

    def rigid_velocity_at(self, points: np.ndarray, amplitudes, center) -> np.ndarray:
        """U + omega x (x - X) at points of shape (n, 3) [m/s] (numpy, for checks)."""
        translation, rotation = self.components(amplitudes)
        return translation + np.cross(rotation, np.asarray(points) - np.asarray(center, dtype=float))
