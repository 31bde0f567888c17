#!/usr/bin/env python3
"""Turek & Hron's CFD2 and CFD3 over resolution (issue 29, item 2).

The cylinder with its bar, both rigid and held at rest by the fluid ([held_body]), in the
2.5 x 0.41 m channel with the ramped parabolic inlet: the scenes
scenes/benchmarks/turek_hron_cfd{2,3}.toml with their [grid] set to n cells per diameter
(nx = 25 n, ny = 4.1 n, dx = D / n; everything else in physical units, so nothing else
changes), each run with `build/fluid/fluid` (build first: bash launch/build.sh --target fluid).

Measured from OUT/<case>_n<n>/held_body.csv (drag and lift per unit depth, N/m):
  CFD2 (steady): the mean over the last 0.5 s;
  CFD3 (periodic): mean +- amplitude [frequency] over the last period, as the benchmark
    defines them: the period between the last two up-crossings of the lift through the middle
    of its range over the last second, mean = (max + min) / 2, amplitude = (max - min) / 2.
The table gives each against the reference (Turek & Hron 2006; FeatFlow's CFD2 and CFD3 pages,
docs/refs.bib) with the relative error and, over three resolutions n, 2n, 4n, the observed
order log2(|q_n - q_2n| / |q_2n - q_4n|).

  /usr/bin/python3 launch/turek_hron_study.py [--out out/turek_hron] [--cases cfd2,cfd3]
      [--resolutions 10,20,40] [--cfd2-seconds 7] [--cfd3-seconds 12] [--threads 1]
      [--table-only]

--table-only makes the table and plots from the runs already in OUT (none is run).
Writes OUT/turek_hron.md (the table) and OUT/turek_hron_<case>.png (drag and lift against time
with the reference).
"""
import argparse
import math
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from build_dir import ROOT, build_dir  # noqa: E402
import last_period as period  # noqa: E402

D_M = 0.1  # the cylinder's diameter
REFERENCE = {
    # quantity: (mean, amplitude, frequency); CFD2 is steady
    "cfd2": {"drag": (136.70, None, None), "lift": (10.534, None, None)},
    "cfd3": {"drag": (439.45, 5.6183, 4.3956), "lift": (-11.893, 437.81, 4.3956)},
}


