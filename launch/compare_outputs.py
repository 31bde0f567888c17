#!/usr/bin/env python3
"""Bit-for-bit comparison of the coupled runs in two folders (launch/bit-identity.sh).

    /usr/bin/python3 launch/compare_outputs.py REFERENCE_DIR OTHER_DIR

For every run folder in REFERENCE_DIR (REFERENCE_DIR/NAME/solid.h5 and monitor.h5) and the
same one in OTHER_DIR: every dataset's bytes compared; one row per file with the datasets
that differ. Exit 0 when all are identical, 1 when one differs or is missing.
"""
import os
import sys

from compare_solid_runs import datasets  # every dataset of a file, by name


def main(argv):
    if len(argv) == 2 and argv[1] in ("--help", "-h"):
        print(__doc__.strip())
        return 0
    if len(argv) != 3:
        print("usage: compare_outputs.py REFERENCE_DIR OTHER_DIR", file=sys.stderr)
        return 2
    ref, other = argv[1], argv[2]
    bad = 0
    print(f"{'run':<20} {'file':<12} {'datasets':>8}  result")
    for name in sorted(os.listdir(ref)):
        if not os.path.isdir(os.path.join(ref, name)):
            continue
        for f in ("solid.h5", "monitor.h5"):
            a, b = os.path.join(ref, name, f), os.path.join(other, name, f)
            if not (os.path.exists(a) and os.path.exists(b)):
                print(f"{name:<20} {f:<12} {'':>8}  missing in {'the reference' if not os.path.exists(a) else other}")
                bad += 1
                continue
            da, db = datasets(a), datasets(b)
            differ = sorted(set(da) ^ set(db)) + [k for k in sorted(set(da) & set(db))
                                                  if da[k].dtype != db[k].dtype or da[k].shape != db[k].shape
                                                  or da[k].tobytes() != db[k].tobytes()]
            print(f"{name:<20} {f:<12} {len(da):>8}  {'bit-identical' if not differ else 'DIFFER: ' + ', '.join(differ)}")
            bad += bool(differ)
    print("all bit-identical" if bad == 0 else f"{bad} file(s) differ")
    return 0 if bad == 0 else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
