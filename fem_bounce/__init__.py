"""fem_bounce: a sphere falling through a viscous liquid onto a wall, and its bounces.

Li, Hunt & Colonius (2011), J. Fluid Mech. 691, 123-145: the contact model,
here shared by a ladder of models (ode, fd, ib, ale); see README.md.
"""
__version__ = "0.1.0"
