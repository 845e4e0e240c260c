"""A linear operator factorised once and back-solved many times.

    solver = FactorizedOperator(A, prefix="fd_fluid_")
    solver.solve(b, x)            # one back-solve with the stored factors
    solver.refactor()             # after A's values changed (same sparsity: the analysis is reused)
    solver.destroy()

`ReusedFactorOperator` keeps the factors of an earlier matrix as the preconditioner of a GMRES solve
with the current one (the ale model's `numerics.ale.factorisation = "reuse"`) and factorises again only
when a solve needs more than a bound of iterations.

The default is MUMPS LU through PETSc (`-{prefix}pc_factor_mat_solver_type`,
`-{prefix}mat_mumps_icntl_*` tune it from the command line).  The operator owns
its KSP and destroys it; `back_solves` counts the solves, so a model can report
its cost per time step in back-solves (`solve_time` the seconds they took,
`single_solve_time / single_solves` the time of one back-solve with one right-hand side).
"""
from __future__ import annotations

import ctypes
import functools
import sys
import time

import numpy as np
from petsc4py import PETSc


MUMPS_WORKSPACE_TOO_SMALL = (-8, -9)  # INFOG(1): integer or real workspace ran out
HEAP_BLOCK_LIMIT = 256 * 2**20  # [bytes] blocks up to this size come from the heap and stay there when freed


@functools.cache
def keep_large_blocks() -> bool:
    """Have glibc's malloc serve blocks up to HEAP_BLOCK_LIMIT from its heap and keep them there when freed.

    MUMPS allocates its factorisation's workspace (tens of MB) anew for every numerical factorisation and frees
    it after.  glibc serves a block above its mmap threshold (at most 32 MB by default) with a fresh mmap and
    unmaps it on free, so every factorisation then faults in zeroed pages: 13 of 43 ms of a factorisation of the
    fd model's 17.8k-unknown matrix (docs/performance.md).  Raising the threshold (and the heap's trim threshold
    with it) reuses the same pages; a process then keeps up to that much freed memory.  Returns whether it
    applied (glibc only: nothing elsewhere)."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL("libc.so.6")
    except OSError:  # not glibc (musl has no mallopt)
        return False
    M_TRIM_THRESHOLD, M_MMAP_THRESHOLD = -1, -3  # glibc's malloc.h
    return bool(libc.mallopt(M_MMAP_THRESHOLD, HEAP_BLOCK_LIMIT)) and bool(libc.mallopt(M_TRIM_THRESHOLD,
                                                                                       HEAP_BLOCK_LIMIT))


class SolverError(RuntimeError):
    """The factorisation or a back-solve failed."""


def _default_option(name: str, value) -> None:
    options = PETSc.Options()
    if not options.hasName(name):
        options[name] = value


def _reproducible_krylov() -> None:
    """Krylov methods whose digits do not depend on where their vectors lie in memory.  PETSc (3.20 and
    later) computes the several dot products and updates of a Gram-Schmidt step (VecMDot, VecMAXPY) with one
    BLAS gemv, whose OpenBLAS kernels sum in an order set by the arrays' alignment: the same solve then
    differs in its last bits from one process to the next, and a restarted run no longer repeats the
    uninterrupted one's digits.  The plain loops cost nothing measurable beside the back-solves they serve."""
    _default_option("vec_mdot_use_gemv", False)
    _default_option("vec_maxpy_use_gemv", False)


def _counted_solve(operator, b: PETSc.Vec, x: PETSc.Vec) -> None:
    """operator.ksp.solve(b, x), its time and count added to the operator's tallies."""
    start = time.perf_counter()
    operator.ksp.solve(b, x)
    elapsed = time.perf_counter() - start
    operator.solve_time += elapsed
    operator.single_solve_time += elapsed
    operator.single_solves += 1
    operator.back_solves += 1


