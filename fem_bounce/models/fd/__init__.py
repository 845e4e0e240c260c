"""The finite-element fictitious-domain model: `fem-bounce run SCENE --model fd`.

A Taylor-Hood P2/P1 axisymmetric flow on a fixed gmsh mesh (fluid), a smoothed
sphere indicator with an immersed force (immersed), implicit coupling with the
shared sphere integrator (coupling), and the time loop with its outputs (model).
"""
from .model import FictitiousDomainModel

__all__ = ["FictitiousDomainModel"]
