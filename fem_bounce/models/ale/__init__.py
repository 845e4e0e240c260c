"""The boundary-fitted ALE model: `fem-bounce run SCENE --model ale`.

The sphere is a hole in a gmsh mesh of the meridian half-plane that follows the sphere by a harmonic
extension (fem.mesh_motion) and is remade when its triangles degrade (models/moving_mesh.py: the machinery
and its domain, which the fd model's moving mesh shares), a Taylor-Hood ALE flow with
the sphere surface as a moving no-slip boundary (flow), and the model (model) that hands that flow
to the moving mesh and the forces to the shared sphere integrator.  Every sphere on the axis is a hole
in the same mesh, each with its own extension, unit response and force; per-sphere values are arrays
over them, one sphere too.
"""
from .model import AleModel

__all__ = ["AleModel"]
