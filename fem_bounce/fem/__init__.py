"""Finite-element building blocks shared by the mesh-based models (fd and ale).

- `mesh`: the axisymmetric meridian half-plane, meshed by gmsh on rank 0 and cached; `mesh_motion`: a mesh
  that follows the spheres on the axis (a harmonic extension of each one's displacement) and its triangles' quality.
- `geometry`: the flow's geometry as an object (axisymmetric, Cartesian): its weighted measure, the forms
  built on it and the MPI reduction of an integral.
- `solver`: a factorise-once, back-solve-many linear solver owning its PETSc objects.
- `functions`: partition-independent save/load of finite-element functions.
- `transfer`: a flow carried onto a new mesh; `vertex_fields`: a state as P1 fields for the field files, which
  `field_writer` writes on a fixed or a moving mesh.

Importing this package needs dolfinx; nothing here runs at import.
"""
