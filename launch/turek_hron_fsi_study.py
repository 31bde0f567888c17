#!/usr/bin/env python3
"""Turek & Hron's FSI2 and FSI3 as coupled runs (issue 29): the quantities against the reference.

The cylinder held by the fluid ([held_body]) with the elastic bar as a sheet of the solid
server, in the 2.5 x 0.41 m channel with the ramped parabolic inlet:
scenes/benchmarks/turek_hron_<case>.toml (FSI2: U_mean 1 m/s, the bar of density 1e4 and
E 1.4 MPa; FSI3: 2 m/s, 1e3 and 5.6 MPa) with its [grid] (and the sheet's CGPs) set to n cells
per diameter: dx = D / n, nx = 25 n, ny = 4.1 n, nz = 4; the sheet's CGPs 1 dx apart across
the span (nz of them) and L / (m + 1/2) along the bar with m = ceil(L / dx - 1/2) free rows
(at most 1 dx), placed half a cell upstream (the scene's comment says why); A_T the
smallest whole number that makes dt_CG = dt_LB / A_T stable (`build/solid/solid SCENE
--check` prints the stable step: 1 at 10 cells, 2 at 20); sheet snapshots
every 10 ms and held_body.csv rows every 5 ms. Each is run through launch/run-coupled.sh (build first:
bash launch/build.sh --target fluid solid).

Measured from a run's folder:
  u_x(A), u_y(A): the displacement of A, the free edge's midpoint (half a spacing beyond the
    top row, extrapolated from the mean of the two top rows, as solid::free_edge_midpoint),
    from the sheet snapshots sheets_NNNNNN.h5 (position_um), in 1e-3 m;
  drag, lift: held_body.csv's total_drag_N_per_m, total_lift_N_per_m, the force on the
    cylinder (the held body's markers) plus the bar (minus the sum of the sheet's impulses),
    N per metre of depth.
Each as the benchmark defines it: over the last period of the quantity (between its last two
up-crossings of the middle of its range over the last `--window` seconds), mean = (max +
min) / 2, amplitude = (max - min) / 2, frequency = 1 / period. The table gives each against
the reference (Turek & Hron 2006, docs/refs.bib) with the relative error of the mean (u_x,
drag), of the amplitude and of the frequency; and the wall time per simulated second.

  /usr/bin/python3 launch/turek_hron_fsi_study.py [--case fsi2|fsi3] [--out out/turek_hron_fsi]
      [--resolutions 10] [--seconds 15] [--table-only] [--run-dir DIR] [--tolerance KEY=REL,...]

--tolerance checks each run: one line "turek_hron_fsi_study: check CASE n N: KEY ...: ok" (or
FAILED) per KEY, exit 1 when one fails; KEY is QUANTITY_mean, _amplitude or _frequency, or
flap_frequency (u_y(A)'s frequency against half the reference's u_x(A) frequency: CHECKS
says why). TurekHronFsi2MatchesReference runs FSI2 at 10 cells for 13 s with the issue's bands.

--run-dir DIR measures one run folder (e.g. of `bash launch/run-coupled.sh
scenes/benchmarks/turek_hron_fsi2.toml --output DIR`) instead. Writes OUT/turek_hron_<case>.md
and OUT/turek_hron_<case>_n<n>.png (u_y(A), u_x(A), drag and lift against time, with the
reference band) when matplotlib is there.
"""
import argparse
import glob
import math
import os
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from build_dir import ROOT, build_dir  # noqa: E402
import last_period as period  # noqa: E402

