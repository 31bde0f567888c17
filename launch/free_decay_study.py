#!/usr/bin/env python3
"""Free decay of the paper's sheet in still air against the Sader reference (issue 16).

Each case releases the paper's 5 x 40 sheet (W 1.2 um, H 8.8 um, "paper" flexural
scaling, the linear rcgp model: the theory is linear and the deflection small) from a held
deflection of its top row in a box of air at rest, periodic across x and z, the plate at
y = 0 (wall) and free slip at the top, and measures the marked CGP's normal displacement
against launch/sader.py's free decay for the same sheet and air: the first two zero
crossings, the undershoot, the frequency from the crossings and the damping ratio from the
first undershoot.

Cases (mass: atoms per CGP over the paper's 2e6; nu fixed across resolutions, so tau
follows dx):
  paper   the paper's sheet in the paper's air (nu = 1.314e-5 m^2/s: tau 0.768 at
          dx = 0.2561 um)
  lownu   the same sheet in air of lower viscosity (tau 0.6 at dx = 0.2561 um)
  heavy   CGPs 100 times heavier, the paper's air: it rings
at two resolutions (dx = 0.5122 and 0.2561 um) and two boxes (small: 12.3 x 12.3 x 10.2
um, large: 20.5 x 15.4 x 15.4 um around the 8.8 um sheet).

  python3 launch/free_decay_study.py [--out out/free_decay] [--cases heavy,paper]
      [--resolutions 0.5122,0.2561] [--boxes small,large] [--law momentum_exchange]
      [--t-end-us T] [--tolerance KEY=REL,...] [--sheet-refine K] [--scene-only] [--table-only]

--sheet-refine K discretizes the same sheet with K times more CGPs each way (5K x 40K CGPs of
spacing 0.24/K x 0.22/K um and 2e6/K^2 atoms, 9 RCGP stages kept): the same plate (D, areal
density, W, H) whose CGPs, the immersed boundary's markers, stay within a cell of each other on
a K times finer grid (5 x 40 CGPs on dx = 0.128 um would be 1.9 dx apart: a leaky boundary).

--table-only makes the table and the plot from the runs already in OUT (none is run).

Writes OUT/<case>/{scene.toml, run output}, OUT/free_decay.md (the table) and
OUT/free_decay.png (the responses against the reference). Runs go through
launch/run-coupled.sh --no-build (build first: bash launch/build.sh).
"""
import argparse
import math
import os
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import sader  # noqa: E402

ROOT = sader.ROOT
NU_PAPER = (0.768 - 0.5) / 3.0 * 0.2561e-6 * math.sqrt(3) * sader.SOUND_SPEED
NU_LOW = (0.6 - 0.5) / 3.0 * 0.2561e-6 * math.sqrt(3) * sader.SOUND_SPEED
CASES = {  # name: (mass factor, nu, time after release in us)
    "paper": (1.0, NU_PAPER, 0.8),
    "lownu": (1.0, NU_LOW, 0.8),
    "heavy": (100.0, NU_PAPER, 2.4),
}
# x (normal to the sheet), air above the tip (y), z (span), um: the box's height is the
# sheet's height plus that margin (12.3 and 15.4 um for the paper's 8.8 um sheet).
BOXES = {"small": (12.3, 3.5, 10.2), "large": (20.5, 6.6, 15.4),
         "x2": (41.0, 13.2, 30.8), "x3": (61.5, 19.8, 46.2)}
# Aspect ratios L/b (the sheet's free length over its width) of the same sheet: rows of CGPs
# and RCGP stages. "paper" flexural scaling multiplies the bending rigidity D by lambda^2 = 4
# per stage while the in-plane constants and the mass per area stay, so a sheet L/L0 times
# longer with (L/L0)^4 times the D keeps f_vac, and with it Sader's Re and T0: only L/b moves.
# (rows, stages, A_T factor): the stiffer bending of the longer sheets shortens the model's
# stable step (L/b 30: 1.2e-12 s against dt_CG 3.0e-12 s at A_T 150), hence 4 A_T there
# (dt_CG at 0.62 of it, as at L/b 15).
ASPECTS = {"7": (40, 9, 1), "15": (80, 11, 1), "30": (160, 13, 4)}
# "strip": the limit L/b -> infinity, Sader's own setting. A rigid plate of the same width and
# mass per area on a spring of the paper sheet's f_vac (solid model "sprung": one degree of
# freedom, Sader's oscillator with no mode shape) spanning a box periodic along its height
# (8 cells, one row of CGPs per cell): no tip, no root, no wall. What is left between it and
# the theory is the coupling's error (and the box's, from its periodic images).
STRIP_CELLS = 8
F_VAC_PAPER_HZ = 5.3238e6  # the 5 x 40 sheet's first eigenfrequency (`solid SCENE --check`)
TIP_UM = 0.02


