#!/usr/bin/env python3
"""The point coordinates of a run's XDMF files, as a reader of XDMF 3 computes them (used by
XdmfGeometryMatchesSheets, tests/test_watch_coupled.cpp).

    /usr/bin/python3 tests/xdmf_geometry.py OUTPUT_DIR

Reads every OUTPUT_DIR/*.xmf with the standard library's XML parser and h5py: for each
file's first grid, the coordinates of its points from its Topology and Geometry, as the
XDMF model defines them (3DCoRectMesh + ORIGIN_DXDYDZ: origin and spacing listed slowest
axis first, z y x, like the Dimensions; Unstructured + XYZ: the HDF5 dataset the DataItem
names). Prints one JSON object: per file, the bounds (x, y, z) of its points, its point
counts per axis where structured, and for a plane snapshot the y_um attribute of its HDF5
file. Debian 12's VTK 9.1 (python3-vtk9) has no XDMF reader module (vtkIOXdmf2/3 are not
built) and its python3-xdmf does not import, hence this reader.
"""
import glob
import json
import os
import sys
import xml.etree.ElementTree as ET

import h5py
import numpy as np


def numbers(text):
    return [float(v) for v in text.split()]


def hdf_data(item, folder):
    path, name = item.text.strip().split(":", 1)
    with h5py.File(os.path.join(folder, path), "r") as f:
        return np.asarray(f[name]), dict(f.attrs)


def grid_points(grid, folder):
    topo, geom = grid.find("Topology"), grid.find("Geometry")
    kind = geom.get("GeometryType") or geom.get("Type")
    out = {}
    if kind == "ORIGIN_DXDYDZ":
        dims = [int(v) for v in topo.get("Dimensions").split()]  # nz ny nx
        origin, spacing = (numbers(d.text) for d in geom.findall("DataItem"))
        nz, ny, nx = dims
        oz, oy, ox = origin
        sz, sy, sx = spacing
        x = ox + sx * np.arange(nx)
        y = oy + sy * np.arange(ny)
        z = oz + sz * np.arange(nz)
        out.update(nx=nx, ny=ny, nz=nz, spacing=[sx, sy, sz],
                   bounds=[[x.min(), x.max()], [y.min(), y.max()], [z.min(), z.max()]])
        attr = grid.find("Attribute/DataItem")
        if attr is not None:
            _, attrs = hdf_data(attr, folder)
            if "y_um" in attrs:
                out["y_um_attribute"] = float(np.asarray(attrs["y_um"]))
    elif kind == "XYZ":
        pts, _ = hdf_data(geom.find("DataItem"), folder)
        pts = pts.reshape(-1, 3)
        out.update(points=len(pts), bounds=[[pts[:, a].min(), pts[:, a].max()] for a in range(3)])
    else:
        raise SystemExit(f"xdmf_geometry: {kind}: a geometry type this reader does not know")
    return out


def main(argv):
    if len(argv) != 2 or argv[1] in ("--help", "-h"):
        print(__doc__.strip())
        return 0 if len(argv) == 2 else 2
    folder = argv[1]
    result = {}
    for path in sorted(glob.glob(os.path.join(folder, "*.xmf"))):
        root = ET.parse(path).getroot()
        grids = [g for g in root.iter("Grid") if g.get("GridType", "Uniform") == "Uniform"]
        if not grids:
            continue
        result[os.path.basename(path)] = dict(grid_points(grids[0], folder), time=float(grids[0].find("Time").get("Value")))
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
