"""A linear operator factorised once and back-solved many times.

    solver = FactorizedOperator(A, prefix="fd_fluid_")
    solver.solve(b, x)            # one back-solve with the stored factors
    solver.refactor()             # after A's values changed (same sparsity: the analysis is reused)
    solver.destroy()

The default is MUMPS LU through PETSc (`-{prefix}pc_factor_mat_solver_type`,
`-{prefix}mat_mumps_icntl_*` tune it from the command line).  The operator owns
its KSP and destroys it; `back_solves` counts the solves, so a model can report
its cost per time step in back-solves.
"""
from __future__ import annotations

from petsc4py import PETSc


MUMPS_WORKSPACE_TOO_SMALL = (-8, -9)  # INFOG(1): integer or real workspace ran out


class SolverError(RuntimeError):
    """The factorisation or a back-solve failed."""


def _default_option(name: str, value) -> None:
    options = PETSc.Options()
    if not options.hasName(name):
        options[name] = value


class FactorizedOperator:
    """Factorise A (PETSc Mat) once on construction; `solve` back-substitutes."""

    def __init__(self, A: PETSc.Mat, prefix: str, factor: str = "lu", package: str = "mumps"):
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
        self.ksp.solve(b, x)
        self.back_solves += 1
        reason = self.ksp.getConvergedReason()
        if reason < 0:
            raise SolverError(f"back-solve failed ({self.prefix}): KSP reason {reason}")

    def factor_memory(self) -> float:
        """Bytes held by the factors on this rank (MUMPS INFOG(22) is the total in MB), or 0 if unknown."""
        pc = self.ksp.getPC()
        try:
            factor = pc.getFactorMatrix()
            return float(factor.getMumpsInfog(22)) * 1e6
        except (PETSc.Error, AttributeError):
            return 0.0

    def destroy(self) -> None:
        if self.ksp is not None:
            self.ksp.destroy()
            self.ksp = None