class FactorizedOperator:
    """Factorise A (PETSc Mat) once on construction; `solve` back-substitutes."""

    def __init__(self, A: PETSc.Mat, prefix: str, factor: str = "lu", package: str = "mumps"):
        keep_large_blocks()
        self.prefix = prefix
        self.operator = A
        _default_option(f"{prefix}ksp_type", "preonly")
        _default_option(f"{prefix}pc_type", factor)
        _default_option(f"{prefix}pc_factor_mat_solver_type", package)
        # MUMPS: a little more workspace than its estimate (pivoting in the saddle point), and
        # its own parallel ordering choice.
        _default_option(f"{prefix}mat_mumps_icntl_14", 80)
        self.ksp = PETSc.KSP().create(A.getComm())
        self.ksp.setOptionsPrefix(prefix)
        self.ksp.setOperators(A)
        self.ksp.setFromOptions()
        self.back_solves = 0
        self.solve_time = 0.0  # [s] spent in back-solves on this rank
        self.single_solves, self.single_solve_time = 0, 0.0  # one right-hand side at a time
        self._blocks: dict = {}  # dense right-hand sides and solutions for solve_many
        self._factorise(self.ksp.setUp)

    def refactor(self) -> None:
        """Factorise again after the operator's values changed in place.  With the same nonzero
        pattern PETSc redoes only the numerical factorisation (MUMPS keeps its analysis)."""
        self._factorise(self.ksp.getPC().setUp)  # KSP.setUp alone would leave it to the next solve

    def _factorise(self, setup) -> None:
        """Run `setup`; when MUMPS ran short of the workspace it estimated (heavy pivoting, e.g. in a
        saddle point whose rows are scaled by r near the axis), double its relaxation ICNTL(14) and
        factorise from scratch, a few times at most."""
        for _ in range(4):
            try:
                setup()
            except PETSc.Error as err:
                raise SolverError(f"factorisation failed ({self.prefix}): {err}") from None
            if self._mumps_status() not in MUMPS_WORKSPACE_TOO_SMALL:
                return
            options = PETSc.Options()
            name = f"{self.prefix}mat_mumps_icntl_14"
            options[name] = 2 * options.getInt(name, 80)
            self.ksp.getPC().reset()  # drops the factors and the operator with them
            self.ksp.setOperators(self.operator)
            setup = self.ksp.setUp

    def _mumps_status(self) -> int:
        """MUMPS's INFOG(1) of the last factorisation (0 when fine or not MUMPS)."""
        try:
            return int(self.ksp.getPC().getFactorMatrix().getMumpsInfog(1))
        except (PETSc.Error, AttributeError):
            return 0

    def solve(self, b: PETSc.Vec, x: PETSc.Vec) -> None:
        _counted_solve(self, b, x)
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise SolverError(f"back-solve failed ({self.prefix}): KSP reason {reason}")

    def solve_many(self, rhs: list, solutions: list) -> None:
        """Back-solve several right-hand sides at once (one pass over the factors: cheaper than
        as many single solves).  Counts as len(rhs) back-solves."""
        k = len(rhs)
        if k == 1:
            return self.solve(rhs[0], solutions[0])
        start = time.perf_counter()
        B, X = self._dense(k, rhs[0])
        block = B.getDenseArray()
        for j, b in enumerate(rhs):
            block[:, j] = b.array_r
        B.assemble()
        self.ksp.getPC().getFactorMatrix().matSolve(B, X)
        solved = X.getDenseArray()
        for j, x in enumerate(solutions):
            x.array[:] = solved[:, j]
        self.solve_time += time.perf_counter() - start
        self.back_solves += k

    def _dense(self, k: int, like: PETSc.Vec):
        if k not in self._blocks:
            n, size = like.getLocalSize(), like.getSize()
            pair = []
            for _ in range(2):
                mat = PETSc.Mat().createDense(((n, size), (PETSc.DECIDE, k)), comm=like.getComm())
                mat.setUp()
                mat.assemble()
                pair.append(mat)
            self._blocks[k] = tuple(pair)
        return self._blocks[k]

    def factor_memory(self) -> float | None:
        """Memory the factorisation used on all ranks together [bytes] (MUMPS INFOG(22)), None if not MUMPS."""
        try:
            return float(self.ksp.getPC().getFactorMatrix().getMumpsInfog(22)) * 1e6
        except (PETSc.Error, AttributeError):
            return None

    def destroy(self) -> None:
        for pair in self._blocks.values():
            for mat in pair:
                mat.destroy()
        self._blocks = {}
        if self.ksp is not None:
            self.ksp.destroy()
            self.ksp = None


