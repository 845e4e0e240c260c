"""A box of liquid above a wall, meshed with tetrahedra by gmsh, fine only around a sphere and in the gap below it.

    spec = BoxSpec(half_width=L, height=H, center=(x_c, 0, z_c), radius=a, surface_size=h, gap_size=h_g,
                   coarse_size=H_c, grading=0.3, mirrored=True)
    mesh, cell_tags, facet_tags = create_box_mesh(comm, spec)

The box is x in [x_b - L, x_b + L] (x_b = `box_center`, 0 unless the box follows a sphere along the wall), y in
[-L, L] (y in [0, L] when `mirrored`: the half of a flow symmetric about the plane
y = 0 through the sphere's centre, for a motion in the x-z plane), z in [0, H], the wall at z = 0.  The sphere
is not cut out (the fictitious-domain model holds it by a penalty on a mesh that fills it); the mesh is fine
only where the flow needs it:

    size(x) = min(coarse_size, surface_size + grading |d_S|, gap_size + grading d_G),

d_S = |x - X| - a the signed distance from the sphere's surface (the size grows inward too: the held interior
needs no resolution), d_G the distance from the gap cylinder under the sphere (horizontal distance from the
centre below gap_radius, 0 <= z <= z_c); with gap_cells > 0 also at most g(rho) / gap_cells between the wall and
the sphere's lower surface, g(rho) = z_c - sqrt(a^2 - rho^2) the local gap at the horizontal distance rho < a
from the centre (a thin gap keeps that many cells across, and the size grows with the gap as the 2-D mesh's does).
With `travel` > 0 the sphere may sit anywhere with its centre within `travel` of `center` along z (the patch the
fd3d model moves it through, model.py): |d_S| is then the distance from the nearest of those spheres' surfaces
(zero in the shell they sweep), and the gap rule takes the lowest of them.  One gmsh MathEval field evaluates
the law (`size_at` is the same in numpy, for checks and for estimates).  The faces carry physical groups: WALL
(z = 0), TOP (z = H), SIDE_X (x = x_b +- L), SIDE_Y (y = +-L, or y = L in the half box) and SYMMETRY (y = 0 in the
half box).  With `conforming` (the moving mesh's) the sphere is cut out of the box and put back (gmsh's OCC
fragment), so its surface is a surface of the mesh (facet group SURFACE) and its inside the cell group BALL;
gmsh puts the surface's vertices on the sphere, and `restore_ball_volume` moves them out to give the polyhedron
the sphere's volume.

gmsh meshes on rank 0 and dolfinx.io.gmsh distributes the mesh.  With `cache` the .msh file is kept in the
mesh cache directory (fem_bounce.cachedir, folder meshes/) under a hash of the spec and the gmsh version,
written beside its place and renamed, with its SHA-256 beside it, and read back only when the hash matches
(a damaged entry is made again); without it the mesh goes straight from gmsh's memory to dolfinx (tests).
Meshing runs in this process: a box at the sizes this model uses meshes in seconds.
"""
from __future__ import annotations

import dataclasses
import hashlib
import importlib.metadata
import json
import os
import signal
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ... import cachedir
from ...fem.mesh import size_everywhere
from ...output import file_digest, sync_file

FLUID, BALL = 1, 2  # the cell groups (BALL: inside a conforming sphere)
WALL, TOP, SIDE_X, SIDE_Y, SYMMETRY, SURFACE = 1, 2, 3, 4, 5, 6  # the facet groups (SURFACE: a conforming sphere's)
BOUNDARY_NAMES = {WALL: "wall", TOP: "top", SIDE_X: "side_x", SIDE_Y: "side_y", SYMMETRY: "symmetry",
                  SURFACE: "surface"}
NORMAL_COMPONENT = {WALL: 2, TOP: 2, SIDE_X: 0, SIDE_Y: 1, SYMMETRY: 1}  # the velocity component normal to each
MESH_FORMAT_VERSION = 2  # part of the cache key: bump when the meshing below changes


