"""The axisymmetric meridian half-plane r in [0, R], z in [0, Z], meshed with gmsh.

    spec = HalfPlane(radius=R, height=Z, fine_size=h, coarse_size=H, grading=0.1,
                     refined=(Box(r_max=..., z_min=..., z_max=...),))
    mesh, cell_tags, facet_tags = create_mesh(comm, spec)

Triangles have size `fine_size` inside the refined boxes and grow linearly with
the distance d from them, size = fine_size + grading * d, up to `coarse_size`.
The boundary carries named physical groups (WALL z = 0, AXIS r = 0, OUTER r = R,
TOP z = Z) so a model can pick its conditions per side.  A boundary-fitted model
cuts the spheres on the axis out of the half-plane (`holes=(SphereHole(...), ...)`,
lowest first): their surfaces are the groups SPHERE, SPHERE_2, ..., each meshed at its
own size, and the thin gap to the wall or between two surfaces keeps a set number
of triangles across.  A filled sphere (`SphereHole(..., filled=True)`, the fd model on a mesh that
moves with it) is meshed inside too, its triangles the group SOLID: its surface is then a curve of
the mesh, not a boundary.

gmsh meshes on rank 0, a large mesh in a child process that a signal stops (`_generate`);
`dolfinx.io.gmsh` distributes the mesh.  The .msh file is cached under the mesh
cache directory (see `cache_directory`), keyed by a hash of the spec and the gmsh
version (another release meshes the same spec differently), written atomically and
checked against its hash when read, so a convergence study or a restart never
meshes twice and a damaged entry is made again.  A mesh above MAX_CELLS triangles
is refused before anything runs (`check_size`).
"""
from __future__ import annotations

import dataclasses
import hashlib
import importlib.metadata
import json
import math
import os
import pickle
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import cachedir
from ..errors import OutputError
from ..output import file_digest, sync_file
from ..progress import on_root_watching, stop_requested
from ..scene import SceneError

# physical group tags
FLUID, SOLID = 1, 2  # cell groups: the liquid, the inside of filled spheres
WALL, AXIS, OUTER, TOP, SPHERE, SPHERE_2 = 1, 2, 3, 4, 5, 6
SPHERE_TAGS = tuple(range(SPHERE, SPHERE + 8))  # the surface of the k-th hole from the bottom (at most 8)
BOUNDARY_NAMES = {WALL: "wall", AXIS: "axis", OUTER: "outer", TOP: "top", SPHERE: "sphere",
                  **{tag: f"sphere_{k + 1}" for k, tag in enumerate(SPHERE_TAGS) if k}}
MESH_FORMAT_VERSION = 1  # part of the cache key: bump when the meshing below changes


@dataclass(frozen=True)
class Box:
    """A region r <= r_max, z_min <= z <= z_max meshed at `size`, or at the half-plane's fine size when
    size is None [m] (a finer box inside the fine region, e.g. the gap under a sphere's path)."""

    r_max: float
    z_min: float
    z_max: float
    size: float | None = None

    def distance(self, r: np.ndarray, z: np.ndarray) -> np.ndarray:
        dr = np.maximum(r - self.r_max, 0.0)
        dz = np.maximum(np.maximum(z - self.z_max, self.z_min - z), 0.0)
        return np.hypot(dr, dz)


