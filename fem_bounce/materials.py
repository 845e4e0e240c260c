"""The material scales of a contact, from the surfaces' and the liquid's properties alone (docs/physics.md
section 2.1): the reduced modulus of two elastic surfaces and the elastohydrodynamic gap.

Below both the scene, which checks a range with them (contact.ehd_handover), and the contact law, which is
built on them (fem_bounce.contact): this module imports nothing of the package.
"""
from __future__ import annotations

import math


def reduced_modulus(e1: float, nu1: float, e2: float, nu2: float) -> float:
    """E* = [(1 - nu1^2)/E1 + (1 - nu2^2)/E2]^-1 [Pa]."""
    return 1.0 / ((1.0 - nu1**2) / e1 + (1.0 - nu2**2) / e2)


def elastohydrodynamic_gap(radius: float, e_star: float, viscosity: float, speed: float) -> float:
    """x_d = (4 theta mu V a*^(3/2))^(2/5), theta = 1 / (pi E*) [m]: the gap at which the elasticity
    parameter of Davis, Serayssol & Hinch (1986) reaches one, so that the film's pressure flattens the
    surfaces by as much as the gap (0.43 um for Li et al.'s case 3 at 0.39 m/s)."""
    return (4.0 * viscosity * abs(speed) * radius**1.5 / (math.pi * e_star)) ** 0.4
