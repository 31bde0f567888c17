#!/usr/bin/env python3
"""The difference between two coupled runs' solid.h5, dataset by dataset.

    /usr/bin/python3 launch/compare_solid_runs.py REFERENCE_DIR OTHER_DIR

For every floating-point dataset of REFERENCE_DIR/solid.h5 (time series of the sheets: the
marked CGP's displacement, the fluid force and coefficients, strain, energies): the largest
|value| in the reference, the largest |difference| at the same row, their ratio, and the last
row of each. Used to state what the single-precision fluid store changes in the paper's scene
(docs/performance.md, launch/paper-end-to-end.sh). Exit 2 with one line for a missing file or
a dataset whose shape differs.
"""
import sys

import h5py
import numpy as np


def datasets(path):
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: out.__setitem__(name, np.array(obj))
                     if isinstance(obj, h5py.Dataset) else None)
    return out


def main(argv):
    if len(argv) == 2 and argv[1] in ("--help", "-h"):
        print(__doc__.strip())
        return 0
    if len(argv) != 3:
        print("usage: compare_solid_runs.py REFERENCE_DIR OTHER_DIR", file=sys.stderr)
        return 2
    try:
        ref = datasets(f"{argv[1]}/solid.h5")
        other = datasets(f"{argv[2]}/solid.h5")
    except OSError as e:
        print(f"compare_solid_runs: {e}", file=sys.stderr)
        return 2
    print(f"{'dataset':32s} {'rows':>6s} {'max |ref|':>11s} {'max |diff|':>11s} {'relative':>10s}   last row (first component): ref / other")
    for name, a in sorted(ref.items()):
        if a.dtype.kind != "f" or a.size == 0:
            continue
        b = other.get(name)
        if b is None or b.shape != a.shape:
            print(f"compare_solid_runs: {name}: shape {a.shape} in {argv[1]}, "
                  f"{None if b is None else b.shape} in {argv[2]}", file=sys.stderr)
            return 2
        scale = float(np.max(np.abs(a)))
        diff = float(np.max(np.abs(a - b)))
        rel = diff / scale if scale > 0 else 0.0
        last_a = a.reshape(len(a), -1)[-1][0]
        last_b = b.reshape(len(b), -1)[-1][0]
        print(f"{name:32s} {len(a):6d} {scale:11.4g} {diff:11.3g} {rel:10.3g}   {last_a:.9g} / {last_b:.9g}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
