"""A bilinear form's PETSc matrix, assembled again in place whenever the form's coefficients or mesh change.

    A = FormMatrix(form, bcs)     # assembled once; A.petsc is the PETSc Mat a solver factorises
    A.assemble()                  # the form again, into the same Mat (same sparsity: the factorisation's
                                  # analysis is kept)

On one rank the PETSc matrix shares its values with a dolfinx MatrixCSR of the same sparsity
(MatCreateSeqAIJWithArrays: no copy), which dolfinx's own assembler fills: PETSc's insertion, a
MatSetValuesLocal per cell, is a quarter of an assembly (2.0 of 7.6 ms for the fd model's step matrix at
8.8k unknowns, 2.9 of 11.1 ms at 13k; docs/performance.md).  On several ranks the PETSc matrix is
assembled directly (its rows are split between a diagonal and an off-diagonal block that a MatrixCSR does
not share).
"""
from __future__ import annotations

from dolfinx import fem
from dolfinx.fem.petsc import assemble_matrix
from petsc4py import PETSc


class FormMatrix:
    """The matrix of `form` (a compiled dolfinx form) with the Dirichlet conditions `bcs` (rows and columns
    zeroed, `diagonal` on the diagonal: fem.geometry.Geometry.dirichlet_diagonal for the weighted forms)."""

    def __init__(self, form, bcs, diagonal: float = 1.0):
        self.form, self.bcs, self.diagonal = form, bcs, diagonal
        if form.mesh.comm.size == 1:
            self._csr = fem.assemble_matrix(form, bcs=bcs, diag=diagonal)
            # PETSc keeps pointers to these arrays: they must live as long as the matrix
            self._rows = self._csr.indptr.astype(PETSc.IntType)
            self._columns = self._csr.indices.astype(PETSc.IntType)
            size = len(self._rows) - 1
            self.petsc = PETSc.Mat().createAIJWithArrays((size, size), (self._rows, self._columns, self._csr.data),
                                                         comm=PETSc.COMM_SELF)
        else:
            self._csr = None
            self.petsc = assemble_matrix(form, bcs=bcs, diag=diagonal)
        self.petsc.assemble()

    def assemble(self) -> PETSc.Mat:
        """Assemble the form again into the same matrix (its new state tells a solver to factorise again)."""
        if self._csr is None:
            self.petsc.zeroEntries()
            assemble_matrix(self.petsc, self.form, bcs=self.bcs, diag=self.diagonal)
        else:
            self._csr.set_value(0.0)
            fem.assemble_matrix(self._csr, self.form, bcs=self.bcs, diag=self.diagonal)
        self.petsc.assemble()
        return self.petsc

    def destroy(self) -> None:
        self.petsc.destroy()
