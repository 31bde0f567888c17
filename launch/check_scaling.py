"""How `solid SCENE --check` scales with the number of sheets (issue 30 item 7: the check of a
scene with many sheets in linear time). Writes scenes of N copies of coupled_small's 5 x 10
CGP sheet, each on its own 3 um square of the floor (the grid widened to hold them), times
`build/solid/solid SCENE --check` on each and prints a table: N, wall seconds, seconds per
1000 sheets, and the peak resident memory.

  /usr/bin/python3 launch/check_scaling.py [--sheets 200,2000,20000] [--repeat 3] [--out DIR]
"""

import argparse
import math
import os
import statistics
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "launch"))
from build_dir import build_dir  # noqa: E402

SPACING_UM = 3.0
DX_UM = 0.2561


def scene_text(template, n):
    """coupled_small.toml with its one [[sheet]] replaced by n sheets on a square of the floor."""
    head = template[: template.index("\n[[sheet]]") + 1]
    side = math.ceil(math.sqrt(n))
    cells = int(side * SPACING_UM / DX_UM) + 20
    for key, value in (("nx = 40\n", f"nx = {cells}\n"), ("nz = 30\n", f"nz = {cells}\n"),
                       ('name = "coupled_small"', f'name = "check_scaling_{n}"')):
        if key not in head:
            sys.exit(f"check_scaling.py: scenes/coupled_small.toml has no '{key.strip()}' to widen")
        head = head.replace(key, value, 1)
    sheets = []
    for i in range(n):
        x, z = 2.0 + (i % side) * SPACING_UM, 2.0 + (i // side) * SPACING_UM
        sheets.append(f"[[sheet]]\nnx_cg = 5\nny_cg = 10\nbase_um = [{x:.4f}, 0.0, {z:.4f}]\ntheta_deg = 90\n\n")
    return head + "".join(sheets)


def timed_check(solid, scene):
    """(wall seconds, peak resident MiB) of one `solid SCENE --check`; exits on a failure."""
    with open(scene + ".log", "w+") as log:
        t0 = time.perf_counter()
        child = subprocess.Popen([solid, scene, "--check"], stdout=log, stderr=subprocess.STDOUT)
        _, status, usage = os.wait4(child.pid, 0)
        wall = time.perf_counter() - t0
        child.returncode = os.waitstatus_to_exitcode(status)
        if child.returncode != 0:
            log.seek(0)
            sys.exit(f"check_scaling.py: {solid} {scene} --check exited {child.returncode}: {log.read().strip()}")
    return wall, usage.ru_maxrss / 1024.0


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--sheets", default="200,2000,20000", help="sheet counts, comma separated")
    p.add_argument("--repeat", type=int, default=3, help="runs per count (the median is shown)")
    p.add_argument("--out", default="out/check_scaling", help="folder for the scenes")
    a = p.parse_args()
    try:
        counts = [int(s) for s in a.sheets.split(",")]
    except ValueError:
        sys.exit(f"check_scaling.py: --sheets '{a.sheets}': allowed: positive integers, comma separated")
    if not counts or min(counts) < 1 or a.repeat < 1:
        sys.exit(f"check_scaling.py: --sheets '{a.sheets}' --repeat {a.repeat}: allowed: counts >= 1, repeat >= 1")
    solid = os.path.join(build_dir(), "solid", "solid")
    if not os.access(solid, os.X_OK):
        sys.exit(f"check_scaling.py: {solid} is not built (bash launch/build.sh)")
    with open(os.path.join(ROOT, "scenes", "coupled_small.toml")) as f:
        template = f.read()
    os.makedirs(a.out, exist_ok=True)
    print(f"solid --check against the number of sheets (5 x 10 CGPs each); median of {a.repeat} runs")
    print(f"{'sheets':>8} {'wall s':>8} {'range s':>15} {'s per 1000':>11} {'peak MiB':>9}")
    for n in counts:
        scene = os.path.join(a.out, f"check_scaling_{n}.toml")
        with open(scene, "w") as f:
            f.write(scene_text(template, n))
        walls, peak = [], 0.0
        for _ in range(a.repeat):
            w, m = timed_check(solid, scene)
            walls.append(w)
            peak = max(peak, m)
        med = statistics.median(walls)
        print(f"{n:>8} {med:>8.2f} {min(walls):>7.2f}-{max(walls):<7.2f} {1000 * med / n:>11.3f} {peak:>9.0f}")


if __name__ == "__main__":
    main()