@dataclass(frozen=True)
class SphereHole:
    """A sphere of `radius` centred on the axis at z = `center`, cut out of the half-plane [m].

    Triangles on its surface have size `surface_size` and grow with the distance from it at
    the half-plane's grading.  Below it, where the local gap between sphere and wall
    g(r) = center - sqrt(radius^2 - r^2) is thin, they are at most g(r) / `gap_cells`
    (0: no gap rule), so a thin gap keeps that many triangles across."""

    center: float
    radius: float
    surface_size: float
    gap_cells: float = 0.0
    filled: bool = False  # its inside meshed too (sizes growing inward from the surface at the grading)

    def __post_init__(self):
        if not (self.radius > 0 and self.center > self.radius and self.surface_size > 0 and self.gap_cells >= 0):
            raise ValueError(f"inconsistent sphere hole {self}")

    @property
    def gap(self) -> float:
        """Distance from the sphere's lowest point to the wall z = 0 [m]."""
        return self.center - self.radius

    @property
    def top(self) -> float:
        """z of the sphere's highest point [m]."""
        return self.center + self.radius

    def size_at(self, r: np.ndarray, z: np.ndarray, grading: float, below: SphereHole | None = None) -> np.ndarray:
        """The size limit of the surface and the gap at (r, z) [m] (the same law as gmsh_size).  The gap
        is the one down to the wall, or up from the sphere `below` (a pair)."""
        a, zc = self.radius, self.center
        distance = np.hypot(r, z - zc) - a
        size = self.surface_size + grading * (np.abs(distance) if self.filled else np.maximum(distance, 0.0))
        if self.gap_cells > 0:
            local_gap = zc - np.sqrt(np.maximum(a * a - r * r, 0.0))
            # only beneath the sphere's centre (a filled one's: beneath its surface): the rule must not
            # refine the axis above it
            cap = 1e6 * np.maximum(z - (local_gap if self.filled else zc), 0.0)
            if below is not None:  # the local gap between the two surfaces, between the two centres
                below_top = below.center + np.sqrt(np.maximum(below.radius**2 - r * r, 0.0))  # its surface's top
                local_gap = local_gap - below_top
                cap = cap + 1e6 * np.maximum((below_top if below.filled else below.center) - z, 0.0)
            size = np.minimum(size, local_gap / self.gap_cells + cap)
        return size

    def gmsh_size(self, grading: float, below: SphereHole | None = None) -> str:
        """size_at as a gmsh MathEval expression in x = r, y = z."""
        a, zc = self.radius, self.center
        distance = f"sqrt(x^2 + (y - {zc!r})^2) - {a!r}"  # from the surface, negative inside
        growth = f"abs({distance})" if self.filled else f"max({distance}, 0)"
        text = f"{self.surface_size!r} + {grading!r} * {growth}"
        if self.gap_cells > 0:
            local_gap = f"({zc!r} - sqrt(max({a * a!r} - x^2, 0)))"
            cap = f"1e6 * max(y - {local_gap if self.filled else repr(zc)}, 0)"
            if below is not None:
                b, zb = below.radius, below.center
                below_top = f"({zb!r} + sqrt(max({b * b!r} - x^2, 0)))"
                local_gap = f"({zc!r} - sqrt(max({a * a!r} - x^2, 0)) - {zb!r} - sqrt(max({b * b!r} - x^2, 0)))"
                cap = f"{cap} + 1e6 * max({below_top if below.filled else repr(zb)} - y, 0)"
            text = f"min({text}, {local_gap} / {self.gap_cells!r} + {cap})"
        return text


