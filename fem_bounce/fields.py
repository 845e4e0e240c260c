"""Flow-field snapshots a run wrote, and the paper's Fig. 11 drawn from them: the fd and ale models write
DIR/fields-KKK.xdmf + .h5 (dolfinx's writer, one segment per restart), the ib model DIR/fields.xdmf + .h5.

    snapshots = read_snapshots("runs/li2011-case7-fd")
    snapshots[0].time, snapshots[0].points (N, 2) in (r, z) [m], snapshots[0].triangles (M, 3),
    snapshots[0].fields["velocity"] (N, 2), ["pressure"] (N,), ["vorticity"] (N,)   [SI]
    vorticity_figure("runs/li2011-case7-fd")       # -> DIR/vorticity.png

The fd3d model's files (tetrahedra of the half box y >= 0) are read in its symmetry plane y = 0, the plane of
incidence: points (N, 2) in (x, z) where the mesh was at that instant (a moving mesh's mesh_displacement added),
triangles the mesh's faces on that plane, fields["velocity"] (N, 2) = (u_x, u_z), ["pressure"], ["vorticity_y"].

Files only: nothing here needs dolfinx, so figures can be redrawn anywhere with
h5py and matplotlib.  Segments written by restarts (fields-001, ...) continue the
series; where a later segment starts, the earlier one's later snapshots are dropped.
"""
from __future__ import annotations

import re
import sys
import xml.etree.ElementTree as ElementTree
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

# dolfinx 0.5 wrote the XInclude namespace with http, 0.10 and later with https
XINCLUDE_NAMESPACES = ("https://www.w3.org/2001/XInclude", "http://www.w3.org/2001/XInclude")


@dataclass
class Snapshot:
    time: float  # [s]
    points: np.ndarray  # (N, 2): r, z [m]
    triangles: np.ndarray  # (M, 3) indices into points
    fields: dict = field(default_factory=dict)  # name -> (N,) or (N, 2) nodal values [SI]


def _data_item(folder: Path, item) -> np.ndarray:
    import h5py

    file_name, dataset = item.text.strip().split(":", 1)
    with h5py.File(folder / file_name, "r") as h5:
        return np.asarray(h5[dataset])


def _read_segment(path: Path) -> list[Snapshot]:
    folder = path.parent
    domain = ElementTree.parse(path).getroot().find("Domain")
    topology = domain.find("Grid/Topology")
    if topology is not None and topology.get("TopologyType") == "Tetrahedron":
        return _read_plane_segment(path, domain)
    grids = domain.findall("Grid")
    meshes = {g.get("Name"): g for g in grids if g.get("GridType") == "Uniform"}
    read: dict[str, tuple] = {}

    def mesh_of(grid) -> tuple[np.ndarray, np.ndarray]:
        """(points, triangles) of the mesh a time grid refers to: a moving mesh (ale) writes one per
        snapshot and names it in the xpointer; otherwise the file's first mesh."""
        name = next(iter(meshes))
        include = next((found for namespace in XINCLUDE_NAMESPACES
                        if (found := grid.find(f"{{{namespace}}}include")) is not None), None)
        if include is not None:
            match = re.search(r"@Name='([^']+)'", include.get("xpointer", ""))
            if match and match.group(1) in meshes:
                name = match.group(1)
        if name not in read:
            mesh = meshes[name]
            read[name] = (_data_item(folder, mesh.find("Geometry/DataItem"))[:, :2],
                          _data_item(folder, mesh.find("Topology/DataItem")).astype(np.int64))
        return read[name]

    by_time: dict[float, Snapshot] = {}
    for series in (g for g in grids if g.get("GridType") == "Collection"):
        for grid in series.findall("Grid"):
            t = float(grid.find("Time").get("Value"))
            snapshot = by_time.setdefault(t, Snapshot(t, *mesh_of(grid)))
            for attribute in grid.findall("Attribute"):  # dolfinx writes one per grid, the ib model three
                values = _data_item(folder, attribute.find("DataItem"))
                name = attribute.get("Name")
                if name == "velocity":
                    values = values[:, :2]
                elif values.ndim == 2:
                    values = values[:, 0]
                snapshot.fields[name] = values
    return [by_time[t] for t in sorted(by_time)]