def tau_for(nu, dx_m):
    dt = dx_m / (math.sqrt(3) * sader.SOUND_SPEED)
    return 0.5 + 3.0 * nu * dt / (dx_m * dx_m)


def scene_text(name, case, dx_um, box, law="momentum_exchange", out_dir=None, t_end_us=None, refine=1,
               aspect="7", floor="wall", sides="periodic"):
    mass, nu, t_us = CASES[case]
    t_us = t_end_us or t_us
    dx = dx_um * 1e-6
    strip = aspect == "strip"
    rows, stages, a_t_factor = ASPECTS["7" if strip else aspect]
    bx, top, bz = BOXES[box]
    n = [max(8, int(round(L / dx_um))) for L in (bx, rows * 0.22 + top, bz)]
    if strip:
        n[1] = STRIP_CELLS
    tau = tau_for(nu, dx)
    dt_lb = dx / (math.sqrt(3) * sader.SOUND_SPEED)
    steps = int(math.ceil(t_us * 1e-6 / dt_lb))
    # dt_CG of the paper (A_T 150 at dx = 0.2561 um) for the paper's mass; a 100 times heavier
    # CGP has a 10 times larger stable step.
    a_t = int(round(150 * dx_um / 0.2561 / math.sqrt(mass)))
    # K times finer CGPs, K^2 times lighter: the highest (in-plane) frequency grows about K-fold
    # (solid --check at K = 2, dx 0.128 um: dt_CG 0.32 of the stable step).
    a_t *= refine * a_t_factor
    law_line = "" if law == "momentum_exchange" else f'\n[reaction]\nlaw = "{law}"\n'
    floors = (floor, "free_slip")
    solid = f'model = "rcgp"\nflexural_scaling = "paper"\nstages = {stages}'
    sheet = (f"nx_cg = {5 * refine}\nny_cg = {rows * refine}\nspacing_um = [{0.24 / refine:g}, {0.22 / refine:g}]\n"
             f"atoms_per_cgp = {2e6 * mass / refine ** 2:g}\n"
             f"base_um = [{n[0] * dx_um / 2:.4f}, 0.0, {n[2] * dx_um / 2:.4f}]")
    shape = ""
    if strip:  # one row per cell along the periodic height, the paper's mass per area
        floors = ("periodic", "periodic")
        solid = f'model = "sprung"\nspring_frequency_hz = {F_VAC_PAPER_HZ / math.sqrt(mass):.6g}'
        sheet = (f"nx_cg = {5 * refine}\nny_cg = {STRIP_CELLS}\nspacing_um = [{0.24 / refine:g}, {dx_um}]\n"
                 f"atoms_per_cgp = {2e6 * mass / refine * dx_um / 0.22:.8g}\n"
                 f"base_um = [{n[0] * dx_um / 2:.4f}, {dx_um / 2:.6g}, {n[2] * dx_um / 2:.4f}]")
        shape = '\nshape = "translation"'
    return f'''# Free decay in still air (launch/free_decay_study.py, issue 16); generated, do not edit.
[scene]
name = "{name}"
description = "free decay: {case} sheet, dx {dx_um} um, {box} box"

[grid]
nx = {n[0]}
ny = {n[1]}
nz = {n[2]}
dx_um = {dx_um}

[fluid]
tau = {tau:.6f}

[boundaries]
x_min = "{sides}"
x_max = "{sides}"
y_min = "{floors[0]}"
y_max = "{floors[1]}"
z_min = "periodic"
z_max = "periodic"

[run]
steps = {steps}
monitor_every = 100
initial = "rest"

[output]
directory = "{out_dir or 'out/' + name}"
fields_every = 0

[coupling]
time_ratio = {a_t}
rigid_steps = 0
{law_line}
[solid]
{solid}

[[sheet]]
{sheet}
theta_deg = 90

[perturbation]
tip_displacement_um = {TIP_UM}{shape}
'''


def read_run(out_dir):
    import h5py
    with h5py.File(os.path.join(out_dir, "solid.h5"), "r") as f:
        t = np.array(f["time_s"])
        w = np.array(f["marked_normal_displacement_um"])[:, 0]
    return t - t[0], w / w[0]