@dataclass(frozen=True)
class HalfPlane:
    """Geometry and mesh-size field of the meridian half-plane [m]."""

    radius: float
    height: float
    fine_size: float
    coarse_size: float
    grading: float
    refined: tuple[Box, ...] = ()
    holes: tuple[SphereHole, ...] = ()  # the spheres on the axis, lowest first

    def __post_init__(self):
        if not (self.radius > 0 and self.height > 0 and 0 < self.fine_size <= self.coarse_size and self.grading > 0):
            raise ValueError(f"inconsistent mesh spec {self}")
        if len(self.holes) > len(SPHERE_TAGS):
            raise ValueError(f"at most {len(SPHERE_TAGS)} sphere holes (one boundary tag each), got {len(self.holes)}")
        for hole in self.holes:
            if not (hole.radius < self.radius and hole.top < self.height):
                raise ValueError(f"the sphere hole {hole} does not fit in the half-plane {self.radius} x {self.height}")
        for lower, upper in zip(self.holes, self.holes[1:]):
            if not upper.gap > lower.top:
                raise ValueError(f"the sphere holes {lower} and {upper} overlap or are not listed lowest first")

    def key(self) -> str:
        """A short hash of everything that shapes the mesh (the cache file name)."""
        data = dataclasses.asdict(self) | {"format": MESH_FORMAT_VERSION, "gmsh": gmsh_version()}
        for hole in data["holes"]:  # the meshes of holes keep the keys they had before `filled`
            if not hole["filled"]:
                del hole["filled"]
        text = json.dumps(data, sort_keys=True, default=lambda x: round(x, 15))
        return hashlib.sha1(text.encode()).hexdigest()[:16]

    def size_at(self, r: np.ndarray, z: np.ndarray) -> np.ndarray:
        """The target triangle size at (r, z) [m]: the same law as the gmsh field."""
        r, z = np.asarray(r, float), np.asarray(z, float)
        size = np.full(np.broadcast(r, z).shape, self.coarse_size)
        for box in self.refined:
            inside = self.fine_size if box.size is None else box.size
            size = np.minimum(size, inside + self.grading * box.distance(r, z))
        for below, hole in zip((None,) + self.holes, self.holes):
            size = np.minimum(size, hole.size_at(r, z, self.grading, below))
        return size

    def estimated_cells(self, samples: int = 400) -> float:
        """About how many triangles gmsh makes of this half-plane: the integral of 1 / (sqrt(3)/4 size^2), an
        equilateral triangle per size^2 sqrt(3)/4, over r and z on grids that are uniform and log-spaced from the
        fine size (so both a large container and the fine region near the axis and the wall are seen)."""
        def nodes(length: float) -> np.ndarray:
            return np.unique(np.r_[np.linspace(0.0, length, samples),
                                   np.geomspace(min(self.fine_size, length) / 4.0, length, samples)])

        r, z = nodes(self.radius), nodes(self.height)
        rc, zc = 0.5 * (r[1:] + r[:-1]), 0.5 * (z[1:] + z[:-1])
        size = self.size_at(rc[:, None], zc[None, :])
        return float(np.sum(np.diff(r)[:, None] * np.diff(z)[None, :] / (math.sqrt(3.0) / 4.0 * size**2)))

    def _gmsh_size_expression(self) -> str:
        terms = [f"{self.coarse_size!r}"]
        for box in self.refined:
            dr = f"max(x - {box.r_max!r}, 0)"
            dz = f"max(max(y - {box.z_max!r}, {box.z_min!r} - y), 0)"
            inside = self.fine_size if box.size is None else box.size
            terms.append(f"{inside!r} + {self.grading!r} * sqrt({dr}^2 + {dz}^2)")
        for below, hole in zip((None,) + self.holes, self.holes):
            terms.append(hole.gmsh_size(self.grading, below))
        expression = terms[0]
        for term in terms[1:]:
            expression = f"min({expression}, {term})"
        return expression


def cache_directory() -> Path:
    """The generated meshes' folder in fem_bounce's cache (fem_bounce.cachedir: $FEM_BOUNCE_CACHE/meshes)."""
    return cachedir.folder("meshes")


def _build_model(gmsh, spec: HalfPlane) -> None:
    """Geometry, physical groups and size field of the half-plane in the current gmsh model."""
    geo = gmsh.model.geo
    corners = [(0.0, 0.0), (spec.radius, 0.0), (spec.radius, spec.height), (0.0, spec.height)]
    points = [geo.addPoint(r, z, 0.0) for r, z in corners]
    wall, outer, top = (geo.addLine(points[k], points[k + 1]) for k in range(3))
    curves = {WALL: [wall], OUTER: [outer], TOP: [top]}
    insides = []  # the surfaces inside filled spheres
    if not spec.holes:
        curves[AXIS] = [geo.addLine(points[3], points[0])]
        loop = [wall, outer, top, *curves[AXIS]]
    else:
        # down the axis from the top, around each sphere's right half (two quarter arcs from its north to
        # its south pole), down to the next sphere or the wall; the entities are created in the order a
        # single hole always had (its points, the axis lines, the arcs), so its meshes stay the same
        poles = []
        for hole in spec.holes[::-1]:
            a, zc = hole.radius, hole.center
            poles.append([geo.addPoint(r, z, 0.0) for r, z in ((0.0, zc + a), (0.0, zc), (a, zc), (0.0, zc - a))])
        stops = [points[3]] + [p for north, _, _, south in poles for p in (north, south)] + [points[0]]
        curves[AXIS] = [geo.addLine(stops[2 * k], stops[2 * k + 1]) for k in range(len(poles) + 1)]
        loop = [wall, outer, top, curves[AXIS][0]]
        for k, ((north, center, equator, south), axis) in enumerate(zip(poles, curves[AXIS][1:])):
            arcs = [geo.addCircleArc(north, center, equator), geo.addCircleArc(equator, center, south)]
            curves[SPHERE_TAGS[len(poles) - 1 - k]] = arcs
            loop += [*arcs, axis]
            if spec.holes[len(poles) - 1 - k].filled:  # the inside: the arcs back up, the axis down
                diameter = geo.addLine(south, north)
                curves[AXIS].append(diameter)
                insides.append(geo.addPlaneSurface([geo.addCurveLoop([diameter, *arcs])]))
    surface = geo.addPlaneSurface([geo.addCurveLoop(loop)])
    geo.synchronize()
    for tag, group in curves.items():
        gmsh.model.addPhysicalGroup(1, group, tag)
        gmsh.model.setPhysicalName(1, tag, BOUNDARY_NAMES[tag])
    gmsh.model.addPhysicalGroup(2, [surface], FLUID)
    gmsh.model.setPhysicalName(2, FLUID, "fluid")
    if insides:
        gmsh.model.addPhysicalGroup(2, insides, SOLID)
        gmsh.model.setPhysicalName(2, SOLID, "solid")
    size_everywhere(gmsh, spec._gmsh_size_expression())
    gmsh.option.setNumber("Mesh.Algorithm", 6)  # Frontal-Delaunay: well-shaped triangles
    gmsh.model.mesh.generate(2)