def _read_plane_segment(path: Path, domain) -> list[Snapshot]:
    """A 3-D segment (one mesh of tetrahedra, as fd3d writes it) in its plane y = 0."""
    folder = path.parent
    grids = domain.findall("Grid")
    mesh = next(g for g in grids if g.get("GridType") == "Uniform")
    x = _data_item(folder, mesh.find("Geometry/DataItem"))
    tetrahedra = _data_item(folder, mesh.find("Topology/DataItem")).astype(np.int64)
    on = np.abs(x[:, 1]) <= 1e-9 * np.ptp(x, axis=0).max()
    faces = np.concatenate([np.delete(tetrahedra, k, axis=1) for k in range(4)])
    faces = faces[on[faces].all(axis=1)]  # on the boundary plane: each belongs to one tetrahedron
    kept = np.flatnonzero(on)
    number = np.full(len(x), -1, dtype=np.int64)
    number[kept] = np.arange(len(kept))
    found: dict[float, dict] = {}
    for series in (g for g in grids if g.get("GridType") == "Collection"):
        for grid in series.findall("Grid"):
            attribute = grid.find("Attribute")
            values = _data_item(folder, attribute.find("DataItem"))[kept]
            found.setdefault(float(grid.find("Time").get("Value")), {})[attribute.get("Name")] = (
                values[:, [0, 2]] if values.shape[-1] == 3 else values.reshape(len(kept), -1)[:, 0])
    snapshots = []
    for t in sorted(found):
        points = x[kept][:, [0, 2]] + found[t].get("mesh_displacement", 0.0)
        snapshots.append(Snapshot(t, points, number[faces], found[t]))
    return snapshots


def read_snapshots(run_dir: Path) -> list[Snapshot]:
    """Every snapshot of a run, in time order, restart segments merged (a 3-D run's in its plane y = 0)."""
    segments = sorted(Path(run_dir).glob("fields-*.xdmf")) or sorted(Path(run_dir).glob("fields.xdmf"))
    if not segments:
        raise FileNotFoundError(f"{run_dir} has no fields-*.xdmf or fields.xdmf (run with "
                                "numerics.<model>.output_every > 0)")
    snapshots: list[Snapshot] = []
    for path in segments:
        later = _read_segment(path)
        if later:
            snapshots = [s for s in snapshots if s.time < later[0].time * (1 - 1e-12)]
        snapshots += later
    return snapshots


def default_times(summary: dict) -> list[float]:
    """Five instants like the paper's Fig. 11: before the first impact, rebounding, at the apex,
    falling again, before the second impact (fewer when the run has fewer events)."""
    impacts, rebounds = summary["impacts"], summary["rebounds"]
    if not impacts:
        end = summary["final"]["time"]
        return list(np.linspace(0.2, 1.0, 5) * end)
    first = impacts[0]["time"]
    times = [first - 1e-3]
    if rebounds and rebounds[0]["apex_time"] is not None:
        apex = rebounds[0]["apex_time"]
        times += [first + (apex - first) / 3.0, apex]
        if len(impacts) > 1:
            second = impacts[1]["time"]
            times += [apex + (second - apex) / 2.0, second - 1e-3]
    return times


