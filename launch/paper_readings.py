#!/usr/bin/env python3
"""The paper's families under each reaction law, point by point (issue 16 item 5).

Runs (unless --table-only) `launch/sweep.sh FAMILY --law LAW --no-build` for each family
(re, angle, pair) and law, then reads each run's solid.h5 and sheet snapshots and prints one
table per family with what the paper's section 3 states about it:

  - ringing near the vacuum eigenfrequency: f from the zero crossings of the marked CGP's
    displacement about its late mean (launch/plot.py crossing_times), over f_vac
    (`solid SCENE --check`, launch/sader.py vacuum_frequency);
  - 30 deg growing while 60 and 90 deg decay: A1 and A2, the peak-to-peak excursion of that
    displacement in the second and the last quarter of the free phase (um), and their ratio
    A2 / A1 (> 1: growing);
  - the pair periodic for ds <= 2.05 um and chaotic for ds >= 4.1 um: cv, the coefficient of
    variation of the half periods between successive crossings in the second half of the
    free phase (0 for a strictly periodic motion);
  - collisions held apart by the LJ wall, none at 11.5 um: gap, the smallest distance
    between a CGP of G1 and one of G2 over the sheet snapshots (um), next to the contact's
    cut-off (the sheets' CGP spacing unless [contact] cutoff_um says otherwise).

The displacement used is the component of the marked CGP's displacement that moves most in
the free phase: x (stream-wise) or z (span-wise); "late: rest" when it moves by less than
1 nm peak to peak in the second half of the free phase.

  /usr/bin/python3 launch/paper_readings.py [--out out/sweep] [--families re,angle,pair]
      [--laws momentum_exchange,per_substep_over_time_ratio] [--table-only]

Output: the tables on stdout and in OUT/paper_readings.md. Build first (bash launch/build.sh).
"""
import argparse
import math
import os
import subprocess
import sys
import tomllib

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import plot_run as plot  # noqa: E402  (reading a run, crossings: launch/plot_run.py)
import sader  # noqa: E402

ROOT = sader.ROOT
FAMILIES = {
    "re": ["single_theta90_re01", "single_theta90_re10", "single_theta90_re20", "single_theta90_re40"],
    "angle": ["single_theta00_re40", "single_theta30_re40", "single_theta45_re40", "single_theta60_re40",
              "single_theta90_re40"],
    "pair": ["pair_ds01p02_re40", "pair_ds02p05_re40", "pair_ds04p10_re40", "pair_ds08p20_re40",
             "pair_ds11p50_re40"],
}
REST_UM = 1e-3   # a late peak-to-peak excursion below 1 nm counts as rest
LAWS = ("momentum_exchange", "omit_boundary_velocity", "per_substep_over_time_ratio", "eq18_literal")


def fail(message):
    print(f"paper_readings: {message}", file=sys.stderr)
    sys.exit(2)


def peak_to_peak(t, x, lo, hi):
    k = (t >= lo) & (t <= hi)
    return float(np.ptp(x[k])) if np.count_nonzero(k) > 1 else math.nan


def half_period_cv(t, crossings):
    """Coefficient of variation of the intervals between successive crossings in the second
    half of the free phase (nan with fewer than three such crossings)."""
    c = np.asarray([z for z in crossings if z >= t[0] + 0.5 * (t[-1] - t[0])])
    if c.size < 3:
        return math.nan
    d = np.diff(c)
    return float(np.std(d) / np.mean(d))


def smallest_gap(run, per_sheet):
    """The smallest G1-G2 CGP distance (um) over the run's sheet snapshots after the release."""
    best = math.inf
    for step in sorted(run.sheet_snapshots):
        if step < run.rigid_steps:
            continue
        p = run.cgp_positions(step)
        if p is None:
            continue
        xyz = np.stack([p["x"], p["y"], p["z"]], axis=1)
        if xyz.shape[0] < 2 * per_sheet:
            continue
        a, b = xyz[:per_sheet], xyz[per_sheet:2 * per_sheet]
        d = np.sqrt(((a[:, None, :] - b[None, :, :]) ** 2).sum(axis=2)).min()
        best = min(best, float(d))
    return best


def measure(run_dir, f_vac):
    run = plot.Run(run_dir)
    k = run.free
    t = run.t_us[k]
    T = t[-1] - t[0]
    rows = []
    for s in range(run.sheets):
        comps = {"x": run.disp[k, s, 0], "z": run.disp[k, s, 2]}
        half = t >= t[0] + 0.5 * T
        name = max(comps, key=lambda c: float(np.std(comps[c])))
        x = comps[name]
        crossings = plot.crossing_times(t, x)
        f, n = plot.crossing_frequency(t, x)
        late = "rest" if float(np.ptp(x[half])) < REST_UM else "moving"
        a1 = peak_to_peak(t, x, t[0] + 0.25 * T, t[0] + 0.5 * T)
        a2 = peak_to_peak(t, x, t[0] + 0.75 * T, t[-1])
        rows.append(dict(sheet=f"G{s + 1}", comp=name, late=late, x_end=float(run.disp[k, s, 0][-1]),
                         z_end=float(run.disp[k, s, 2][-1]), f=f, n=n,
                         ratio=f / (f_vac * 1e-6) if math.isfinite(f) else math.nan,
                         a1=a1, a2=a2, growth=a2 / a1 if a1 > 0 else math.nan,
                         cv=half_period_cv(t, crossings) if late == "moving" else math.nan, t_free=T))
    return run, rows