def size_everywhere(gmsh, expression: str) -> None:
    """The size of gmsh's next mesh at every point from `expression` (a MathEval formula of x, y, z) and from
    nothing else (the boundary, the points and the curvature give none)."""
    field = gmsh.model.mesh.field.add("MathEval")
    gmsh.model.mesh.field.setString(field, "F", expression)
    gmsh.model.mesh.field.setAsBackgroundMesh(field)
    for option in ("Mesh.MeshSizeExtendFromBoundary", "Mesh.MeshSizeFromPoints", "Mesh.MeshSizeFromCurvature"):
        gmsh.option.setNumber(option, 0)


def gmsh_version() -> str:
    """The gmsh library's version (part of a mesh's cache key), read without loading the library."""
    try:
        return importlib.metadata.version("gmsh")
    except importlib.metadata.PackageNotFoundError:  # a gmsh installed without Python metadata
        import gmsh

        return gmsh.__version__


def create_mesh(comm, spec: HalfPlane, cache: bool = True):
    """(mesh, cell_tags, facet_tags) of the half-plane, distributed over comm.

    Rank 0 reads the cached .msh file, or meshes it (`_generate`: a large mesh in a child process, which a signal
    can stop) and caches it; every rank takes part in the distribution.  A cache entry is written atomically (beside its
    place, fsynced, renamed) with the hash of its content beside it, and checked against that hash when read: a
    damaged or half-written entry is made again, never read.  The process's SIGINT and SIGTERM handlers are
    left as they were found (gmsh.initialize puts the default SIGTERM handler back at the C level, and its
    Python API the default SIGINT one, and neither restores them: _generate puts them back), so a signal still
    ends a run with its summary."""
    import gmsh
    from dolfinx.io import gmsh as gmsh_io

    handlers = _Handlers()
    path = cache_directory() / f"halfplane-{spec.key()}.msh" if comm.rank == 0 else None
    scratch = Path(tempfile.mkdtemp()) if comm.rank == 0 and not cache else None
    try:
        if not cache:
            path = scratch / f"halfplane-{spec.key()}.msh" if comm.rank == 0 else None
            on_root_watching(comm, lambda: _generate(spec, path))
        elif comm.rank == 0 and not _verified(path):
            _remove_stale_partials(path.parent)
            on_root_watching(comm, lambda: _cache(spec, path))
        else:
            on_root_watching(comm, lambda: None)
        if comm.rank == 0:
            gmsh.initialize(interruptible=False)
            handlers.restore()
            gmsh.option.setNumber("General.Terminal", 0)
            try:
                # always read the file back: a fresh and a cached mesh are then identical to the last bit
                gmsh.merge(str(path))
                result = gmsh_io.model_to_mesh(gmsh.model, comm, 0, gdim=2)
            finally:
                gmsh.finalize()
                handlers.restore()
        else:
            result = gmsh_io.model_to_mesh(None, comm, 0, gdim=2)
    finally:
        if scratch is not None:
            shutil.rmtree(scratch, ignore_errors=True)
    return result.mesh, result.cell_tags, result.facet_tags