@dataclass(frozen=True)
class BoxSpec:
    """The box, the sphere its mesh is refined around, and the sizes [m] (module docstring)."""

    half_width: float
    height: float
    center: tuple[float, float, float]
    radius: float
    surface_size: float
    coarse_size: float
    grading: float = 0.3
    gap_size: float | None = None  # the size in the gap under the sphere (None: surface_size)
    gap_radius: float | None = None  # the gap cylinder's radius (None: half the sphere's radius)
    gap_cells: float = 0.0  # at least this many cells across the local gap under the sphere (0: no such rule)
    mirrored: bool = False
    travel: float = 0.0  # the centre may lie within this of `center` along z (module docstring) [m]
    conforming: bool = False  # the sphere's surface a surface of the mesh (module docstring)
    box_center: float = 0.0  # x_b, the box's middle along x [m]

    def __post_init__(self):
        x, y, z = self.center
        x -= self.box_center
        a = self.radius
        if not 0.0 <= self.travel < z - a:
            raise ValueError(f"travel must lie in [0, gap = {z - a}), not {self.travel}")
        if not (a > 0 and 0 < self.surface_size <= self.coarse_size and self.grading > 0):
            raise ValueError(f"inconsistent box mesh spec {self}")
        if not (z > a and z + a < self.height and abs(x) + a < self.half_width and abs(y) + a < self.half_width):
            raise ValueError(f"the sphere of radius {a} at {self.center} does not fit above the wall in the box "
                             f"{2 * self.half_width} x {2 * self.half_width} x {self.height}")
        if self.conforming and self.travel:
            raise ValueError("a conforming sphere's surface has one place: travel must be 0")
        if self.mirrored and y != 0.0:
            raise ValueError(f"a mirrored (half) box needs the sphere's centre on the plane y = 0, not y = {y}")
        if (self.gap_size is not None and not self.gap_size > 0) or self.gap_cells < 0:
            raise ValueError(f"gap_size must be positive and gap_cells not negative, not {self.gap_size}, "
                             f"{self.gap_cells}")

    @property
    def gap(self) -> float:
        """The distance from the sphere's lowest point to the wall [m]."""
        return self.center[2] - self.radius

    def _gap_size(self) -> float:
        return self.surface_size if self.gap_size is None else self.gap_size

    def _gap_radius(self) -> float:
        return 0.5 * self.radius if self.gap_radius is None else self.gap_radius

    def key(self) -> str:
        """A short hash of everything that shapes the mesh (the cache file's name)."""
        data = dataclasses.asdict(self) | {"format": MESH_FORMAT_VERSION, "gmsh": _gmsh_version()}
        for option in ("conforming", "box_center"):  # the keys of the meshes made before the options
            if not data[option]:
                del data[option]
        text = json.dumps(data, sort_keys=True, default=lambda value: round(value, 15))
        return hashlib.sha1(text.encode()).hexdigest()[:16]

    def size_at(self, x, y, z) -> np.ndarray:
        """The target tetrahedron size at points (x, y, z) [m]: the law of the gmsh field."""
        xc, yc, zc = self.center
        x, y, z = (np.asarray(value, dtype=float) for value in (x, y, z))
        if self.travel:  # the distance from the nearest surface of the spheres centred on the segment
            across, along = (x - xc) ** 2 + (y - yc) ** 2, np.abs(z - zc)
            capsule = np.sqrt(across + np.maximum(along - self.travel, 0.0) ** 2) - self.radius  # > 0 outside all
            inner = self.radius - np.sqrt(across + (along + self.travel) ** 2)  # > 0 inside all
            surface = np.maximum(np.maximum(capsule, inner), 0.0)
        else:
            surface = np.abs(np.sqrt((x - xc) ** 2 + (y - yc) ** 2 + (z - zc) ** 2) - self.radius)
        horizontal = np.maximum(np.hypot(x - xc, y - yc) - self._gap_radius(), 0.0)
        gap = np.hypot(horizontal, np.maximum(z - zc, 0.0))
        size = np.minimum(np.minimum(self.coarse_size, self.surface_size + self.grading * surface),
                          self._gap_size() + self.grading * gap)
        if self.gap_cells > 0:
            rho = np.hypot(x - xc, y - yc)
            local_gap = (zc - self.travel) - np.sqrt(np.maximum(self.radius**2 - rho**2, 0.0))
            outside = np.maximum(z - local_gap, 0.0) + np.maximum(rho - self.radius, 0.0)  # not in the gap: no cap
            size = np.minimum(size, local_gap / self.gap_cells + 1e6 * outside)
        return size

    def _gmsh_size_expression(self) -> str:
        xc, yc, zc = (repr(float(value)) for value in self.center)
        if self.travel:
            across, t, a = f"(x - {xc})^2 + (y - {yc})^2", repr(float(self.travel)), repr(self.radius)
            capsule = f"sqrt({across} + max(abs(z - {zc}) - {t}, 0)^2) - {a}"
            inner = f"{a} - sqrt({across} + (abs(z - {zc}) + {t})^2)"
            surface = f"max(max({capsule}, {inner}), 0)"
        else:
            surface = f"abs(sqrt((x - {xc})^2 + (y - {yc})^2 + (z - {zc})^2) - {self.radius!r})"
        horizontal = f"max(sqrt((x - {xc})^2 + (y - {yc})^2) - {self._gap_radius()!r}, 0)"
        gap = f"sqrt({horizontal}^2 + max(z - {zc}, 0)^2)"
        text = (f"min(min({self.coarse_size!r}, {self.surface_size!r} + {self.grading!r} * {surface}), "
                f"{self._gap_size()!r} + {self.grading!r} * {gap})")
        if self.gap_cells > 0:
            rho = f"sqrt((x - {xc})^2 + (y - {yc})^2)"
            lowest = repr(float(self.center[2]) - self.travel) if self.travel else zc
            local_gap = f"({lowest} - sqrt(max({self.radius**2!r} - (x - {xc})^2 - (y - {yc})^2, 0)))"
            outside = f"(max(z - {local_gap}, 0) + max({rho} - {self.radius!r}, 0))"
            text = f"min({text}, {local_gap} / {self.gap_cells!r} + 1e6 * {outside})"
        return text

    def estimated_vertices(self, samples: int = 60) -> float:
        """About how many mesh vertices gmsh makes: the integral of 1 / (0.65 size^3) (a regular tetrahedron of
        edge h has volume h^3 / 8.5, and a Delaunay mesh has about 5.5 tetrahedra per vertex) by the midpoint
        rule on grids log-spaced from the sphere's surface; P2/P1 Taylor-Hood has about 25 unknowns a vertex."""
        low = 0.0 if self.mirrored else -self.half_width

        def nodes(start, stop, around):
            fine = self.surface_size / 4.0
            offsets = np.geomspace(fine, max(stop - start, fine), samples)
            return np.unique(np.clip(np.r_[start, stop, around - offsets, around + offsets,
                                           np.linspace(start, stop, samples)], start, stop))

        xs = nodes(self.box_center - self.half_width, self.box_center + self.half_width, self.center[0])
        ys = nodes(low, self.half_width, self.center[1])
        zs = nodes(0.0, self.height, self.center[2])
        mid = [0.5 * (n[1:] + n[:-1]) for n in (xs, ys, zs)]
        size = self.size_at(mid[0][:, None, None], mid[1][None, :, None], mid[2][None, None, :])
        volume = np.diff(xs)[:, None, None] * np.diff(ys)[None, :, None] * np.diff(zs)[None, None, :]
        return float(np.sum(volume / (0.65 * size**3)))


