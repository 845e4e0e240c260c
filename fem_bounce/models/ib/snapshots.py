"""Flow-field snapshots: XDMF + HDF5 in the run directory (read back by fem_bounce.fields.read_snapshots).

    DIR/fields.xdmf, DIR/fields.h5     velocity (r, z components) [m/s], pressure [Pa],
                                       azimuthal vorticity du/dz - dw/dr [1/s]

Fields live at the grid nodes (R_i, Z_j), the points are (r, z) and each grid cell
is split into two triangles, so any triangle-mesh plotting tool reads them; the
XDMF layout is meshio's (ParaView opens it).  Written with h5py directly: meshio
5.0's TimeSeriesWriter puts the .h5 file in the current directory.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

FIELDS_FILE = "fields.xdmf"


def node_mesh(r_nodes: np.ndarray, z_nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Points (row-major over r then z, matching arrays of shape (nr+1, nz+1)) and split quads."""
    rr, zz = np.meshgrid(r_nodes, z_nodes, indexing="ij")
    points = np.column_stack([rr.ravel(), zz.ravel()])
    nz1 = len(z_nodes)
    index = np.arange(points.shape[0]).reshape(len(r_nodes), nz1)
    a, b = index[:-1, :-1].ravel(), index[1:, :-1].ravel()
    c, d = index[1:, 1:].ravel(), index[:-1, 1:].ravel()
    triangles = np.concatenate([np.column_stack([a, b, c]), np.column_stack([a, c, d])])
    return points, triangles


XINCLUDE = "http://www.w3.org/2001/XInclude"


class SnapshotWriter:
    """Writes one time series (rank 0 only).  The XDMF file is rewritten after every
    snapshot, so a run that is killed still leaves a readable series."""

    def __init__(self, run_dir: Path, r_nodes: np.ndarray, z_nodes: np.ndarray, continue_until: float | None = None):
        """`continue_until`: a restart from time t [s] keeps the series' snapshots up to t and appends."""
        import h5py

        self.run_dir = Path(run_dir)
        self.points, self.triangles = node_mesh(r_nodes, z_nodes)
        self.times: list[float] = []
        h5_path = self.run_dir / FIELDS_FILE.replace(".xdmf", ".h5")
        if continue_until is not None and (self.run_dir / FIELDS_FILE).is_file() and h5_path.is_file():
            from ...fields import read_snapshots

            kept = [s.time for s in read_snapshots(self.run_dir) if s.time <= continue_until * (1.0 + 1e-12)]
            self._h5 = h5py.File(h5_path, "a")
            for name in [n for n in self._h5 if n.startswith("step") and int(n[4:]) >= len(kept)]:
                del self._h5[name]  # written after the checkpoint: the restart writes them again
            self.times = kept
            return
        self._h5 = h5py.File(h5_path, "w")
        self._h5.create_dataset("geometry", data=self.points)
        self._h5.create_dataset("topology", data=self.triangles)

    @property
    def count(self) -> int:
        return len(self.times)

    def write(self, time: float, velocity_r: np.ndarray, velocity_z: np.ndarray, pressure: np.ndarray,
              vorticity: np.ndarray) -> None:
        """Nodal arrays of shape (nr+1, nz+1): velocity [m/s], pressure [Pa], vorticity [1/s]."""
        k = self.count
        group = self._h5.create_group(f"step{k}")
        group.create_dataset("velocity", data=np.column_stack([velocity_r.ravel(), velocity_z.ravel()]))
        group.create_dataset("pressure", data=pressure.ravel())
        group.create_dataset("vorticity", data=vorticity.ravel())
        self._h5.flush()
        self.times.append(float(time))
        self._write_xdmf()

    def _write_xdmf(self) -> None:
        import xml.etree.ElementTree as ET

        h5 = FIELDS_FILE.replace(".xdmf", ".h5")
        n, m = self.points.shape[0], self.triangles.shape[0]
        root = ET.Element("Xdmf", Version="3.0")
        root.set("xmlns:xi", XINCLUDE)
        domain = ET.SubElement(root, "Domain")
        mesh = ET.SubElement(domain, "Grid", Name="mesh", GridType="Uniform")
        topology = ET.SubElement(mesh, "Topology", TopologyType="Triangle", NumberOfElements=str(m))
        ET.SubElement(topology, "DataItem", Dimensions=f"{m} 3", NumberType="Int", Precision="8",
                      Format="HDF").text = f"{h5}:/topology"
        geometry = ET.SubElement(mesh, "Geometry", GeometryType="XY")
        ET.SubElement(geometry, "DataItem", Dimensions=f"{n} 2", NumberType="Float", Precision="8",
                      Format="HDF").text = f"{h5}:/geometry"
        series = ET.SubElement(domain, "Grid", Name="fields", GridType="Collection", CollectionType="Temporal")
        for k, time in enumerate(self.times):
            step = ET.SubElement(series, "Grid", Name=f"step{k}", GridType="Uniform")
            ET.SubElement(step, "xi:include",
                          xpointer='xpointer(//Grid[@Name="mesh"]/*[self::Topology or self::Geometry])')
            ET.SubElement(step, "Time", Value=repr(time))
            for name, kind, dims in (("velocity", "Vector", f"{n} 2"), ("pressure", "Scalar", str(n)),
                                     ("vorticity", "Scalar", str(n))):
                attribute = ET.SubElement(step, "Attribute", Name=name, AttributeType=kind, Center="Node")
                ET.SubElement(attribute, "DataItem", Dimensions=dims, NumberType="Float", Precision="8",
                              Format="HDF").text = f"{h5}:/step{k}/{name}"
        tmp = self.run_dir / (FIELDS_FILE + ".tmp")
        ET.ElementTree(root).write(tmp, xml_declaration=True, encoding="utf-8")
        tmp.replace(self.run_dir / FIELDS_FILE)

    def close(self) -> None:
        if self._h5 is not None:
            self._h5.close()
            self._h5 = None