D_M = 0.1      # the cylinder's diameter
L_M = 0.35     # the bar's length
NZ = 4         # span cells
C_M_S = 40.0   # the lattice speed of the scene (c = sqrt(3) c_s)
# quantity: (mean, amplitude, frequency in Hz); displacements in 1e-3 m, forces in N/m
REFERENCES = {
    "fsi2": {"u_x": (-14.58, 12.44, 3.8), "u_y": (1.23, 80.6, 2.0), "drag": (208.83, 73.75, 3.8),
             "lift": (0.88, 234.2, 2.0)},
    "fsi3": {"u_x": (-2.69, 2.53, 10.9), "u_y": (1.48, 34.38, 5.3), "drag": (457.3, 22.66, 10.9),
             "lift": (2.22, 149.78, 5.3)},
}
REFERENCE = REFERENCES["fsi2"]  # the case of this run of the script (main sets it)
# The flapping frequency. u_x(A) and the drag oscillate at twice the frequency of u_y(A) and
# the lift (the bar's tip shortens twice per flap: this script measures the ratio 2 within
# 0.3 % in every run), but the reference gives them rounded to 0.1 Hz: 3.8 and 2.0 Hz for
# FSI2 (3.75-3.85 and 1.95-2.05 Hz; no frequency lies in both), 10.9 and 5.3 for FSI3.
# The check "flap_frequency" takes the flap's frequency from the doubled one, known to 1.3 %
# (half its 0.05 Hz rounding over 3.8 Hz) instead of 2.5 %: u_y(A)'s frequency against half
# of u_x(A)'s reference frequency. docs/validation.md, "FSI2", says why and what
# independent computations report.
CHECKS = ("u_x_mean", "u_x_amplitude", "u_x_frequency", "u_y_amplitude", "u_y_frequency",
          "flap_frequency", "drag_mean", "drag_amplitude", "drag_frequency", "lift_amplitude",
          "lift_frequency")
UNITS = {"u_x": "1e-3 m", "u_y": "1e-3 m", "drag": "N/m", "lift": "N/m"}