class _Handlers:
    """The process's SIGINT and SIGTERM handlers as Python set them (the main thread only), to put back."""

    def __init__(self):
        main = threading.current_thread() is threading.main_thread()
        self.saved = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)} if main else {}

    def restore(self) -> None:
        for signum, handler in self.saved.items():
            if handler is not None:  # None: not set from Python, nothing to put back
                signal.signal(signum, handler)


# The largest mesh a model may ask for: about 4.5 unknowns a triangle (Taylor-Hood P2-P1, two velocity components),
# so 1e6 triangles are ~4.5e6 unknowns, whose sparse LU factors (MUMPS) take of the order of 10 GB; a container of
# 100 m around a 9.5 mm sphere would need 2.6e8 (HalfPlane.estimated_cells).
MAX_CELLS = 1e6
# Below this many triangles gmsh meshes in about a second or less (the default ale mesh of case 3, ~6,000
# triangles, in 0.1 s): made in the process, as a signal waits no longer than that.
IN_PROCESS_CELLS = 5e4


def check_size(spec: HalfPlane, setting: str) -> None:
    """Refuse, before anything is written, a half-plane whose mesh would pass MAX_CELLS (`setting`: the model's
    numerics table, named in the message)."""
    cells = spec.estimated_cells()
    if cells > MAX_CELLS:
        raise SceneError(f"{setting}: its mesh of this scene would have ~{cells:.2g} triangles (the half-plane "
                         f"{spec.radius:.4g} m x {spec.height:.4g} m, at {spec.fine_size:.3g} m near the spheres "
                         f"growing to {spec.coarse_size:.3g} m): allowed up to {MAX_CELLS:.0e} (~4.5 unknowns each; "
                         f"their factors need ~10 GB); make the container smaller (or {setting}.far_field, without "
                         f"one), lower {setting}.cells_per_diameter, or use the ode model")


POLL_SECONDS = 0.1  # how often a wait for gmsh looks for a signal (progress.stop_requested)
# what MPI's launchers tell the processes they start: a child of a rank must not take it for itself
_MPI_ENVIRONMENT = ("PMI_", "PMIX_", "MPI_LOCAL", "HYDRA_", "OMPI_")


def _verified(path: Path) -> bool:
    """A cached mesh file that is whole: its hash is the one written beside it when it was made."""
    try:
        return file_digest(path) == _hash_file(path).read_text().strip()
    except OSError:
        return False


def _hash_file(path: Path) -> Path:
    return path.with_name(path.name + ".sha256")


_PARTIAL = re.compile(r"\.(\d+)\.partial\.msh(\.sha256)?")  # _cache's files being made, by the maker's process id


def _remove_stale_partials(folder: Path) -> None:
    """Remove the half-made files (_cache) that a run killed outright left in the mesh cache: those whose maker's
    process is gone, never a live one's (another run meshing the same spec now)."""
    for partial in folder.glob(".*.partial.msh*"):
        found = _PARTIAL.search(partial.name)
        if found is None:
            continue
        try:
            os.kill(int(found[1]), 0)
        except ProcessLookupError:
            partial.unlink(missing_ok=True)
        except OSError:  # alive (another user's process), or the id is out of range: leave it
            continue


def _cache(spec: HalfPlane, path: Path) -> None:
    """Mesh `spec` into the cache entry `path`: the file beside its place, checked and fsynced, renamed over it,
    then its hash (written the same way).  A half-made entry has no matching hash and is made again."""
    partial = path.with_name(f".{path.stem}.{os.getpid()}.partial{path.suffix}")  # gmsh reads the format from it
    try:
        _generate(spec, partial)
        sync_file(partial)
        _hash_file(path).unlink(missing_ok=True)
        partial.replace(path)
        hashed = partial.with_name(partial.name + ".sha256")
        hashed.write_text(file_digest(path) + "\n")
        sync_file(hashed)
        hashed.replace(_hash_file(path))
    except OSError as err:
        raise OutputError(f"cannot write the mesh cache {path}: {err.strerror or err} (set {cachedir.VARIABLE} to a "
                          "folder with room)") from None
    finally:
        partial.unlink(missing_ok=True)


