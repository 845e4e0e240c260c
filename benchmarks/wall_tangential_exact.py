"""The exact Stokes resistance of a sphere near a plane wall, tangential motions, from the bispherical series.

    .venv/bin/python benchmarks/wall_tangential_exact.py            # checks, then writes the table  ~1 s
    .venv/bin/python benchmarks/wall_tangential_exact.py --no-write # the checks only

Two solutions in bispherical coordinates (xi, eta, phi), the wall xi = 0, the sphere xi = alpha with
cosh(alpha) = l / a (l the height of the centre, a the radius, eps = l / a - 1 the gap over the radius):

- O'Neill (1964), Mathematika 11, 67-74: the sphere translating parallel to the wall without rotation;
- Dean & O'Neill (1963), Mathematika 10, 13-24: the sphere rotating about a wall-parallel axis without translation;

both in the notation in which Goldman, Cox & Brenner (1967, Chem. Eng. Sci. 22, 637, part I) restate them.  The
velocity is a series over n in Legendre functions of cos eta and hyperbolic functions of (n + 1/2) xi, with
coefficients A_n .. E_n; the no-slip conditions on the sphere and on the wall leave one set, A_n (n >= 1, A_0 = 0),
coupled through the three-term difference equation

    a_n [(n-1)/(2n-1) A_{n-1} - n/(2n+1) A_n] - b_n [(n+1)/(2n+1) A_n - (n+2)/(2n+3) A_{n+1}] = r_n,
    k_n = (n+1/2) coth((n+1/2) alpha) - coth(alpha),
    a_n = (2n-1) k_{n-1} - (2n-3) k_n,   b_n = (2n+5) k_n - (2n+3) k_{n+1},

with the same left side for both motions and the right sides r_n of `_translation_rhs` and `_rotation_rhs`.  The
others follow from A_n (`_coefficients`); the force and the torque are sums over n of them (`_force_torque_sums`).
The series is truncated at N terms (A_{N+1} = 0) and the tridiagonal system solved; the coefficients decay like
exp(-n alpha) (alpha ~ sqrt(2 eps) near contact), so N = 1000 is converged to round-off for eps >= 0.001 (the
checks print the change from N to 2N).

The equations were read from the public code haloless/StupidCFD (StokesianDynBox/WallBody/WallParallelTrans.m,
WallParallelRot.m), which follows Goldman, Cox & Brenner's statement of them, to understand the recurrence; the papers
themselves were not available here, so no equation numbers are quoted.  This implementation is written anew
(vectorised over n, exponentials written without overflow) and checked independently of that code:
  1. reciprocity: the torque from translation equals the force from rotation (two different right sides);
  2. far field: f_xx, c_yy -> 1, and the torque-free parallel mobility against the Faxen series
     1 - 9/16 z + 1/8 z^3 - 45/256 z^4 - 1/16 z^5, z = a / l (error O(z^6));
  3. near contact: the lubrication asymptotes (8/15) ln(1/eps) + 0.9543, (2/5) ln(1/eps) + 0.3709,
     (1/10) ln(1/eps) - 0.1930 of Chaoui & Feuillebois (2003), with their O(eps ln eps) terms;
  4. Chaoui & Feuillebois' printed values at eps 0.1, 0.01, 0.001 (fem_bounce/data/chaoui2003_wall_tangential.csv).
Units are those of fem_bounce/wall_tangential.py: f_xx in 6 pi mu a U, c_yx (torque from translation) in
8 pi mu a^2 U, c_yy in 8 pi mu a^3 Omega; the force from rotation, in 6 pi mu a^2 Omega, is (4/3) c_yx.

The table goes to fem_bounce/data/oneill1964_wall_tangential.csv (read by tests/test_wall_tangential.py).
"""
from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path

import numpy as np
from scipy.linalg import solve_banded

TABLE = Path(__file__).resolve().parents[1] / "fem_bounce" / "data" / "oneill1964_wall_tangential.csv"
N_TERMS = 1000
GAPS = (0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0, 3.0, 5.0, 7.0, 10.0)
SQRT2 = math.sqrt(2.0)


def _coth(x: np.ndarray) -> np.ndarray:
    """coth x for x > 0 without overflow."""
    q = np.exp(-2.0 * x)
    return (1.0 + q) / -np.expm1(-2.0 * x)


