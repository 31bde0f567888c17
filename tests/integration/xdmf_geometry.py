#!/usr/bin/env python3
"""The point coordinates of a run's XDMF files, as VTK's XDMF reader computes them (used by
XdmfGeometryMatchesSheets, tests/integration/test_watch_run.cpp).

    /usr/bin/python3 tests/integration/xdmf_geometry.py OUTPUT_DIR

Opens every OUTPUT_DIR/*.xmf with vtkXdmfReader (the reader ParaView uses; Debian 12 ships
it in python3-paraview's vtkmodules, python3-vtk9's VTK 9.1 is built without it) at the
file's first time: per file, the bounds (x, y, z) of its points, its point counts per axis
and spacing where the grid is structured, its number of points otherwise, the time, and for
a plane snapshot the y_um attribute of its HDF5 file (read with h5py). Prints one JSON object.
"""
import glob
import json
import os
import sys
import xml.etree.ElementTree as ET

import h5py
import numpy as np


def vtk_datasets(obj):
    """The datasets of a VTK data object, a composite one walked through."""
    if obj is None:
        return []
    if hasattr(obj, "NewIterator") and not hasattr(obj, "GetNumberOfPoints"):
        out, it = [], obj.NewIterator()
        it.InitTraversal()
        while not it.IsDoneWithTraversal():
            out.append(it.GetCurrentDataObject())
            it.GoToNextItem()
        return out
    return [obj]


def read_with_vtk(path):
    from vtkmodules.vtkCommonExecutionModel import vtkStreamingDemandDrivenPipeline
    from vtkmodules.vtkIOXdmf2 import vtkXdmfReader

    r = vtkXdmfReader()
    r.SetFileName(path)
    r.UpdateInformation()
    info = r.GetOutputInformation(0)
    key = vtkStreamingDemandDrivenPipeline.TIME_STEPS()
    times = [info.Get(key, k) for k in range(info.Length(key))] if info.Has(key) else [0.0]
    r.UpdateTimeStep(times[0])
    sets = [d for d in vtk_datasets(r.GetOutputDataObject(0)) if d is not None and d.GetNumberOfPoints() > 0]
    if len(sets) != 1:
        raise SystemExit(f"xdmf_geometry: {path}: VTK's reader gave {len(sets)} datasets with points, expected 1")
    d = sets[0]
    b = d.GetBounds()
    out = dict(time=float(times[0]), points=d.GetNumberOfPoints(),
               bounds=[[b[0], b[1]], [b[2], b[3]], [b[4], b[5]]])
    if hasattr(d, "GetDimensions"):
        nx, ny, nz = d.GetDimensions()
        out.update(nx=nx, ny=ny, nz=nz, spacing=list(d.GetSpacing()))
    return out


def y_um_attribute(path, folder):
    """The y_um attribute of the HDF5 file behind the first grid's first attribute, if any."""
    for grid in ET.parse(path).getroot().iter("Grid"):
        if grid.get("GridType", "Uniform") != "Uniform":
            continue
        item = grid.find("Attribute/DataItem")
        if item is None:
            return None
        file, _ = item.text.strip().split(":", 1)
        with h5py.File(os.path.join(folder, file), "r") as f:
            return float(np.asarray(f.attrs["y_um"])) if "y_um" in f.attrs else None
    return None


def main(argv):
    if len(argv) != 2 or argv[1] in ("--help", "-h"):
        print(__doc__.strip())
        return 0 if len(argv) == 2 else 2
    folder = argv[1]
    result = {}
    for path in sorted(glob.glob(os.path.join(folder, "*.xmf"))):
        entry = read_with_vtk(path)
        y_um = y_um_attribute(path, folder)
        if y_um is not None:
            entry["y_um_attribute"] = y_um
        result[os.path.basename(path)] = entry
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