def _generate(spec: HalfPlane, target: Path) -> None:
    """Mesh `spec` into the .msh file `target`, read it back and compare it with what was meshed; OutputError
    naming the file when it could not be written.  A small mesh (below IN_PROCESS_CELLS triangles, every model's
    default and most studies') is made here, the signal handlers put back after gmsh; a larger one in a child
    process (_child) watched for a signal: gmsh's meshing is one long call that no signal reaches, but a child
    can be stopped (starting it costs ~0.3 s)."""
    if spec.estimated_cells() < IN_PROCESS_CELLS:
        handlers = _Handlers()
        try:
            _mesh_into(spec, target)
        except Exception as err:  # noqa: BLE001 -- gmsh raises plain Exception
            raise OutputError(f"cannot mesh into {target}: {type(err).__name__}: {err}") from None
        finally:
            handlers.restore()
        return
    environment = {k: v for k, v in os.environ.items() if not k.startswith(_MPI_ENVIRONMENT)}
    environment["MPI4PY_RC_INITIALIZE"] = "0"  # the package imports mpi4py.MPI; the child needs no MPI
    package = Path(__file__).resolve().parents[2]
    # Linux: the kernel kills the child when this process dies, however it dies (SIGKILL included), asked for
    # first thing, before the imports (~1 s), and the child ends at once if this process died before it asked
    code = ("import ctypes, os, signal, sys\n"
            "if sys.platform.startswith('linux'):\n"
            "    ctypes.CDLL(None).prctl(1, int(signal.SIGKILL))  # PR_SET_PDEATHSIG\n"
            f"if os.getppid() != {os.getpid()}:\n"
            "    sys.exit('the run that started this mesher has ended')\n"
            f"sys.path.insert(0, {str(package)!r})\n"
            "from fem_bounce.fem.mesh import _child\n"
            "_child()")
    child = subprocess.Popen([sys.executable, "-c", code, str(target)], stdin=subprocess.PIPE,
                             stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=environment)
    try:
        data = pickle.dumps(spec)
        while True:
            try:
                _, err = child.communicate(data, timeout=POLL_SECONDS)
                break
            except subprocess.TimeoutExpired:
                data = None  # sent
                stop_requested()
    finally:
        if child.poll() is None:  # a signal, or an exception while waiting: the child goes too
            child.kill()
            child.wait()
    if child.returncode:
        lines = err.decode(errors="replace").strip().splitlines() or [f"exit status {child.returncode}"]
        raise OutputError(f"cannot mesh into {target}: {lines[-1]}")


def _child() -> None:
    """The child process of _generate: the spec (pickled) on stdin, the target file as its argument."""
    spec, target = pickle.load(sys.stdin.buffer), sys.argv[1]
    try:
        _mesh_into(spec, target)
    except Exception as err:  # noqa: BLE001 -- gmsh raises plain Exception: one line for the parent
        sys.exit(f"{type(err).__name__}: {err}")


def _mesh_into(spec: HalfPlane, target) -> None:
    """gmsh meshes `spec` into the file `target`, reads it back and checks it holds what it meshed."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("halfplane")
        _build_model(gmsh, spec)
        made = _counts(gmsh)
        gmsh.write(str(target))
        gmsh.clear()
        try:
            gmsh.merge(str(target))
        except Exception as err:  # noqa: BLE001 -- gmsh raises plain Exception
            raise OSError(f"reading it back failed ({err}): is the disk full?") from None
        if _counts(gmsh) != made:
            raise OSError(f"it holds {_counts(gmsh)} boundary segments and triangles of the {made} meshed (is the disk "
                          "full?)")
    finally:
        gmsh.finalize()


def _counts(gmsh) -> tuple[int, int]:
    """(boundary segments, triangles) of the current gmsh model's mesh (the nodes are not compared: the arcs'
    centres are the geometry's, not written)."""
    return tuple(sum(len(tags) for tags in gmsh.model.mesh.getElements(dim)[1]) for dim in (1, 2))