def sweep_exit(base, run_name):
    """The run's exit status from the sweep's summary.txt (launch/run-coupled.sh's codes)."""
    path = os.path.join(base, "summary.txt")
    if os.path.isfile(path):
        with open(path, errors="replace") as fh:
            for line in fh:
                w = line.split()
                if len(w) >= 3 and w[0] == run_name:
                    return w[2]
    return "?"


def contact_cutoff(scene_path):
    with open(scene_path, "rb") as fh:
        s = tomllib.load(fh)
    c = s.get("contact", {}).get("cutoff_um")
    if c is not None:
        return float(c)
    sh = s["sheet"][0]
    sp = sh.get("spacing_um", 0.2561)
    return float(min(sp) if isinstance(sp, list) else sp)


def fmt(v, spec=".3g"):
    return "-" if v is None or (isinstance(v, float) and not math.isfinite(v)) else format(v, spec)


def table(out, family, laws):
    lines = [f"### {family}", "",
             "| scene | law | sheet | exit | x_end, z_end (um) | moves | f (MHz) | crossings | f / f_vac | "
             "A1, A2 (um) | A2 / A1 | late | cv | gap (um) / cut-off |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for name in FAMILIES[family]:
        for law in laws:
            base = os.path.join(out, f"{family}-{law}")
            run_dir = os.path.join(base, f"{name}_reduced")
            scene = os.path.join(base, "scenes", f"{name}_reduced.toml")
            if not os.path.isfile(os.path.join(run_dir, "solid.h5")) or not os.path.isfile(scene):
                lines.append(f"| {name} | {law} | - | - | not run | | | | | | | | | |")
                continue
            exit_status = sweep_exit(base, f"{name}_reduced")
            f_vac = sader.vacuum_frequency(scene)
            try:
                run, rows = measure(run_dir, f_vac)
            except plot.RunError as e:
                lines.append(f"| {name} | {law} | - | - | unreadable: {e} | | | | | | | | | |")
                continue
            gap = ""
            if run.sheets >= 2:
                with open(scene, "rb") as fh:
                    sh = tomllib.load(fh)["sheet"][0]
                g = smallest_gap(run, int(sh["nx_cg"]) * int(sh["ny_cg"]))
                gap = f"{fmt(g)} / {fmt(contact_cutoff(scene))}"
            for r in rows:
                lines.append(
                    f"| {name} | {law} | {r['sheet']} | {exit_status} | {fmt(r['x_end'])}, {fmt(r['z_end'])} | "
                    f"{r['comp']} | {fmt(r['f'], '.4g')} | {r['n']} | {fmt(r['ratio'])} | "
                    f"{fmt(r['a1'])}, {fmt(r['a2'])} | {fmt(r['growth'])} | {r['late']} | {fmt(r['cv'], '.2f')} | "
                    f"{gap} |")
    lines.append("")
    return lines


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="out/sweep")
    ap.add_argument("--families", default="re,angle,pair")
    ap.add_argument("--laws", default="momentum_exchange,per_substep_over_time_ratio")
    ap.add_argument("--table-only", action="store_true")
    a = ap.parse_args()
    families = [f for f in a.families.split(",") if f]
    laws = [l for l in a.laws.split(",") if l]
    for f in families:
        if f not in FAMILIES:
            fail(f"--families: '{f}' is not a family (re, angle, pair)")
    for l in laws:
        if l not in LAWS:
            fail(f"--laws: '{l}' is not a reaction law ({', '.join(LAWS)})")
    out = os.path.abspath(a.out)
    if not a.table_only:
        env = dict(os.environ, COSIM_SWEEP_OUT=out)
        for f in families:
            for l in laws:
                r = subprocess.run(["bash", os.path.join(ROOT, "launch", "sweep.sh"), f, "--no-build",
                                    "--law", l], env=env)
                if r.returncode != 0:
                    print(f"paper_readings: sweep {f} --law {l} exited {r.returncode}; its rows say what ran",
                          file=sys.stderr)
    lines = ["Made by `/usr/bin/python3 launch/paper_readings.py " +
             f"--out {a.out} --families {','.join(families)} --laws {','.join(laws)}" +
             (" --table-only" if a.table_only else "") + "`.", "",
             "moves: the component of the marked CGP's displacement that moves most in the free phase (x "
             "stream-wise, z span-wise); f: from its crossings of its late mean over the free phase "
             "(launch/plot.py, as sweep.sh's table); f_vac: the first vacuum eigenfrequency (solid --check); "
             "A1, A2: its peak-to-peak excursion in the second and last quarter of the free phase; late: "
             "rest when it moves less than 1 nm peak to peak in the second half; cv: variation of the half "
             "periods in the second half (moving only); gap: smallest G1-G2 CGP distance after the "
             "release, against the LJ cut-off.", ""]
    for f in families:
        lines += table(out, f, laws)
    text = "\n".join(lines)
    print(text)
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "paper_readings.md"), "w") as fh:
        fh.write(text + "\n")


if __name__ == "__main__":
    main()
