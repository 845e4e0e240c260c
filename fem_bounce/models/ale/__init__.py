"""The boundary-fitted ALE model: `fem-bounce run SCENE --model ale`.

The sphere is a hole in a gmsh mesh of the meridian half-plane (domain), the mesh
follows the sphere by a harmonic extension and is remade when its triangles degrade
(motion, remesh), a Taylor-Hood ALE flow with the sphere surface as a moving no-slip
boundary (flow), implicit coupling with the shared sphere integrator and the time loop
with its outputs (model).  Every sphere on the axis is a hole in the same mesh, each with its own
extension, unit response and force; per-sphere values are arrays over them, one sphere too.
"""
from .model import AleModel

__all__ = ["AleModel"]