class ReusedFactorOperator(FactorizedOperator):
    """Solves with the current A (changed in place between solves, same sparsity) by flexible GMRES
    preconditioned on the right (the residual it tests is the true one) by the LU factors of A as it was at
    the last factorisation.  A solve is converged when |b - A x| <= rtol |b_free|, starting from the
    solution vector's values (an initial guess); b_free is b without the rows `fixed_rows` (this rank's
    local indices of Dirichlet rows: diagonal rows whose values, velocities of order 1, would otherwise
    set the scale for the finite-element rows, whose entries carry cell areas and are many orders
    smaller).  A guess meeting the Dirichlet values leaves no residual in those rows.

    When to factorise again is a renewal problem: with f the cost of a factorisation and i_1, i_2, ...
    the iterations of the steps since (each about one back-solve), the cost per step (f + sum i_j) / n
    is smallest when the last step's iterations reach it, so `end_step` marks the operator `stale` when
    i_n > (f + sum_j i_j) / n, f = `factorisation_cost` in iterations; also when one solve needs more than
    `max_iterations`.  `refactor` (by the caller, at the next matrix) clears it.  A solve that fails to
    converge in `limit` iterations factorises at once and solves again.  The rule counts iterations, not
    seconds, so a run is reproducible.

    `factorisations` counts the numerical factorisations, `iterations` the Krylov iterations
    (each one back-solve with the factors and one product with A)."""

    def __init__(self, A: PETSc.Mat, prefix: str, rtol: float = 1e-7, factorisation_cost: float = 20.0,
                 max_iterations: int = 30, limit: int = 100, fixed_rows=None):
        # flexible GMRES: right-preconditioned (the residual it tests is the true one) and keeps the
        # preconditioned directions, so the solution needs no extra back-solve at the end as GMRES's does
        _default_option(f"{prefix}ksp_type", "fgmres")
        _default_option(f"{prefix}ksp_gmres_restart", limit)
        _reproducible_krylov()
        self.rtol, self.factorisation_cost = rtol, factorisation_cost
        self.max_iterations, self.limit = max_iterations, limit
        self.fixed_rows = None if fixed_rows is None else np.asarray(fixed_rows, dtype=np.int64)
        self._free = None  # the mask of the other rows, made at the first solve
        self.factorisations = 0
        self.iterations = 0
        self.last_iterations = 0
        self.stale = False
        self._since = []  # iterations of each step since the last factorisation
        self._step_iterations = 0
        super().__init__(A, prefix)
        self.ksp.setInitialGuessNonzero(True)
        self.ksp.getPC().setReusePreconditioner(True)

    def _factorise(self, setup) -> None:
        pc = self.ksp.getPC()
        pc.setReusePreconditioner(False)
        try:
            super()._factorise(setup)
        finally:
            pc.setReusePreconditioner(True)
        self.factorisations += 1
        self.stale = False
        self._since, self._step_iterations = [], 0

    def solve(self, b: PETSc.Vec, x: PETSc.Vec) -> None:
        if not self._since:
            # fresh factors (the first step since the factorisation) converge in one iteration from any guess:
            # start from 0, so that a run restarted after a checkpoint (the model factorises there,
            # fem_bounce.models.ale) repeats the digits
            x.set(0.0)
        norm = self._free_norm(b)
        # |r| <= rtol |b_free| whatever the initial guess (PETSc's rtol is relative to the first residual)
        self.ksp.setTolerances(rtol=1e-300, atol=max(self.rtol * norm, 1e-300), max_it=self.limit)
        _counted_solve(self, b, x)
        if self.ksp.getConvergedReason() < 0:  # the factors are too stale to precondition: factorise now
            self.iterations += self.ksp.getIterationNumber()
            self.refactor()
            _counted_solve(self, b, x)
            reason = self.ksp.getConvergedReason()
            if reason < 0:
                raise SolverError(f"GMRES with fresh factors failed ({self.prefix}): KSP reason {reason}")
        self.last_iterations = self.ksp.getIterationNumber()
        self.iterations += self.last_iterations
        self._step_iterations += self.last_iterations
        self.stale = self.stale or self.last_iterations > self.max_iterations

    def _free_norm(self, b: PETSc.Vec) -> float:
        """|b| over the rows other than `fixed_rows` (all ranks)."""
        if self.fixed_rows is None:
            return b.norm()
        values = b.array_r
        if self._free is None or self._free.size != values.size:
            self._free = np.ones(values.size, dtype=bool)
            self._free[self.fixed_rows] = False
        free = values[self._free]
        return b.getComm().tompi4py().allreduce(float(free @ free)) ** 0.5

    def end_step(self) -> None:
        """The solves of one step are done: decide whether the next step factorises (the rule above)."""
        self._since.append(self._step_iterations)
        self._step_iterations = 0
        average = (self.factorisation_cost + sum(self._since)) / len(self._since)
        self.stale = self.stale or self._since[-1] > average

    def solve_many(self, rhs: list, solutions: list) -> None:
        for b, x in zip(rhs, solutions):
            self.solve(b, x)