def scene_text(case, n, seconds):
    """The case's scene at n cells per diameter, run for `seconds`."""
    with open(ROOT / "scenes" / "benchmarks" / f"turek_hron_{case}.toml") as f:
        text = f.read()
    if (41 * n) % 10 != 0:
        raise SystemExit(f"turek_hron_study: {n} cells per diameter: ny = 4.1 n must be whole (n a multiple of 10)")
    grid = {"nx": str(25 * n), "ny": str(41 * n // 10), "dx_um": repr(1e5 / n)}
    out, section = [], ""
    for line in text.splitlines():
        if line.startswith("["):
            section = line.strip()
        key = line.split("=")[0].strip()
        if section == "[grid]" and key in grid:
            line = f"{key} = {grid[key]}"
        if section == "[run]" and key == "duration_us":
            line = f"duration_us = {seconds * 1e6:.6g}"
        out.append(line)
    return "\n".join(out) + "\n"


def run_case(case, n, seconds, out, threads):
    folder = out / f"{case}_n{n}"
    folder.mkdir(parents=True, exist_ok=True)
    scene = folder / "scene.toml"
    scene.write_text(scene_text(case, n, seconds))
    env = dict(os.environ, OMP_NUM_THREADS=str(threads))
    cmd = [str(build_dir() / "fluid" / "fluid"), str(scene), "--quiet", "--output", str(folder / "run")]
    print("turek_hron_study: " + " ".join(cmd), flush=True)
    with open(folder / "fluid.log", "w") as log:
        subprocess.run(cmd, check=True, stdout=log, stderr=subprocess.STDOUT, env=env)


def series(out, case, n):
    path = out / f"{case}_n{n}" / "run" / "held_body.csv"
    if not path.exists():
        return None
    d = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    return d[:, 1], d[:, 2], d[:, 3]


def last_period(t, drag, lift):
    """Mean, amplitude of drag and lift over the last lift period, its frequency; None if the
    lift did not cross the middle of its range at least twice upward in the last second, or
    if its range there is below 1 % of the mean drag (a steady wake and its acoustic noise)."""
    m = t >= t[-1] - 1.0
    if lift[m].max() - lift[m].min() < 0.01 * abs(drag[m].mean()):
        return None
    p = period.last_period(t, lift, 1.0)
    if p is None:
        return None
    s, f = p
    return {name: (*period.mean_amplitude(v, s), f) for name, v in (("drag", drag), ("lift", lift))}


def measure(out, case, n):
    s = series(out, case, n)
    if s is None:
        return None
    t, drag, lift = s
    if case == "cfd2":
        m = t > t[-1] - 0.5
        before = (t > t[-1] - 1.0) & ~m
        return {"drag": (drag[m].mean(), None, None), "lift": (lift[m].mean(), None, None),
                "steady": abs(drag[m].mean() - drag[before].mean()) / abs(drag[m].mean()), "t_end": t[-1]}
    q = last_period(t, drag, lift)
    if q is None:
        q = {"drag": (drag[t > t[-1] - 0.5].mean(), None, None), "lift": (lift[t > t[-1] - 0.5].mean(), None, None)}
        q["no_shedding"] = True
    q["t_end"] = t[-1]
    return q


def order(values):
    """Observed order over three resolutions n, 2n, 4n; None if undefined."""
    if len(values) != 3 or any(v is None for v in values):
        return None
    a, b = values[0] - values[1], values[1] - values[2]
    if a == 0 or b == 0 or a * b < 0:
        return None
    return math.log2(abs(a) / abs(b))


def table(out, cases, resolutions):
    lines = ["| case | quantity | " + " | ".join(f"n = {n}" for n in resolutions) + " | reference | observed order |",
             "| --- | --- | " + " | ".join("---" for _ in resolutions) + " | --- | --- |"]
    for case in cases:
        results = [measure(out, case, n) for n in resolutions]
        for qname in ("drag", "lift"):
            for part, label in ((0, "mean"), (1, "amplitude"), (2, "frequency (Hz)")):
                ref = REFERENCE[case][qname][part]
                if ref is None:
                    continue
                cells, vals = [], []
                for r in results:
                    v = None if r is None or (r.get("no_shedding") and part > 0) else r[qname][part]
                    vals.append(v)
                    if r is None:
                        cells.append("not run")
                    elif v is None:
                        cells.append("no shedding")
                    else:
                        cells.append(f"{v:.4g} ({100 * (v / ref - 1):+.2f} %)")
                # An order only over runs of one regime: none where a resolution did not shed.
                steady_mix = any(r is not None and r.get("no_shedding") for r in results)
                p = order(vals) if len(resolutions) == 3 and not steady_mix else None
                unit = "" if part == 2 else " (N/m)"
                lines.append(f"| {case.upper()} | {qname} {label}{unit} | " + " | ".join(cells) +
                             f" | {ref:.5g} | {'-' if p is None else f'{p:.2f}'} |")
        for n, r in zip(resolutions, results):
            if r is not None and r.get("no_shedding"):
                lines.append(f"| {case.upper()} | n = {n}: no shedding by t = {r['t_end']:.3g} s (lift range in the "
                             "last second below 1 % of the drag); its means are those of the last 0.5 s |" +
                             " |" * (len(resolutions) + 1))
    text = "\n".join(lines) + "\n"
    (out / "turek_hron.md").write_text(text)
    print(text)


def plot(out, cases, resolutions):
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        print("turek_hron_study: matplotlib missing, no plots")
        return
    for case in cases:
        fig, axes = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
        for ax, (k, name) in zip(axes, ((1, "drag"), (2, "lift"))):
            mean, amp, _ = REFERENCE[case][name]
            if amp is None:
                ax.axhline(mean, color="k", lw=0.8, label="reference")
            else:
                ax.axhspan(mean - amp, mean + amp, color="0.85", label="reference mean +- amplitude")
            for n in resolutions:
                s = series(out, case, n)
                if s is not None:
                    ax.plot(s[0], s[k], lw=0.8, label=f"{n} cells / D")
            ax.set_ylabel(f"{name} (N/m)")
            ax.legend(fontsize=7)
        axes[-1].set_xlabel("t (s)")
        fig.suptitle(f"Turek & Hron {case.upper()}: cylinder and rigid bar held by the fluid")
        fig.tight_layout()
        fig.savefig(out / f"turek_hron_{case}.png", dpi=110)
        plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0], epilog=__doc__,
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--out", default="out/turek_hron")
    ap.add_argument("--cases", default="cfd2,cfd3")
    ap.add_argument("--resolutions", default="10,20,40")
    ap.add_argument("--cfd2-seconds", type=float, default=7.0)
    ap.add_argument("--cfd3-seconds", type=float, default=12.0)
    ap.add_argument("--threads", type=int, default=1)
    ap.add_argument("--table-only", action="store_true")
    a = ap.parse_args()
    from pathlib import Path
    out = Path(a.out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    cases = [c for c in a.cases.split(",") if c]
    for c in cases:
        if c not in REFERENCE:
            raise SystemExit(f"turek_hron_study: --cases {c}: allowed: cfd2, cfd3")
    resolutions = [int(x) for x in a.resolutions.split(",") if x]
    if not a.table_only:
        for case in cases:
            for n in resolutions:
                run_case(case, n, a.cfd2_seconds if case == "cfd2" else a.cfd3_seconds, out, a.threads)
    table(out, cases, resolutions)
    plot(out, cases, resolutions)


if __name__ == "__main__":
    main()
