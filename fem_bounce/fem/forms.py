"""Axisymmetric (no swirl) incompressible-flow forms on the meridian half-plane x = (r, z).

Every integral over the 3-D volume is 2 pi times the integral over the half-plane
weighted by r; the forms below carry the weight r and leave out the 2 pi.  With
u = (u_r, u_z) and no swirl (e.g. Deville, Fischer & Mund 2002, section 6.7):

    div u       = d(u_r)/dr + d(u_z)/dz + u_r / r
    (Lap u)_r   = (1/r) d/dr (r d(u_r)/dr) + d2(u_r)/dz2 - u_r / r^2     (the hoop term)
    (Lap u)_z   = (1/r) d/dr (r d(u_z)/dr) + d2(u_z)/dz2
    (u.grad) u  = (u_r d/dr + u_z d/dz) u                                (no extra term without swirl)

so the weak forms are the planar ones weighted by r plus the terms in 1/r.  On the
axis r = 0 the weight removes the boundary integrals, and u_r = 0 is imposed.

These are pure functions returning UFL forms (no assembly here).  `r` is the
radial coordinate, `ufl.SpatialCoordinate(mesh)[0]`.
"""
from __future__ import annotations

import ufl


def radial_coordinate(mesh):
    return ufl.SpatialCoordinate(mesh)[0]


def divergence(u, r):
    """div u of an axisymmetric field (a UFL expression)."""
    return u[0].dx(0) + u[1].dx(1) + u[0] / r


def vorticity(u):
    """omega_theta = d(u_r)/dz - d(u_z)/dr [1/s] (positive counter-clockwise seen with r to the right)."""
    return u[0].dx(1) - u[1].dx(0)


def mass(u, v, r, dx):
    """int u . v r dx."""
    return ufl.inner(u, v) * r * dx


def viscous(u, v, r, dx):
    """int (grad u : grad v + u_r v_r / r^2) r dx: minus the vector Laplacian, hoop term included."""
    return (ufl.inner(ufl.grad(u), ufl.grad(v)) * r + u[0] * v[0] / r) * dx


def pressure_divergence(v, p, r, dx):
    """-int p div v r dx: the pressure gradient tested with v (and, transposed, the constraint)."""
    return -p * (v[0].dx(0) + v[1].dx(1)) * r * dx - p * v[0] * dx


def stokes_operator(u, p, v, q, mass_coefficient, viscosity, r, dx):
    """The symmetric saddle-point form of a linearised step:
    mass_coefficient (u, v)_r + viscosity a(u, v) - (p, div v)_r - (q, div u)_r.

    mass_coefficient is rho c for a time step (c = 3 / (2 dt) for BDF2) or 0 for steady Stokes."""
    return (mass_coefficient * mass(u, v, r, dx) + viscosity * viscous(u, v, r, dx)
            + pressure_divergence(v, p, r, dx) + pressure_divergence(u, q, r, dx))


def convection(w, u, v, r, dx):
    """int ((w . grad) u) . v r dx: the convective term in advective form.

    (The skew-symmetric variant adds (1/2)(div w) u, which only helps when the term is
    implicit; extrapolated explicitly it made the flow past a sphere blow up near the
    shoulder at half the time step this form tolerates.)"""
    return ufl.inner(ufl.grad(u) * w, v) * r * dx


def source(f, v, r, dx):
    """int f . v r dx (a body force density f [N/m^3])."""
    return ufl.inner(f, v) * r * dx