class FieldSplitOperator:
    """The same interface as FactorizedOperator for a Taylor-Hood saddle point, solved iteratively:
    GMRES preconditioned by a Schur-complement field split (velocity block by algebraic multigrid, the
    Schur complement approximated by -B diag(F)^-1 B^T, also by multigrid), for meshes where the direct
    factorisation stops scaling.  The multigrid is hypre's BoomerAMG where PETSc has hypre, PETSc's own
    GAMG otherwise (the PyPI wheel has no hypre).  `velocity`, `pressure`: PETSc index sets of the two
    fields.  `options`: the caller's defaults in place of these (names without the prefix).  Every option can be
    changed under `{prefix}` (e.g. -fd_flow_fieldsplit_ksp_rtol 1e-10, -fd_flow_fieldsplit_fieldsplit_u_pc_type
    gamg)."""

    def __init__(self, A: PETSc.Mat, prefix: str, velocity: PETSc.IS, pressure: PETSc.IS, rtol: float = 1e-9,
                 options: dict | None = None):
        self.prefix = prefix
        self.operator = A
        defaults = {"ksp_type": "fgmres", "ksp_rtol": rtol, "ksp_atol": 1e-30, "ksp_gmres_restart": 100,
                    "ksp_max_it": 500, "pc_type": "fieldsplit", "pc_fieldsplit_type": "schur",
                    "pc_fieldsplit_schur_fact_type": "full", "pc_fieldsplit_schur_precondition": "selfp",
                    "fieldsplit_u_ksp_type": "preonly", "fieldsplit_p_ksp_type": "preonly"}
        amg = ({"pc_type": "hypre", "pc_hypre_type": "boomeramg"} if PETSc.Sys.hasExternalPackage("hypre")
               else {"pc_type": "gamg"})
        for field in ("u", "p"):
            defaults |= {f"fieldsplit_{field}_{name}": value for name, value in amg.items()}
        for name, value in (defaults | (options or {})).items():
            _default_option(f"{prefix}{name}", value)
        _reproducible_krylov()
        self.ksp = PETSc.KSP().create(A.getComm())
        self.ksp.setOptionsPrefix(prefix)
        self.ksp.setOperators(A)
        pc = self.ksp.getPC()
        pc.setType("fieldsplit")
        pc.setFieldSplitIS(("u", velocity), ("p", pressure))
        self.ksp.setFromOptions()
        self.back_solves = 0
        self.solve_time = 0.0
        self.single_solves, self.single_solve_time = 0, 0.0
        self.iterations = 0  # Krylov iterations over all solves
        try:
            self.ksp.setUp()
        except PETSc.Error as err:
            raise SolverError(f"field-split set-up failed ({prefix}): {err}") from None

    def refactor(self) -> None:
        self.ksp.setOperators(self.operator)
        self.ksp.setUp()

    def solve(self, b: PETSc.Vec, x: PETSc.Vec) -> None:
        x.set(0.0)
        _counted_solve(self, b, x)
        self.iterations += self.ksp.getIterationNumber()
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise SolverError(f"iterative solve failed ({self.prefix}): KSP reason {reason} after "
                              f"{self.ksp.getIterationNumber()} iterations")

    def solve_many(self, rhs: list, solutions: list) -> None:
        """One solve per right-hand side (an iterative solver gains nothing from a block)."""
        for b, x in zip(rhs, solutions):
            self.solve(b, x)

    def factor_memory(self) -> None:
        return None

    def destroy(self) -> None:
        if self.ksp is not None:
            self.ksp.destroy()
            self.ksp = None
