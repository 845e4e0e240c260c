"""The pieces of an axisymmetric Taylor-Hood (P2/P1) flow that every finite-element model shares (the fd
model's fixed mesh, the ale model's moving one): the mixed space, the BDF and extrapolation coefficients,
the side conditions named by the mesh's facet tags, the pressure pin, the lifted right-hand side and a uniform state.

Boundaries: "no-slip" (u = 0), "slip" (zero normal velocity, free tangential), "inflow" (u = (0, U_in)),
"outflow" (do nothing: mu du/dn - p n = 0); the axis always has u_r = 0.  When every side fixes the normal
velocity the pressure is pinned at one far corner.
"""
from __future__ import annotations

import basix.ufl
import numpy as np
from dolfinx import fem
from dolfinx.fem.petsc import apply_lifting, assemble_vector, set_bc
from mpi4py import MPI
from petsc4py import PETSc

from .compat import collapse
from .mesh import AXIS, OUTER, TOP, WALL

SIDE_KINDS = ("no-slip", "slip", "inflow", "outflow")
# du/dt ~ sum_j BDF[k][j] u^{n+1-j} / dt and u* = sum_j EXTRAPOLATION[k][j] u^{n-j} (Karniadakis et al. 1991)
BDF = {1: (1.0, -1.0), 2: (1.5, -2.0, 0.5), 3: (11.0 / 6.0, -3.0, 1.5, -1.0 / 3.0)}
EXTRAPOLATION = {1: (1.0,), 2: (2.0, -1.0), 3: (3.0, -3.0, 1.0)}
_NORMAL_COMPONENT = {WALL: 1, TOP: 1, OUTER: 0, AXIS: 0}


def set_velocity(state: fem.Function, velocity: tuple[float, float]) -> None:
    """A mixed (u, p) function set to a uniform velocity and zero pressure."""
    state.x.array[:] = 0.0
    W = state.function_space
    for component in range(2):
        _, dofs = collapse(W.sub(0).sub(component))
        state.x.array[dofs] = velocity[component]


def step_coefficients(order: int, ratio: float = 1.0) -> tuple[tuple, tuple]:
    """(BDF, EXTRAPOLATION) coefficients of a step whose length is `ratio` times the previous one's.
    ratio 1: the constant-step tables above.  Order 2 otherwise: the variable-step BDF2 and its linear
    extrapolation (Hairer, Norsett & Wanner, Solving ODEs I, section III.5; w = ratio):
    du/dt ~ [(1 + 2w)/(1 + w) u^{n+1} - (1 + w) u^n + w^2/(1 + w) u^{n-1}] / dt, u* = (1 + w) u^n - w u^{n-1};
    zero-stable for w < 1 + sqrt(2)."""
    if ratio == 1.0 or order == 1:
        return BDF[order], EXTRAPOLATION[order]
    if order != 2:
        raise ValueError(f"a variable step needs time order 1 or 2, not {order}")
    w = ratio
    return ((1.0 + 2.0 * w) / (1.0 + w), -(1.0 + w), w * w / (1.0 + w)), (1.0 + w, -w)


def side_constraints(facet_tags, sides: dict[int, str]) -> tuple[list[tuple[int, np.ndarray, bool]], bool]:
    """The velocity components the named sides fix, as (component, facets, is_inflow_value), and
    whether every side fixes the normal velocity (then the pressure level is free and must be pinned)."""
    fixed, pinned = [], True
    for side, kind in sides.items():
        facets = facet_tags.find(side)
        if kind == "no-slip":
            fixed += [(0, facets, False), (1, facets, False)]
        elif kind == "slip":
            fixed.append((_NORMAL_COMPONENT[side], facets, False))
        elif kind == "inflow":
            fixed += [(0, facets, False), (1, facets, True)]
        else:
            pinned = False
    return fixed, pinned


def pressure_pin(W, mesh):
    """p = 0 at the domain's far corner (largest r and z), for a pressure fixed only up to a constant."""
    Q, _ = collapse(W.sub(1))
    x = mesh.geometry.x
    corner = x[:, :2].max(axis=0) if x.size else np.full(2, -np.inf)
    corner = np.array([mesh.comm.allreduce(corner[k], op=MPI.MAX) for k in range(2)])
    dofs = fem.locate_dofs_geometrical(
        (W.sub(1), Q), lambda x: np.isclose(x[0], corner[0]) & np.isclose(x[1], corner[1]))
    return fem.dirichletbc(fem.Function(Q), dofs, W.sub(1))


def lifted_rhs(b: PETSc.Vec, L, a, bcs, diagonal: float = 1.0) -> PETSc.Vec:
    """b = assemble(L) (nothing when L is None) lifted by the Dirichlet values of `bcs` through the
    bilinear form a, ghosts accumulated and the boundary rows set to `diagonal` times their values (the
    diagonal the matrix has on those rows, fem.matrix.FormMatrix): ready for a back-solve."""
    with b.localForm() as local:
        local.set(0.0)
    if L is not None:
        assemble_vector(b, L)
    apply_lifting(b, [a], [bcs])
    b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
    set_bc(b, bcs, alpha=diagonal)
    return b


def taylor_hood_space(mesh) -> fem.FunctionSpace:
    """The mixed space of (u, p): continuous P2 velocity (r, z) and P1 pressure."""
    cell = mesh.basix_cell()
    velocity = basix.ufl.element("Lagrange", cell, 2, shape=(mesh.geometry.dim,))
    return fem.functionspace(mesh, basix.ufl.mixed_element([velocity, basix.ufl.element("Lagrange", cell, 1)]))


def field_indices(W, field: int) -> PETSc.IS:
    """The owned global indices of the velocity (0) or pressure (1) dofs of the mixed space W, for a field split."""
    index_map = W.dofmap.index_map
    _, dofs = collapse(W.sub(field))
    dofs = dofs.astype(np.int32)
    owned = np.sort(dofs[dofs < index_map.size_local])
    return PETSc.IS().createGeneral(owned + index_map.local_range[0], comm=W.mesh.comm)


def owned_dirichlet_rows(bcs) -> np.ndarray:
    """This rank's owned local indices of the rows the Dirichlet conditions `bcs` fix (sorted, unique)."""
    rows = [bc.dof_indices()[0][: bc.dof_indices()[1]] for bc in bcs]
    return np.unique(np.concatenate(rows)) if rows else np.zeros(0, dtype=np.int64)