def run_case(scene, out_dir):
    os.makedirs(out_dir, exist_ok=True)
    cmd = ["bash", os.path.join(ROOT, "launch", "run-coupled.sh"), scene, "--output", out_dir,
           "--no-build", "--quiet"]
    with open(os.path.join(out_dir, "launcher.log"), "w") as log:
        return subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT).returncode


def fmt(v, scale=1.0, spec="{:.4g}"):
    return "-" if v is None or not math.isfinite(v) else spec.format(v * scale)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/free_decay")
    ap.add_argument("--cases", default="heavy,paper,lownu")
    ap.add_argument("--resolutions", default="0.5122,0.2561")
    ap.add_argument("--boxes", default="small,large")
    ap.add_argument("--law", default="momentum_exchange")
    ap.add_argument("--aspects", default="7",
                    help="L/b of the sheet, of " + ", ".join(ASPECTS) + " (the same width, mass per "
                         "area and f_vac; longer sheets, stiffer in bending), or strip (a rigid plate "
                         "on a spring spanning a periodic height: L/b infinite)")
    ap.add_argument("--floor", default="wall", choices=["wall", "free_slip"],
                    help="the face the sheet stands on: the no-slip plate of the paper, or a free-slip "
                         "plane (a mirror: no wall under the sheet's root)")
    ap.add_argument("--sides", default="periodic", choices=["periodic", "free_slip", "wall"],
                    help="the two faces normal to the sheet's normal (x): periodic (images of the sheet "
                         "along x; in a box periodic everywhere, the strip's, the fluid as a whole can "
                         "move along x), or free-slip or no-slip walls")
    ap.add_argument("--scene-only", action="store_true")
    ap.add_argument("--table-only", action="store_true")
    ap.add_argument("--sheet-refine", type=int, default=1,
                    help="K: the sheet as 5K x 40K CGPs (the same plate, markers K times closer)")
    ap.add_argument("--t-end-us", type=float,
                    help="run this long after the release instead of the case's default")
    ap.add_argument("--tolerance", default="",
                    help="KEY=REL,... (KEY of t_cross1, t_cross2, undershoot, freq, zeta): exit 1 "
                         "when a run differs from Sader by more than REL (relative) in KEY")
    a = ap.parse_args()
    if not 1 <= a.sheet_refine <= 4:
        ap.error(f"--sheet-refine {a.sheet_refine}: allowed 1 to 4")
    for aspect in a.aspects.split(","):
        if aspect not in ASPECTS and aspect != "strip":
            ap.error(f"--aspects {aspect}: allowed " + ", ".join(ASPECTS) + ", strip")
    for box in a.boxes.split(","):
        if box not in BOXES:
            ap.error(f"--boxes {box}: allowed " + ", ".join(BOXES))
    tolerances = {}
    for item in filter(None, a.tolerance.split(",")):
        k, _, v = item.partition("=")
        if k not in ("t_cross1", "t_cross2", "undershoot", "freq", "zeta") or not v:
            ap.error(f"--tolerance {item}: allowed KEY=REL with KEY one of t_cross1, t_cross2, "
                     "undershoot, freq, zeta")
        tolerances[k] = float(v)
    rows, curves, run_failures = [], [], 0
    for case, dx, box, aspect in [(c, float(d), b, s) for c in a.cases.split(",")
                                  for d in a.resolutions.split(",") for b in a.boxes.split(",")
                                  for s in a.aspects.split(",")]:
        rows_cg = STRIP_CELLS // a.sheet_refine if aspect == "strip" else ASPECTS[aspect][0]
        name = f"free_decay_{case}_dx{str(dx).replace('.', 'p')}_{box}" + (
            "" if a.law == "momentum_exchange" else "_" + a.law) + (
            "" if a.sheet_refine == 1 else f"_sheet{5 * a.sheet_refine}x{rows_cg * a.sheet_refine}") + (
            "" if aspect == "7" else f"_aspect{aspect}") + ("" if a.floor == "wall" else "_freeslip") + (
            "" if a.sides == "periodic" else "_sides" + a.sides.replace("_", ""))
        d = os.path.abspath(os.path.join(a.out, name))
        os.makedirs(d, exist_ok=True)
        scene = os.path.join(d, "scene.toml")
        if not (a.table_only and os.path.exists(scene)):  # else: the scene the run was made with
            with open(scene, "w") as f:
                f.write(scene_text(name, case, dx, box, a.law, os.path.join(d, "run"), a.t_end_us,
                                   a.sheet_refine, aspect, a.floor, a.sides))
        if a.scene_only:
            print(scene)
            continue
        if a.table_only:
            if not os.path.exists(os.path.join(d, "run", "solid.h5")):
                print(f"free_decay_study: {name}: not run yet (no {d}/run/solid.h5); left out")
                continue
        else:
            rc = run_case(scene, os.path.join(d, "run"))
            if rc != 0:
                print(f"free_decay_study: {name}: run-coupled exit {rc} (see {d}/run/)", file=sys.stderr)
                run_failures += 1
                continue
        t, x = read_run(os.path.join(d, "run"))
        beam = sader.scene_beam(scene)
        tr = np.linspace(0.0, t[-1], 600)
        xr = beam.free_decay(tr)
        m, r = sader.decay_measures(t, x), sader.decay_measures(tr, xr)
        where = box if a.sheet_refine == 1 else f"{box}, {5 * a.sheet_refine} x {rows_cg * a.sheet_refine} CGPs"
        where += ("" if aspect == "7" else ", strip (L/b infinite)" if aspect == "strip"
                  else f", L/b {beam.length / beam.b:.1f}") + (
            "" if a.floor == "wall" else ", free-slip floor") + (
            "" if a.sides == "periodic" else f", {a.sides.replace('_', '-')} sides")
        rows.append((case, dx, where, m, r, beam))
        curves.append((name, t, x, tr, xr))
        print(f"{name}: sim {m}; sader {r}", flush=True)
    if a.scene_only or not rows:
        return 1 if run_failures else 0
    write_table(a.out, rows, a.law)
    plot(a.out, curves)
    failed = run_failures
    for case, dx, box, m, r, beam in rows:
        for k, tol in tolerances.items():
            d = rel(m[k], r[k])
            ok = math.isfinite(d) and abs(d) <= tol
            failed += not ok
            print(f"free_decay_study: check {case} dx {dx} {box}: {k} {fmt(d, 100, '{:+.2f}')} % "
                  f"against Sader, tolerance {tol * 100:g} %: {'ok' if ok else 'FAILED'}")
    return 1 if failed else 0


