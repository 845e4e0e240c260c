"""The finite-element fictitious-domain model: `fem-bounce run SCENE --model fd`.

A Taylor-Hood P2/P1 axisymmetric flow (fluid), a smoothed sphere indicator with an immersed force
(immersed; penalised: the implicit constraint), implicit coupling with the shared sphere integrator
(coupling), and the time loop with its outputs: on a fixed mesh (model), or on one that moves with
the spheres (moving: numerics.fd.mesh = "moving", on the moving mesh the ale model also uses: models/moving_mesh.py).
"""
from .model import FictitiousDomainModel
from .moving import MovingFictitiousDomainModel


def model_class(scene):
    """The fd model's class for `scene`: the moving mesh's (numerics.fd.mesh = "moving") unless the scene asks
    for the held spheres' steady Stokes state (numerics.fd.steady_stokes, a solve on the fixed mesh)."""
    return MovingFictitiousDomainModel if scene.numerics.fd.moving else FictitiousDomainModel


__all__ = ["FictitiousDomainModel", "MovingFictitiousDomainModel", "model_class"]