def _csch(x: np.ndarray) -> np.ndarray:
    """1 / sinh x for x > 0 without overflow."""
    return 2.0 * np.exp(-x) / -np.expm1(-2.0 * x)


def _system(alpha: float, n: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(k_n for n = 0..N+1, and the sub-, main and super-diagonal of the difference equations for n = 1..N)."""
    m = np.arange(n[-1] + 2, dtype=float)
    k = (m + 0.5) * _coth((m + 0.5) * alpha) - 1.0 / math.tanh(alpha)
    k_prev, k_here, k_next = k[n - 1], k[n], k[n + 1]
    a_n = (2 * n - 1) * k_prev - (2 * n - 3) * k_here
    b_n = (2 * n + 5) * k_here - (2 * n + 3) * k_next
    lower = a_n * (n - 1) / (2 * n - 1)  # multiplies A_{n-1}
    diagonal = -(a_n * n + b_n * (n + 1)) / (2 * n + 1)
    upper = b_n * (n + 2) / (2 * n + 3)  # multiplies A_{n+1}
    return k, (lower, diagonal, upper)


def _translation_rhs(alpha: float, n: np.ndarray) -> np.ndarray:
    """r_n of O'Neill's translation."""
    return SQRT2 * (2.0 * _coth((n + 0.5) * alpha) - _coth((n - 0.5) * alpha) - _coth((n + 1.5) * alpha))


def _l_term(alpha: float, n: np.ndarray) -> np.ndarray:
    """The rotation's particular part L_n = -(exp(-(n-1/2) alpha) / (2n-1) - exp(-(n+3/2) alpha) / (2n+3)) / sqrt 2."""
    return -(np.exp(-(n - 0.5) * alpha) / (2 * n - 1) - np.exp(-(n + 1.5) * alpha) / (2 * n + 3)) / SQRT2


def _rotation_rhs(alpha: float, n: np.ndarray) -> np.ndarray:
    """r_n of Dean & O'Neill's rotation."""
    bracket = ((2 * n + 1) ** 2 * (math.exp(alpha) / (2 * n - 1) + math.exp(-alpha) / (2 * n + 3))
               * _csch((n + 0.5) * alpha) - (2 * n - 1) * _csch((n - 0.5) * alpha)
               - (2 * n + 3) * _csch((n + 1.5) * alpha))
    return -SQRT2 * np.exp(-(n + 0.5) * alpha) / ((2 * n + 1) * math.sinh(alpha)) * bracket


def _coefficients(alpha: float, k: np.ndarray, a_coef: np.ndarray, rotation: bool) -> dict[str, np.ndarray]:
    """B_n .. E_n (n = 0..N) from A_n (given for n = 1..N); A_0 = A_{N+1} = 0."""
    size = a_coef.size
    n = np.arange(size + 1, dtype=float)
    a_full = np.zeros(size + 3)  # A_{-1} .. A_{N+1}, A_j at index j + 1
    a_full[2:size + 2] = a_coef
    a_prev, a_here, a_next = a_full[:size + 1], a_full[1:size + 2], a_full[2:size + 3]
    k_n = k[:size + 1]
    csch_n = _csch((n + 0.5) * alpha)
    c_coef = -2.0 * k_n * ((n - 1) / (2 * n - 1) * a_prev - a_here + (n + 2) / (2 * n + 3) * a_next)
    e_coef = k_n * ((n - 1) * n / (2 * n - 1) * a_prev - (n + 1) * (n + 2) / (2 * n + 3) * a_next)
    b_coef = (n - 1) * a_prev - (2 * n + 1) * a_here + (n + 2) * a_next
    d_coef = 0.5 * ((n + 1) * (n + 2) * a_next - (n - 1) * n * a_prev)
    decay = np.exp(-(n + 0.5) * alpha) * csch_n
    if rotation:
        l_n = _l_term(alpha, n)
        c_coef = c_coef + 4.0 * l_n / math.sinh(alpha) * csch_n
        e_coef = e_coef + SQRT2 * (2 * n + 1) * decay - l_n / math.sinh(alpha) * csch_n
    else:
        e_coef = e_coef + 2.0 * SQRT2 * decay
    c_coef[0] = b_coef[0] = 0.0  # n = 0: no such terms (they enter multiplied by n (n + 1) anyway)
    return {"n": n, "A": a_here, "B": b_coef, "C": c_coef, "D": d_coef, "E": e_coef}


def _force_torque_sums(alpha: float, c: dict[str, np.ndarray]) -> tuple[float, float]:
    """The sums over n of the force, sum (E_n + n (n+1) C_n), and of the torque."""
    n, coth_a = c["n"], 1.0 / math.tanh(alpha)
    nn = n * (n + 1)
    q = np.exp(-(2 * n + 1) * alpha)
    force = np.sum(c["E"] + nn * c["C"])
    torque = np.sum((2.0 + q) * (nn * (2.0 * c["A"] + c["C"] * coth_a) - (2 * n + 1 - coth_a) * c["E"])
                    + (2.0 - q) * (nn * c["B"] * coth_a - (2 * n + 1 - coth_a) * c["D"]))
    return float(force), float(torque)


def exact_series(eps: float, n_terms: int = N_TERMS) -> dict[str, float]:
    """f_xx, c_yx (the torque from translation), c_yx_rot (the force from rotation over 4/3) and c_yy at the gap
    eps = delta / a, the series truncated at n_terms."""
    alpha = math.acosh(1.0 + eps)
    n = np.arange(1, n_terms + 1)
    k, (lower, diagonal, upper) = _system(alpha, n)
    bands = np.zeros((3, n_terms))
    bands[0, 1:] = upper[:-1]
    bands[1] = diagonal
    bands[2, :-1] = lower[1:]
    out = {}
    for rotation, rhs in ((False, _translation_rhs(alpha, n)), (True, _rotation_rhs(alpha, n))):
        a_coef = solve_banded((1, 1), bands, rhs)
        force, torque = _force_torque_sums(alpha, _coefficients(alpha, k, a_coef, rotation))
        sh = math.sinh(alpha)
        if rotation:
            out["c_yx_rot"] = -SQRT2 / 6.0 * sh**2 * force * 0.75  # force in 6 pi mu a^2 Omega, over 4/3
            out["c_yy"] = (1.0 - torque * sh**3 / (4.0 * SQRT2)) / 3.0  # torque in 8 pi mu a^3 Omega
        else:
            out["f_xx"] = SQRT2 / 6.0 * sh * force  # force in 6 pi mu a U
            out["c_yx"] = torque * sh**2 / (12.0 * SQRT2)  # torque in 8 pi mu a^2 U
    return out



# Chaoui & Feuillebois (2003): the lubrication asymptotes (alpha_0 ln eps + beta_0 + alpha_1 eps ln eps; the constants
# to the 4 decimals quoted) and the printed values at eps 0.1, 0.01, 0.001 (3 decimals)
ASYMPTOTES = {"f_xx": (-8.0 / 15.0, 0.9543, -64.0 / 375.0), "c_yx": (-0.1, -0.1930, -43.0 / 250.0),
              "c_yy": (-0.4, 0.3709, -66.0 / 125.0)}
PRINTED = {0.1: (2.264, 0.089, 1.455), 0.01: (3.423, 0.277, 2.241), 0.001: (4.640, 0.499, 3.138)}
KEYS = ("f_xx", "c_yx", "c_yy")


def terms_for(eps: float) -> int:
    """A truncation with exp(-N alpha) below 1e-17 (at least N_TERMS)."""
    return max(N_TERMS, math.ceil(40.0 / math.acosh(1.0 + eps)))


def mobility(values: dict[str, float]) -> np.ndarray:
    """The torque-free / force-free mobility matrix, the inverse of K = [[f_xx, -(4/3) c_yx], [-(4/3) c_yx,
    (4/3) c_yy]] (wall_tangential.py's K)."""
    coupling = -4.0 / 3.0 * values["c_yx"]
    return np.linalg.inv(np.array([[values["f_xx"], coupling], [coupling, 4.0 / 3.0 * values["c_yy"]]]))


def check_convergence() -> float:
    """The largest relative change of f_xx, c_yx, c_yy from N_TERMS to 2 N_TERMS at the table's gaps (printed with
    the change from N_TERMS / 4 and N_TERMS / 2)."""
    print(f"convergence: relative change to N = {2 * N_TERMS}")
    print(f"{'eps':>7} " + " ".join(f"{f'N={n}':>27}" for n in (N_TERMS // 4, N_TERMS // 2, N_TERMS)))
    worst = 0.0
    for eps in GAPS:
        fine = exact_series(eps, 2 * N_TERMS)
        row = []
        for n in (N_TERMS // 4, N_TERMS // 2, N_TERMS):
            coarse = exact_series(eps, n)
            change = max(abs(coarse[k] / fine[k] - 1.0) for k in KEYS)
            row.append(f"{change:27.1e}")
            if n == N_TERMS:
                worst = max(worst, change)
        print(f"{eps:7g} " + " ".join(row))
    return worst


def check_reciprocity() -> tuple[float, float]:
    """(the largest relative and absolute difference of the torque from translation and the force from rotation,
    in c_yx's units), over the table's gaps and three smaller ones.  Both come from sums of O(1) terms: the absolute
    difference is round-off (1e-15 at N = 1000, 4e-12 at the N of 9000 that eps 1e-5 takes), so the relative one is
    largest where c_yx is smallest (eps 10, c_yx 6e-6)."""
    rel = absolute = 0.0
    for eps in (*GAPS, 1e-4, 1e-5, 1e-6):
        v = exact_series(eps, terms_for(eps))
        absolute = max(absolute, abs(v["c_yx_rot"] - v["c_yx"]))
        rel = max(rel, abs(v["c_yx_rot"] / v["c_yx"] - 1.0))
        print(f"  eps {eps:7g}: c_yx from translation {v['c_yx']:.15g}, from rotation {v['c_yx_rot']:.15g}")
    return rel, absolute


def check_far_field() -> bool:
    """f_xx, c_yy -> 1, c_yx -> 0; the parallel mobility against the Faxen series, the rotational one against
    (3/4) (1 - 5/16 z^3), the coupling against (3/32) z^4: the differences should fall as z^6, z^6 and z^5."""
    ok = True
    print(f"{'eps':>7} {'f_xx - 1':>10} {'c_yy - 1':>10} {'c_yx':>10} {'(mob-Faxen)/z^6':>16} {'(rot-ser)/z^6':>14}"
          f" {'c_yx/(3/32 z^4)':>16}")
    for eps in (3.0, 10.0, 20.0, 50.0, 100.0, 1000.0):
        v = exact_series(eps)
        z = 1.0 / (1.0 + eps)
        m = mobility(v)
        faxen = 1.0 - 9.0 / 16.0 * z + z**3 / 8.0 - 45.0 / 256.0 * z**4 - z**5 / 16.0
        rotation = 0.75 * (1.0 - 5.0 / 16.0 * z**3)
        r_trans, r_rot = (m[0, 0] - faxen) / z**6, (m[1, 1] - rotation) / z**6
        print(f"{eps:7g} {v['f_xx'] - 1:10.3e} {v['c_yy'] - 1:10.3e} {v['c_yx']:10.3e} {r_trans:16.4f}"
              f" {r_rot:14.4f} {v['c_yx'] / (3.0 / 32.0 * z**4):16.4f}")
        if eps <= 100.0:  # beyond, the z^6 differences are below round-off
            ok &= abs(r_trans) < 1.0 and abs(r_rot) < 1.0
    ok &= abs(exact_series(1e3)["f_xx"] - 1.0) < 1e-3 and abs(exact_series(1e3)["c_yy"] - 1.0) < 1e-8
    return ok


def check_lubrication() -> float:
    """The largest |value - asymptote| at eps 1e-5 and 1e-6 (the constants' rounding is 5e-5, the next term O(eps));
    prints the constants the exact values give."""
    worst = 0.0
    for eps in (1e-4, 1e-5, 1e-6):
        v = exact_series(eps, terms_for(eps))
        log = math.log(eps)
        parts = []
        for key, (slope, constant, next_slope) in ASYMPTOTES.items():
            beta = v[key] - slope * log - next_slope * eps * log
            parts.append(f"{key} {v[key]:.8f} (constant {beta:+.6f}, quoted {constant:+.4f})")
            if eps <= 1e-5:
                worst = max(worst, abs(beta - constant))
        print(f"  eps {eps:g}, N {terms_for(eps)}: " + ", ".join(parts))
    return worst


def check_printed() -> float:
    """The largest |exact - printed| at Chaoui & Feuillebois' three gaps (infinite unless every exact value rounds to
    the printed one)."""
    worst = 0.0
    for eps, printed in PRINTED.items():
        v = exact_series(eps)
        exact = tuple(v[k] for k in KEYS)
        worst = max(worst, *(abs(a - b) for a, b in zip(exact, printed)))
        if any(round(a, 3) != b for a, b in zip(exact, printed)):
            worst = math.inf  # the exact value must round to the printed one
        print(f"  eps {eps:g}: exact " + ", ".join(f"{k} {x:.6f}" for k, x in zip(KEYS, exact))
              + "; printed " + ", ".join(f"{x:.3f}" for x in printed))
    return worst


def write_table(convergence: float) -> None:
    """The table at GAPS, N_TERMS terms, its header saying how far it has converged and how reciprocal it is."""
    rows = {eps: exact_series(eps) for eps in GAPS}
    absolute = max(abs(v["c_yx_rot"] - v["c_yx"]) for v in rows.values())
    rel = max(abs(v["c_yx_rot"] / v["c_yx"] - 1.0) for v in rows.values())
    lines = [
        "# Stokes resistance of a sphere at the gap eps = delta / a from a plane wall, tangential motions: the",
        "# exact bispherical-coordinate series of O'Neill (1964), Mathematika 11, 67-74 (translation parallel to the",
        "# wall) and Dean & O'Neill (1963), Mathematika 10, 13-24 (rotation about a wall-parallel axis), computed by",
        f"# benchmarks/wall_tangential_exact.py with N = {N_TERMS} terms (converged: the change to N = {2 * N_TERMS} is"
        f" at most {max(convergence, 2.2e-16):.0e} relative).",
        "# Units of fem_bounce/wall_tangential.py (Chaoui & Feuillebois 2003): f_xx the drag in 6 pi mu a U; c_yx the",
        "# torque from translation in 8 pi mu a^2 U; c_yy the torque resisting rotation in 8 pi mu a^3 Omega; c_yx_rot",
        "# the force from rotation, in 6 pi mu a^2 Omega, over 4/3 (equal to c_yx by reciprocity: here to"
        f" {absolute:.0e} absolute,",
        f"# {rel:.0e} relative at eps 10 where c_yx is smallest: round-off in sums of O(1) terms).",
        "eps,f_xx,c_yx,c_yy,c_yx_rot",
    ]
    lines += [f"{eps:g}," + ",".join(f"{v[k]:.12g}" for k in (*KEYS, "c_yx_rot")) for eps, v in rows.items()]
    TABLE.write_text("\n".join(lines) + "\n")
    print(f"wrote {TABLE}")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--no-write", action="store_true", help="run the checks only")
    args = parser.parse_args()
    start = time.perf_counter()
    convergence = check_convergence()
    print("reciprocity (torque from translation = force from rotation):")
    reciprocity = check_reciprocity()
    print(f"  largest difference {reciprocity[1]:.1e} absolute, {reciprocity[0]:.1e} relative")
    print("far field:")
    far = check_far_field()
    print("lubrication asymptotes (Chaoui & Feuillebois 2003):")
    lubrication = check_lubrication()
    print(f"  largest |constant - quoted| at eps <= 1e-5: {lubrication:.1e}")
    print("Chaoui & Feuillebois' printed values:")
    printed = check_printed()
    print(f"  largest |exact - printed| {printed:.1e}")
    checks = {"convergence": convergence < 1e-12, "reciprocity": reciprocity[0] < 1e-9 and reciprocity[1] < 1e-11,
              "far field": far, "lubrication": lubrication < 1e-4, "printed values": printed <= 5.01e-4}
    for name, ok in checks.items():
        print(f"{name}: {'ok' if ok else 'FAILED'}")
    if not all(checks.values()):
        print("a check failed: the table is not written")
        return 1
    if not args.no_write:
        write_table(convergence)
    print(f"{time.perf_counter() - start:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