def _gmsh_version() -> str:
    try:
        return importlib.metadata.version("gmsh")
    except importlib.metadata.PackageNotFoundError:  # a gmsh installed without Python metadata
        import gmsh

        return gmsh.__version__


def cache_directory() -> Path:
    """The generated meshes' folder in fem_bounce's cache (the same as the axisymmetric meshes')."""
    return cachedir.folder("meshes")


class _Handlers:
    """The process's SIGINT and SIGTERM handlers as Python set them (main thread only): gmsh.initialize puts
    the defaults back and never restores them."""

    def __init__(self):
        main = threading.current_thread() is threading.main_thread()
        self.saved = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)} if main else {}

    def restore(self) -> None:
        for signum, handler in self.saved.items():
            if handler is not None:
                signal.signal(signum, handler)


def _build_model(gmsh, spec: BoxSpec) -> None:
    """The box, its physical groups and its size field in the current gmsh model, meshed."""
    L, H, x_b = spec.half_width, spec.height, spec.box_center
    y_low = 0.0 if spec.mirrored else -L
    box = gmsh.model.occ.addBox(x_b - L, y_low, 0.0, 2.0 * L, L - y_low, H)
    ball_volumes: list[int] = []
    if spec.conforming:  # the ball cut out of the box and put back: two volumes sharing the sphere's surface
        ball = gmsh.model.occ.addSphere(*spec.center, spec.radius)
        pieces, _ = gmsh.model.occ.fragment([(3, box)], [(3, ball)])
        outside = [piece for piece in pieces if gmsh.model.occ.getCenterOfMass(*piece)[1] < y_low]
        gmsh.model.occ.remove(outside, recursive=True)
        gmsh.model.occ.synchronize()
        for _, volume in gmsh.model.getEntities(3):
            lo = gmsh.model.getBoundingBox(3, volume)
            if lo[3] - lo[0] < 2.0 * L * (1 - 1e-9):  # not the whole box's width: the ball
                ball_volumes.append(volume)
    gmsh.model.occ.synchronize()
    faces: dict[int, list[int]] = {}
    for _, face in gmsh.model.getEntities(2):
        x, y, z = gmsh.model.occ.getCenterOfMass(2, face)
        tolerance = 1e-9 * max(L, H)
        if gmsh.model.getType(2, face) == "Sphere":
            group = SURFACE
        elif abs(z) < tolerance:
            group = WALL
        elif abs(z - H) < tolerance:
            group = TOP
        elif abs(abs(x - x_b) - L) < tolerance:
            group = SIDE_X
        elif spec.mirrored and abs(y) < tolerance:
            group = SYMMETRY
        else:
            group = SIDE_Y
        faces.setdefault(group, []).append(face)
    for group, tags in faces.items():
        gmsh.model.addPhysicalGroup(2, tags, group)
        gmsh.model.setPhysicalName(2, group, BOUNDARY_NAMES[group])
    volumes = [tag for _, tag in gmsh.model.getEntities(3) if tag not in ball_volumes]
    gmsh.model.addPhysicalGroup(3, volumes, FLUID)
    gmsh.model.setPhysicalName(3, FLUID, "fluid")
    if ball_volumes:
        gmsh.model.addPhysicalGroup(3, ball_volumes, BALL)
        gmsh.model.setPhysicalName(3, BALL, "ball")
    size_everywhere(gmsh, spec._gmsh_size_expression())
    gmsh.model.mesh.generate(3)


