"""The three-dimensional fictitious-domain model's flow: a sphere held by a volume penalty in a box of liquid.

- `mesh`: the box above the wall, tetrahedra fine only around the sphere and the gap (gmsh), optionally the half
  y >= 0 of a flow symmetric about y = 0;
- `indicator`: the sphere's smoothed indicator at the penalty's quadrature points;
- `flow`: Taylor-Hood P2/P1 with the side conditions, the penalised steady Stokes solve and the BDF2 step, each
  giving the flow affine in the rigid-body amplitudes;
- `response`: the penalty's force on the sphere, affine in those amplitudes (what the body integrator takes).

Not yet here: the body integrator's coupling, the contact model, a patch that follows the sphere, output.

Importing this package needs dolfinx; nothing here runs at import.
"""