def vorticity_figure(run_dir: Path, times: list[float] | None = None, path: Path | None = None,
                     extent: tuple[float, float] = (2.5, 4.0), dpi: int = 130) -> Path:
    """(a) the trajectory with the snapshot instants, (b) vorticity contours omega sqrt(D/g) from -0.5 to
    0.5 every 0.05 (as the paper's Fig. 11) near the axis, the sphere drawn black; extent = (r, z) in D.
    A 3-D run (fd3d): omega_y in the plane y = 0 over -extent[0] < x/D < extent[0], the sphere's outline where the
    flow has it (no lower than the contact's hold gap, flow_model.flow_gaps) and dashed where it is when lower."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Circle, Wedge
    from matplotlib.tri import Triangulation

    from . import output, plots

    run_dir = Path(run_dir)
    summary, trajectory = output.read_summary(run_dir), output.read_trajectory(run_dir)
    diameter, t_unit, _ = plots.units(summary["scene"])
    snapshots = read_snapshots(run_dir)
    available = np.array([s.time for s in snapshots])
    chosen = [snapshots[int(np.argmin(np.abs(available - t)))] for t in (times or default_times(summary))]
    plane = "vorticity_y" in chosen[0].fields  # a 3-D run's plane of incidence, both sides of the axis
    left = -extent[0] if plane else 0.0
    hold = 0.0
    if plane:
        from .contact import ContactModel
        from .scene import from_dict

        hold = ContactModel(from_dict(summary["scene"])).hold_gap
    width = (extent[0] - left) / 2.5  # a panel's width, the axisymmetric default's 1
    fig = plt.figure(figsize=(3.0 + 2.4 * width * len(chosen), 4.2))
    grid = fig.add_gridspec(1, len(chosen) + 1, width_ratios=[1.4] + [width] * len(chosen))
    ax = fig.add_subplot(grid[0])
    ax.plot(trajectory["t"] / t_unit, trajectory["gap"] / diameter, lw=1.0, color="k")
    for k, snap in enumerate(chosen, 1):
        gap = np.interp(snap.time, trajectory["t"], trajectory["gap"])
        ax.plot(snap.time / t_unit, gap / diameter, "o", color="C3", ms=4)
        ax.annotate(str(k), (snap.time / t_unit, gap / diameter), textcoords="offset points", xytext=(3, 4))
    ax.set_xlabel(r"$t/\sqrt{D/g}$")
    ax.set_ylabel(r"$h/D$")
    ax.set_title("(a) trajectory", fontsize=9)
    levels = np.arange(-0.5, 0.5001, 0.05)
    radius = 0.5 * diameter
    for k, snap in enumerate(chosen, 1):
        ax = fig.add_subplot(grid[k])
        tri = Triangulation(snap.points[:, 0] / diameter, snap.points[:, 1] / diameter, snap.triangles)
        omega = np.clip(snap.fields["vorticity_y" if plane else "vorticity"] * t_unit, levels[0], levels[-1])
        ax.tricontourf(tri, omega, levels=levels, cmap="RdBu_r", extend="both")
        ax.tricontour(tri, omega, levels=levels[levels != 0.0], colors="k", linewidths=0.3)
        gap = np.interp(snap.time, trajectory["t"], trajectory["gap"])
        center = (gap + radius) / diameter
        if plane:
            ax.add_patch(Circle((0.0, (max(gap, hold) + radius) / diameter), 0.5, fill=False, lw=1.0, color="k"))
            if gap < hold:
                ax.add_patch(Circle((0.0, center), 0.5, fill=False, lw=0.8, ls="--", color="k"))
        else:
            ax.add_patch(Wedge((0.0, center), 0.5, -90, 90, color="k"))
        ax.axhline(0.0, color="k", lw=2)
        ax.set_xlim(left, extent[0])
        ax.set_ylim(0.0, extent[1])
        ax.set_aspect("equal")
        ax.set_title(f"({k}) t = {snap.time / t_unit:.2f}", fontsize=9)
        ax.set_xlabel("x/D" if plane else "r/D")
        if k == 1:
            ax.set_ylabel("z/D")
    fig.suptitle(f"{summary['scene']['name']}: vorticity $\\omega{'_y' if plane else ''}\\sqrt{{D/g}}$"
                 f"{' in the plane y = 0' if plane else ''}, levels -0.5:0.05:0.5 "
                 f"({summary['model']} model)", fontsize=10)
    fig.tight_layout()
    out = Path(path) if path else run_dir / "vorticity.png"
    fig.savefig(out, dpi=dpi)
    plt.close(fig)
    return out


if __name__ == "__main__":
    for folder in sys.argv[1:]:
        print(vorticity_figure(Path(folder)))