def create_box_mesh(comm, spec: BoxSpec, cache: bool = True):
    """(mesh, cell_tags, facet_tags) of the box, distributed over comm (module docstring)."""
    import gmsh
    from dolfinx.io import gmsh as gmsh_io

    handlers = _Handlers()
    path = cache_directory() / f"box3d-{spec.key()}.msh" if cache and comm.rank == 0 else None
    failure = None
    if comm.rank == 0:
        gmsh.initialize(interruptible=False)
        handlers.restore()
        try:
            gmsh.option.setNumber("General.Terminal", 0)
            if path is not None and not _verified(path):
                gmsh.model.add("box3d")
                _build_model(gmsh, spec)
                _write_entry(gmsh, path)
                gmsh.clear()
            if path is not None:
                gmsh.merge(str(path))  # a fresh and a cached mesh are then the same to the last bit
            else:
                gmsh.model.add("box3d")
                _build_model(gmsh, spec)
        except Exception as err:  # noqa: BLE001 -- gmsh raises plain Exception; every rank raises below
            failure = f"{type(err).__name__}: {err}"
        failure = comm.bcast(failure, root=0)
        try:
            if failure is None:
                result = gmsh_io.model_to_mesh(gmsh.model, comm, 0, gdim=3)
        finally:
            gmsh.finalize()
            handlers.restore()
    else:
        failure = comm.bcast(None, root=0)
        if failure is None:
            result = gmsh_io.model_to_mesh(None, comm, 0, gdim=3)
    if failure is not None:
        raise RuntimeError(f"meshing the box {spec} failed: {failure}")
    return result.mesh, result.cell_tags, result.facet_tags


def _hash_file(path: Path) -> Path:
    return path.with_name(path.name + ".sha256")


def _verified(path: Path) -> bool:
    try:
        return file_digest(path) == _hash_file(path).read_text().strip()
    except OSError:
        return False


def _write_entry(gmsh, path: Path) -> None:
    """The current model's mesh into the cache entry `path`: beside its place, fsynced, renamed, then its hash."""
    partial = path.with_name(f".{path.stem}.{os.getpid()}.partial{path.suffix}")
    try:
        gmsh.write(str(partial))
        sync_file(partial)
        _hash_file(path).unlink(missing_ok=True)
        partial.replace(path)
        hashed = partial.with_name(partial.name + ".sha256")
        hashed.write_text(file_digest(path) + "\n")
        sync_file(hashed)
        hashed.replace(_hash_file(path))
    finally:
        partial.unlink(missing_ok=True)


def cells_across_sphere(spec: BoxSpec) -> float:
    """The sphere's diameter in surface-size cells (the resolution the penalty's band sees)."""
    return 2.0 * spec.radius / spec.surface_size



def restore_ball_volume(mesh, cell_tags, spec: BoxSpec) -> float:
    """Scale a conforming ball's vertices radially about its centre so that the polyhedron has the sphere's volume;
    returns the factor.  gmsh puts the surface's vertices on the sphere, so the flat faces between them cut away
    about 4 % of the volume at 6 cells/D and 2 % at 8: a body 1.3 % (0.7 %) smaller in radius, whose drag is
    smaller.  The layer of liquid cells on the surface is squeezed by the same fraction of a radius (a small part
    of a cell).  The vertices are picked by position (on or inside the sphere), the same on every rank."""
    import ufl
    from dolfinx import fem
    from mpi4py import MPI

    dx = ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags)
    local = fem.assemble_scalar(fem.form(fem.Constant(mesh, 1.0) * dx(BALL)))
    volume = mesh.comm.allreduce(local, op=MPI.SUM) * (2.0 if spec.mirrored else 1.0)
    factor = (4.0 / 3.0 * np.pi * spec.radius**3 / volume) ** (1.0 / 3.0)
    x = mesh.geometry.x
    offset = x - np.asarray(spec.center)
    inside = np.linalg.norm(offset, axis=1) <= spec.radius * (1.0 + 1e-9)
    x[inside] = np.asarray(spec.center) + factor * offset[inside]
    return factor
