"""Studies: what users do with the models once they exist.  Each runs many simulations through the
run cache (fem_bounce.cache), so it can be interrupted, resumed and redrawn without re-running."""
from . import band, convergence, figures, restitution, speed_accuracy, stability

__all__ = ["band", "convergence", "figures", "restitution", "speed_accuracy", "stability"]