def scene_text(n, seconds, case="fsi2"):
    """turek_hron_<case>.toml at n cells per diameter, run for `seconds`."""
    if (41 * n) % 10 != 0:
        raise SystemExit(f"turek_hron_fsi_study: {n} cells per diameter: ny = 4.1 n must be whole (n a multiple of 10)")
    dx = D_M / n
    rows = math.ceil(L_M / dx - 0.5 - 1e-9)  # the spacing along the bar at most dx
    h = L_M / (rows + 0.5)
    every = max(1, round((0.01 if case == "fsi2" else 0.002) / (dx / C_M_S)))  # 10 ms (FSI3: 2 ms) of LB steps
    values = {
        "[grid]": {"nx": str(25 * n), "ny": str(41 * n // 10), "nz": str(NZ), "dx_um": repr(dx * 1e6)},
        "[run]": {"duration_us": f"{seconds * 1e6:.6g}"},
        "[held_body]": {"record_every": str(max(1, every // 2))},
        "[output]": {"sheets_every": str(every)},
        "[[sheet]]": {"nx_cg": str(NZ), "ny_cg": str(rows + 1),
                      "spacing_um": f"[{dx * 1e6!r}, {h * 1e6!r}]",
                      "base_um": f"[{(0.25 - dx / 2) * 1e6!r}, 200000.0, {1.5 * dx * 1e6!r}]"},
    }
    with open(ROOT / "scenes" / "benchmarks" / f"turek_hron_{case}.toml") as f:
        text = f.read()
    out, section = [], ""
    for line in text.splitlines():
        if line.startswith("["):
            section = line.strip()
        key = line.split("=")[0].strip()
        if key in values.get(section, {}):
            line = f"{key} = {values[section][key]}"
        out.append(line)
    return "\n".join(out) + "\n"


def time_ratio(scene):
    """A_T = ceil(dt_LB / the bar's stable step), the stable step as `solid --check` prints it
    (the bending of the finer sheet stiffens it as 1 / spacing^2, dt_LB shrinks as dx)."""
    text = subprocess.run([str(build_dir() / "solid" / "solid"), str(scene), "--check"], check=True,
                          capture_output=True, text=True).stdout
    stable = float(re.search(r"stable dt_CG \(2 / omega_max[^)]*\): ([0-9.eE+-]+) s", text).group(1))
    dt_lb = float(re.search(r"dt_LB = ([0-9.eE+-]+) s", text).group(1))
    return math.ceil(dt_lb / stable * (1 + 1e-12))


def run_case(case, n, seconds, out):
    folder = out / f"{case}_n{n}"
    folder.mkdir(parents=True, exist_ok=True)
    scene = folder / "scene.toml"
    scene.write_text(scene_text(n, seconds, case))
    a_t = time_ratio(scene)
    scene.write_text(re.sub(r"(?m)^time_ratio = .*$", f"time_ratio = {a_t}", scene.read_text()))
    run = folder / "run"
    if run.exists():
        shutil.rmtree(run)  # the study's own earlier run of this resolution: run anew
    cmd = ["bash", str(ROOT / "launch" / "run-coupled.sh"), str(scene), "--no-build", "--quiet", "--output", str(run)]
    print("turek_hron_fsi_study: " + " ".join(cmd), flush=True)
    t0 = time.monotonic()
    subprocess.run(cmd, check=True)
    (folder / "wall_s").write_text(f"{time.monotonic() - t0:.1f}\n")


def tip_series(run):
    """Times (s) and A's displacement (x, y) in 1e-3 m from the sheet snapshots."""
    import h5py  # noqa: PLC0415 (only where snapshots are read)
    files = sorted(glob.glob(str(run / "sheets_*.h5")))
    if not files:
        return None
    t, a = [], []
    for p in files:
        with h5py.File(p, "r") as f:
            nx, ny = (int(v) for v in f["sheet_grid"][0])
            x = f["position_um"][: nx * ny].reshape(ny, nx, 3) * 1e-6  # CGP (i, j) at j nx + i
            top, below = x[-1].mean(axis=0), x[-2].mean(axis=0)
            a.append(top + 0.5 * (top - below))
            t.append(float(f.attrs["time_s"]))
    t, a = np.array(t), np.array(a)
    u = (a - a[0]) * 1e3
    return t, u[:, 0], u[:, 1]


def force_series(run):
    path = run / "held_body.csv"
    if not path.exists():
        return None
    with open(path) as f:
        names = f.readline().strip().split(",")
    d = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    col = {k: d[:, i] for i, k in enumerate(names)}
    return col["time_s"], col["total_drag_N_per_m"], col["total_lift_N_per_m"]


def last_period(t, v, window):
    """(mean, amplitude, frequency) of v over its last period in the last `window` seconds;
    None where it did not cross the middle of its range upward twice there."""
    p = period.last_period(t, v, window)
    return None if p is None else (*period.mean_amplitude(v, p[0]), p[1])


def measure(run, window):
    tip, forces = tip_series(run), force_series(run)
    series = {}
    if tip is not None:
        series["u_x"] = (tip[0], tip[1])
        series["u_y"] = (tip[0], tip[2])
    if forces is not None:
        series["drag"] = (forces[0], forces[1])
        series["lift"] = (forces[0], forces[2])
    q = {k: last_period(t, v, window) for k, (t, v) in series.items()}
    t_end = max((t[-1] for t, _ in series.values()), default=0.0)
    return q, series, t_end


def rel(value, ref):
    return "" if value is None or ref in (None, 0) else f"{100.0 * (value / ref - 1.0):+.1f} %"


def fmt(q):
    return "no period" if q is None else f"{q[0]:.4g} +- {q[1]:.4g} [{q[2]:.3g} Hz]"


def table(rows):
    lines = ["| n | t_end (s) | wall s per simulated s | quantity | measured | reference | "
             "error of mean | error of amplitude | error of frequency |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for n, (q, _, t_end), wall in rows:
        per = f"{wall / t_end:.3g}" if wall and t_end else ""
        for k, ref in REFERENCE.items():
            got = q.get(k)
            lines.append(f"| {n} | {t_end:.3g} | {per} | {k} ({UNITS[k]}) | {fmt(got)} | "
                         f"{ref[0]} +- {ref[1]} [{ref[2]}] | "
                         + (" | ".join(["", "", ""]) if got is None else
                            f"{rel(got[0], ref[0])} | {rel(got[1], ref[1])} | {rel(got[2], ref[2])}") + " |")
    return "\n".join(lines) + "\n"


def check(q, key):
    """(measured, reference) of the check `key` (CHECKS) from measure()'s quantities."""
    if key == "flap_frequency":
        got = q.get("u_y")
        return (None if got is None else got[2]), REFERENCE["u_x"][2] / 2.0
    name, part = key.rsplit("_", 1)
    index = ("mean", "amplitude", "frequency").index(part)
    got = q.get(name)
    return (None if got is None else got[index]), REFERENCE[name][index]


def checks(where, q, tolerances):
    """Prints one line per tolerance; returns the number that failed (or were not measured)."""
    failed = 0
    for key, tol in tolerances.items():
        got, ref = check(q, key)
        d = None if got is None else got / ref - 1.0
        ok = d is not None and math.isfinite(d) and abs(d) <= tol
        failed += not ok
        shown = "not measured" if d is None else f"{got:.4g} against {ref:.4g}, {100 * d:+.2f} %"
        print(f"turek_hron_fsi_study: check {where}: {key} {shown}, tolerance {100 * tol:g} %: "
              f"{'ok' if ok else 'FAILED'}")
    return failed


def plot(path, series):
    try:
        import matplotlib  # noqa: PLC0415
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt  # noqa: PLC0415
    except ImportError:
        return False
    fig, axes = plt.subplots(4, 1, figsize=(8, 10), sharex=True)
    for ax, k in zip(axes, ("u_y", "u_x", "drag", "lift")):
        if k in series:
            t, v = series[k]
            ax.plot(t, v, lw=0.8)
        mean, amp, _ = REFERENCE[k]
        ax.axhspan(mean - amp, mean + amp, color="0.85", zorder=0)
        ax.set_ylabel(f"{k} ({UNITS[k]})")
    axes[-1].set_xlabel("t (s)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    return True


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--case", choices=sorted(REFERENCES), default="fsi2")
    ap.add_argument("--out", default=str(ROOT / "out" / "turek_hron_fsi"))
    ap.add_argument("--resolutions", default="10")
    ap.add_argument("--seconds", type=float, default=15.0)
    ap.add_argument("--window", type=float, default=1.5, help="seconds at the end in which the last period is sought")
    ap.add_argument("--table-only", action="store_true")
    ap.add_argument("--run-dir", help="measure this one run folder")
    ap.add_argument("--print-scene", type=int, metavar="N", help="print the scene at N cells per diameter and exit")
    ap.add_argument("--tolerance", default="",
                    help="KEY=REL,... (KEY of " + ", ".join(CHECKS) + "): exit 1 when a run "
                         "differs from the reference by more than REL (relative) in KEY")
    a = ap.parse_args()
    tolerances = {}
    for item in filter(None, a.tolerance.split(",")):
        k, _, v = item.partition("=")
        try:
            tol = float(v)
        except ValueError:
            tol = -1.0
        if k not in CHECKS or not tol > 0.0:
            ap.error(f"--tolerance {item}: allowed KEY=REL with REL > 0 and KEY one of " + ", ".join(CHECKS))
        tolerances[k] = tol
    global REFERENCE
    REFERENCE = REFERENCES[a.case]
    if a.print_scene:
        sys.stdout.write(scene_text(a.print_scene, a.seconds, a.case))
        return
    if a.run_dir:
        run = Path(a.run_dir)
        q, series, t_end = measure(run, a.window)
        print(table([("run", (q, series, t_end), None)]), end="")
        return 1 if checks(f"{a.case} {run}", q, tolerances) else 0
    out = Path(a.out)
    rows = []
    for n in (int(v) for v in a.resolutions.split(",")):
        if not a.table_only:
            run_case(a.case, n, a.seconds, out)
        folder = out / f"{a.case}_n{n}"
        wall = float((folder / "wall_s").read_text()) if (folder / "wall_s").exists() else None
        m = measure(folder / "run", a.window)
        rows.append((n, m, wall))
        plot(out / f"turek_hron_{a.case}_n{n}.png", m[1])
    text = table(rows)
    (out / f"turek_hron_{a.case}.md").write_text(text)
    print(text, end="")
    failed = sum(checks(f"{a.case} n {n}", m[0], tolerances) for n, m, _ in rows)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