def rel(a, b):
    return (a - b) / b if (math.isfinite(a) and math.isfinite(b) and b != 0) else math.nan


def write_table(out, rows, law):
    lines = [f"Reaction law: {law}. t1, t2: first and second zero crossings after the release (us); "
             "u: undershoot (of the held deflection); f: 1 / (2 (t2 - t1)) (MHz); zeta: damping ratio "
             "from the first undershoot; simulation / Sader, and the relative difference.", "",
             "| case | dx (um) | box | tau | T0 | f_vac (MHz) | t1 | t2 | u | f | zeta |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for case, dx, box, m, r, beam in rows:
        cells = []
        for k, scale in (("t_cross1", 1e6), ("t_cross2", 1e6), ("undershoot", 1.0), ("freq", 1e-6), ("zeta", 1.0)):
            cells.append(f"{fmt(m[k], scale)} / {fmt(r[k], scale)} ({fmt(rel(m[k], r[k]), 100, '{:+.1f}')} %)")
        lines.append(f"| {case} | {dx} | {box} | {beam.tau:.4f} | {beam.T0:.4g} | {beam.f_vac / 1e6:.4g} | "
                     + " | ".join(cells) + " |")
    path = os.path.join(out, "free_decay.md")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"free_decay_study: table {path}")


def plot(out, curves):
    """One panel per case: the runs (solid, one per resolution and box) and Sader (dashed)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    cases = [c for c in CASES if any(name.split("_")[2] == c for name, *_ in curves)]
    fig, axes = plt.subplots(len(cases), 1, figsize=(8, 3.2 * len(cases)), squeeze=False)
    for ax, case in zip(axes[:, 0], cases):
        longest = None
        for k, (name, t, x, tr, xr) in enumerate(c for c in curves if c[0].split("_")[2] == case):
            label = "_".join(name.split("_")[3:]).replace("dx0p", "dx 0.")
            ax.plot(t * 1e6, x, color=f"C{k % 10}", label=label)
            if longest is None or tr[-1] > longest[0][-1]:
                longest = (tr, xr)
        ax.plot(longest[0] * 1e6, longest[1], color="k", ls="--", lw=1.0, label="Sader")
        ax.axhline(0.0, color="k", lw=0.5)
        ax.set_title(f"{case}: marked CGP after the release in still air", fontsize=9)
        ax.set_ylabel("w / w(0)")
        ax.legend(fontsize=7)
    axes[-1, 0].set_xlabel("time after release (us)")
    fig.tight_layout()
    path = os.path.join(out, "free_decay.png")
    fig.savefig(path, dpi=110)
    print(f"free_decay_study: plot {path}")


if __name__ == "__main__":
    sys.exit(main())
