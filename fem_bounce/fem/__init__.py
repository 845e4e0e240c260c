"""Finite-element building blocks shared by the mesh-based models (fd and ale).

- `mesh`: the axisymmetric meridian half-plane, meshed by gmsh on rank 0 and cached.
- `forms`: pure functions returning the r-weighted UFL forms of axisymmetric flow.
- `solver`: a factorise-once, back-solve-many linear solver owning its PETSc objects.
- `functions`: partition-independent save/load of finite-element functions.
- `transfer`: a flow carried onto a new mesh; `vertex_fields`: a state as P1 fields for the field files.

Importing this package needs dolfinx; nothing here runs at import.
"""
