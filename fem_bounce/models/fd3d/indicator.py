"""A sphere in a 3-D mesh: its smoothed indicator at the penalty's quadrature points.

    phi(x) = S((a_h - |x - X|) / w),   S(t) = t^2 (3 - 2 t) on [0, 1], 0 below, 1 above,

the same C^1 profile with compact support as the axisymmetric model's (models/fd/immersed.py): 1 deep inside,
falling across a band of width w inside the surface, exactly 0 outside a_h.  The implicit penalisation holds
the whole ball |x - X| < a_h, the band included, so a_h is the sphere's radius (penalised.py's choice).

phi lives in a quadrature space: its values at the quadrature points of every cell this rank holds (ghosts
included), computed from the points' coordinates (tabulated once, and by `tabulate` again after the mesh has
moved) whenever the sphere is placed, so moving the sphere recompiles no form.  `dx` is the measure with the
same points; `center` is a fem.Constant the rigid modes can be built on, updated by `place`.
"""
from __future__ import annotations

import math

import basix
import basix.ufl
import numpy as np
import ufl
from dolfinx import fem

QUADRATURE_DEGREE = 4  # 14 points per tetrahedron: the cubic profile across a band of two cells to ~1e-3


def smooth_step(depth: np.ndarray) -> np.ndarray:
    """S(t) = t^2 (3 - 2 t) clipped to [0, 1]."""
    depth = np.clip(depth, 0.0, 1.0)
    return depth**2 * (3.0 - 2.0 * depth)


class SphereIndicator:
    """phi of a sphere of `radius` (the indicator's outer edge) with a band of `width` [m], centred at `center`
    [m], on a tetrahedral mesh."""

    def __init__(self, mesh, radius: float, width: float, center):
        if not 0 < width <= radius:
            raise ValueError(f"the indicator's band width must lie in (0, radius = {radius}], not {width}")
        self.mesh, self.radius, self.width = mesh, radius, width
        points, weights = basix.make_quadrature(basix.CellType.tetrahedron, QUADRATURE_DEGREE)
        element = basix.ufl.quadrature_element(mesh.basix_cell(), points=points, weights=weights)
        self.phi = fem.Function(fem.functionspace(mesh, element), name="indicator")
        self.dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_rule": "custom", "quadrature_points": points,
                                                           "quadrature_weights": weights})
        cells = mesh.topology.index_map(3)
        self._cells = np.arange(cells.size_local + cells.num_ghosts, dtype=np.int32)
        self._rule, self._coordinates = points, None  # the coordinates' expression, compiled when first tabulated
        self._dofs = self.phi.function_space.dofmap.list[self._cells]
        self.center = fem.Constant(mesh, np.zeros(3))
        self.tabulate()
        self.place(center)

    def tabulate(self) -> None:
        """The quadrature points' coordinates (cells, points, 3) [m], again after the mesh has moved."""
        if self._coordinates is None:
            self._coordinates = fem.Expression(ufl.SpatialCoordinate(self.mesh), self._rule)
        self._points = self._coordinates.eval(self.mesh, self._cells)

    def _set_center(self, center) -> np.ndarray:
        center = np.asarray(center, dtype=float)
        if center.shape != (3,):
            raise ValueError(f"a sphere's centre has 3 coordinates, not {center.shape}")
        self.center.value[:] = center
        return center

    def place(self, center) -> None:
        """Put the sphere's centre at `center` [m]: phi at every quadrature point, and the centre constant."""
        center = self._set_center(center)
        distance = np.linalg.norm(self._points - center, axis=2)
        self.phi.x.array[self._dofs] = smooth_step((self.radius - distance) / self.width)

    @property
    def ball_volume(self) -> float:
        """4/3 pi a_h^3 [m^3]: the volume the penalty holds (the whole ball, band included)."""
        return 4.0 / 3.0 * math.pi * self.radius**3


class ConformingBall(SphereIndicator):
    """The sharp indicator of a sphere whose surface is a surface of the mesh (mesh.BoxSpec.conforming, the moving
    mesh's): phi = 1 at every point of the ball's cells `cells`, 0 elsewhere, so the velocity's kink at the surface
    lies on the cells' faces, where the P2 space has it.  The mesh carries the ball with the sphere: `place` moves
    the centre only.  `width` [m] is the depth below the surface that the interior-slip check leaves out."""

    def __init__(self, mesh, cells: np.ndarray, radius: float, width: float, center):
        self._ball_cells = np.asarray(cells, dtype=np.int32)
        super().__init__(mesh, radius, width, center)
        self.phi.x.array[:] = 0.0
        self.phi.x.array[self.phi.function_space.dofmap.list[self._ball_cells]] = 1.0

    def tabulate(self) -> None:
        """Nothing to do: phi belongs to the cells."""

    def place(self, center) -> None:
        self._set_center(center)
