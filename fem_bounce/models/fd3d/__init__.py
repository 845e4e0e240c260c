"""The three-dimensional fictitious-domain model's flow: a sphere held by a volume penalty in a box of liquid.

- `mesh`: the box above the wall, tetrahedra fine only around the sphere and the gap (gmsh), optionally the half
  y >= 0 of a flow symmetric about y = 0;
- `indicator`: the sphere's smoothed indicator at the penalty's quadrature points;
- `flow`: Taylor-Hood P2/P1 with the side conditions, the penalised steady Stokes solve and the BDF2 step, each
  giving the flow affine in the rigid-body amplitudes;
- `response`: the penalty's force on the sphere, affine in those amplitudes (what the body integrator takes);
- `transfer`: a flow carried from one patch's mesh to the next (dolfinx's non-matching interpolation);
- `model`: `--model fd3d`, the FlowModel of a head-on bounce on the half box: the sphere moving along z through a
  mesh refined in a patch around it (a new mesh when it strays), the force linearised in the acceleration for the
  body integrator, the near-wall correction's hold, adaptive steps, checkpoints and XDMF fields.

Not yet here: oblique motion (the body state in space), a solver that keeps its factorisation over several steps.

Importing this package needs dolfinx; nothing here runs at import.
"""
