#!/usr/bin/env python3
"""Flapping flag: a thin elastic sheet in a uniform stream (issue 16, item 4).

The 2D flexible filament of Huang, Shin & Sung, J. Comput. Phys. 226 (2007) 2206-2228, run as a
span-periodic sheet: the leading edge (the sheet's bottom CGP row, clamped) sits in the middle of
a uniform stream along +y, the sheet lies in the y-z plane (normal x, theta 90 deg) and spans the
periodic z axis of the box (nx_cg CGPs of spacing dx across nz = nx_cg cells), so that it is one
period of an infinitely wide flag, a filament in 2D. The nondimensional numbers, with L the free
length, U the stream speed, rho the air's density, mu the sheet's mass per area and D its bending
rigidity per unit width (the corotational model, `flexural_scaling = "physical"`: D = graphene's
kappa, read from `solid SCENE --check`):

  Re    = U L / nu                 (200)
  M     = mu / (rho L)             (mass ratio, 1.5)
  gamma = D / (rho U^2 L^3)        (bending rigidity, 0.001)
  Fr    = g L / U^2                (Froude number, gravity along the stream; 0: none)

--froude F applies g = F U^2 / L along the stream (+y) as a body force m g on every CGP
([solid] gravity_m_s2), as the public implementations of Huang, Shin & Sung's filament apply
their Fr (an acceleration Fr U^2 / L on the filament's mass); --leading-edge pinned holds the
bottom row but leaves the sheet free to rotate about it ([[sheet]] leading_edge = "pinned", a
simply supported edge; "clamped", the default, also fixes the slope).

The solid's D and the air's rho are fixed, so a resolution N (cells along L) with a lattice stream
speed u = U / c fixes dx (gamma), tau (Re) and the CGP mass (M). Measured: the trailing edge's
transverse displacement (the marked CGP, middle of the top row, x component of
marked_displacement_um in solid.h5) over the last part of the run: the peak-to-peak amplitude
A / L and the Strouhal number St = f L / U (f from the zero crossings of x - mean).

  python3 launch/flapping_flag_study.py [--out out/flapping_flag] [--resolutions 16,24,32]
      [--u 0.1] [--length-times 60] [--measure-from 0.5] [--re 200] [--mass-ratio 1.5]
      [--gamma 0.001] [--froude 0] [--leading-edge clamped|pinned]
      [--st-band LO,HI] [--amp-band LO,HI] [--scene-only] [--table-only]
      [--print-scene N]

--st-band LO,HI: exit 1 unless every run flaps (A / L >= 0.05) with St in [LO, HI];
--amp-band LO,HI: exit 1 unless every run's A / L lies in [LO, HI]. --table-only makes the
table and the plot from the runs already in OUT (none is run); --print-scene N prints the
scene of N cells along L (scenes/flapping_flag.toml is N = 16).
Writes OUT/flag_N<N>/{scene.toml, run/}, OUT/flapping_flag.md (the table) and
OUT/flapping_flag.png (the trailing edge against time). Runs go through
launch/run-coupled.sh --no-build (build first: bash launch/build.sh).
"""
import argparse
import math
import os
import re
import subprocess
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from build_dir import build_dir  # noqa: E402
from sader import CARBON_KG, RHO_AIR, ROOT, SOUND_SPEED  # noqa: E402  (Table 1's air, one C atom)

C_LATTICE = math.sqrt(3.0) * SOUND_SPEED  # c = dx / dt_LB
KAPPA_J = 3.72e-19                       # D of the corotational model, "physical" (solid --check):
#   sets dx; the gamma each scene reaches is computed again from its own solid --check

# The configuration: Re, mass ratio and bending rigidity of Huang, Shin & Sung's flapping
# filament as public implementations of it set them (docs/validation.md, "The flapping flag",
# says where they come from); --re, --mass-ratio, --gamma change them. Their Froude number
# (gravity along the stream) and pinned leading edge: --froude, --leading-edge (defaults: Fr 0,
# clamped, the study's first configuration).
RE, MASS_RATIO, GAMMA = 200.0, 1.5, 0.001
FROUDE, LEADING_EDGE = 0.0, "clamped"
SPAN_CELLS = 8                           # nz: the smallest box the fluid takes
# The flow round the flapping trailing edge reaches about twice U (Mach 2 sqrt(3) u = 0.35 at
# u = 0.1): the health limit is raised from 0.3 to this (run.mach_limit allows 0.5).
MACH_LIMIT = 0.45
TIP_FRACTION = 0.03                      # seed: trailing-edge deflection, of L (a larger one
#   stretches the inextensible sheet: its membrane energy, released, outruns the watchdog)


def geometry(n, u):
    """Lengths of the case with N cells along the free length L = (N + 1/2) dx (the top CGP
    covers half a spacing beyond its row, as the solid's report counts the free height)."""
    l_cells = n + 0.5
    dx = (KAPPA_J / (GAMMA * RHO_AIR * (u * C_LATTICE) ** 2 * l_cells ** 3)) ** (1.0 / 3.0)
    return l_cells, dx


def case_numbers(n, u, length_times):
    l_cells, dx = geometry(n, u)
    nu_lattice = u * l_cells / RE
    tau = 0.5 + 3.0 * nu_lattice
    length = l_cells * dx
    cgp_kg = MASS_RATIO * RHO_AIR * length * dx * dx
    convective = l_cells / u                       # L / U in LB steps
    return dict(n=n, u=u, l_cells=l_cells, dx=dx, tau=tau, length=length, cgp_kg=cgp_kg,
                atoms=cgp_kg / CARBON_KG, convective=convective,
                steps=int(math.ceil(length_times * convective)),
                rigid=int(math.ceil(1.0 * convective)),
                nx=int(round(4 * l_cells)), ny=int(round(5 * l_cells)), nz=SPAN_CELLS)


def configuration_text():
    """The study's options that change the scene, for its comments and --print-scene."""
    extra = f" --froude {FROUDE:g}" if FROUDE else ""
    extra += " --leading-edge pinned" if LEADING_EDGE == "pinned" else ""
    return f"--re {RE:g} --mass-ratio {MASS_RATIO:g} --gamma {GAMMA:g}{extra}"


def gravity_m_s2(c):
    """g along the stream (+y) for the Froude number: Fr U^2 / L, m/s^2."""
    return FROUDE * (c["u"] * C_LATTICE) ** 2 / c["length"]


def scene_text(name, c, out_dir, time_ratio):
    dx_um = c["dx"] * 1e6
    y0 = 1.0 * c["l_cells"] * dx_um                # leading edge one L downstream of the inlet
    gravity = f"gravity_m_s2 = [0, {gravity_m_s2(c):.6g}, 0]   # Fr {FROUDE:g} along the stream\n" if FROUDE else ""
    edge = 'leading_edge = "pinned"\n' if LEADING_EDGE == "pinned" else ""
    return f'''# Flapping flag (launch/flapping_flag_study.py, issue 16): the filament of Huang, Shin & Sung,
# J. Comput. Phys. 226 (2007) 2206, as a span-periodic sheet; Re {RE:g}, mass ratio {MASS_RATIO:g},
# bending rigidity {GAMMA:g}, Froude number {FROUDE:g}, {LEADING_EDGE} leading edge; {c["n"]} cells
# along L. Generated by the study; regenerate with
#   python3 launch/flapping_flag_study.py {configuration_text()} --print-scene {c["n"]}
[scene]
name = "{name}"
description = "flapping flag, Re {RE:g}, M {MASS_RATIO:g}, gamma {GAMMA:g}, Fr {FROUDE:g}, {LEADING_EDGE}, L = {c["l_cells"]:g} dx"

[grid]
nx = {c["nx"]}
ny = {c["ny"]}
nz = {c["nz"]}
dx_um = {dx_um:.6g}

[fluid]
tau = {c["tau"]:.6f}

[boundaries]
x_min = "free_slip"
x_max = "free_slip"
y_min = "inlet"
y_max = "outflow"
z_min = "periodic"
z_max = "periodic"

[inlet]
u_max = {c["u"]:g}
profile = "uniform"

[run]
steps = {c["steps"]}
monitor_every = 500
initial = "inlet"
mach_limit = {MACH_LIMIT:g}

[output]
directory = "{out_dir}"

[coupling]
time_ratio = {time_ratio}
rigid_steps = {c["rigid"]}

[solid]
model = "corotational"
flexural_scaling = "physical"
{gravity}
[[sheet]]
nx_cg = {c["nz"]}
ny_cg = {c["n"] + 1}
spacing_um = {dx_um:.6g}
atoms_per_cgp = {c["atoms"]:.6g}
base_um = [{c["nx"] * dx_um / 2:.6g}, {y0:.6g}, {c["nz"] * dx_um / 2:.6g}]
theta_deg = 90
clamped_rows = 1
{edge}
[perturbation]
tip_displacement_um = {TIP_FRACTION * c["length"] * 1e6:.6g}
'''


def solid_check(scene):
    """The solid's own report of the scene: D (J) and its stable step (s)."""
    r = subprocess.run([str(build_dir(ROOT) / "solid" / "solid"), scene, "--check", "--token",
                        "0123456789abcdef"], capture_output=True, text=True)
    text = r.stdout + r.stderr
    d = re.search(r"bending rigidity: D = ([0-9.eE+-]+) J", text)
    s = re.search(r"stable dt_CG[^:]*: ([0-9.eE+-]+) s", text)
    return (float(d.group(1)) if d else math.nan, float(s.group(1)) if s else math.nan, text)


def write_scene(name, c, scene, out_dir):
    dt_lb = c["dx"] / C_LATTICE
    with open(scene, "w") as f:   # a first A_T to learn the model's stable step
        f.write(scene_text(name, c, out_dir, 1000))
    d, stable, text = solid_check(scene)
    if not math.isfinite(stable):
        raise SystemExit(f"flapping_flag_study: solid --check {scene} failed:\n{text}")
    time_ratio = int(math.ceil(dt_lb / (0.5 * stable)))  # dt_CG half the stable step
    with open(scene, "w") as f:
        f.write(scene_text(name, c, out_dir, time_ratio))
    return d


def measure(out_dir, c, measure_from):
    """A / L (peak to peak) and St = f L / U of the trailing edge from measure_from of the run on."""
    import h5py
    with h5py.File(os.path.join(out_dir, "solid.h5"), "r") as f:
        step = np.array(f["step"], dtype=float)
        x = np.array(f["marked_displacement_um"])[:, 0, 0] * 1e-6
    x_all = x
    keep = step >= measure_from * step[-1]
    s, x = step[keep], x[keep]
    length = c["length"]
    res = dict(t=step / c["convective"], x=x_all / length, st=math.nan, periods=0,
               amp=(x.max() - x.min()) / length if x.size else math.nan)
    y = x - x.mean()
    up = [s[i] + (s[i + 1] - s[i]) * (-y[i]) / (y[i + 1] - y[i])
          for i in range(len(y) - 1) if y[i] < 0.0 <= y[i + 1]]
    if len(up) >= 3:
        period_steps = (up[-1] - up[0]) / (len(up) - 1)
        res["st"] = c["l_cells"] / (c["u"] * period_steps)   # f L / U in lattice units
        res["periods"] = len(up) - 1
    return res


def plot(out, rows, measure_from):
    """The trailing edge's transverse displacement over L against time in L / U, one curve per
    resolution; the measured window shaded."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(8, 3.2))
    for k, (c, gamma, m) in enumerate(rows):
        ax.plot(m["t"], m["x"], color=f"C{k % 10}", lw=0.8,
                label=f"{c['l_cells']:g} dx along L: A/L {m['amp']:.3f}, St {m['st']:.3f}")
    t_end = max(m["t"][-1] for _, _, m in rows)
    ax.axvspan(measure_from * t_end, t_end, color="0.9", zorder=0)
    ax.set_xlabel("t U / L")
    ax.set_ylabel("trailing edge x / L")
    ax.set_title(f"flapping flag: Re {RE:g}, mass ratio {MASS_RATIO:g}, bending rigidity {GAMMA:g}, "
                 f"Fr {FROUDE:g}, {LEADING_EDGE} leading edge", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    path = os.path.join(out, "flapping_flag.png")
    fig.savefig(path, dpi=110)
    print(f"flapping_flag_study: plot {path}")


def run_case(scene, out_dir):
    cmd = ["bash", os.path.join(ROOT, "launch", "run-coupled.sh"), scene, "--output", out_dir,
           "--no-build", "--quiet"]
    os.makedirs(os.path.dirname(out_dir), exist_ok=True)
    with open(out_dir + ".launcher.log", "w") as log:
        return subprocess.run(cmd, stdout=log, stderr=subprocess.STDOUT).returncode


def main():
    global RE, MASS_RATIO, GAMMA, FROUDE, LEADING_EDGE
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--out", default="out/flapping_flag")
    ap.add_argument("--resolutions", default="16,24,32", help="cells along L, comma-separated")
    ap.add_argument("--u", type=float, default=0.1, help="stream speed U / c (lattice)")
    ap.add_argument("--length-times", type=float, default=60.0,
                    help="run length in convective times L / U, spin-up included")
    ap.add_argument("--measure-from", type=float, default=0.5,
                    help="measure over the run from this fraction of its steps on")
    ap.add_argument("--st-band", default="", help="LO,HI: exit 1 unless each run flaps with St in it")
    ap.add_argument("--amp-band", default="", help="LO,HI: exit 1 unless each run's A / L lies in it")
    ap.add_argument("--scene-only", action="store_true")
    ap.add_argument("--table-only", action="store_true")
    ap.add_argument("--print-scene", type=int, help="print the scene for N cells along L and exit")
    ap.add_argument("--re", type=float, default=RE, help="Reynolds number U L / nu")
    ap.add_argument("--mass-ratio", type=float, default=MASS_RATIO, help="mu / (rho L)")
    ap.add_argument("--gamma", type=float, default=GAMMA, help="bending rigidity D / (rho U^2 L^3)")
    ap.add_argument("--froude", type=float, default=FROUDE, help="g L / U^2, gravity along the stream")
    ap.add_argument("--leading-edge", default=LEADING_EDGE, help="clamped or pinned")
    a = ap.parse_args()
    if not (a.froude >= 0.0 and math.isfinite(a.froude)):
        ap.error(f"--froude {a.froude}: allowed a finite number >= 0 (gravity along the stream)")
    if a.leading_edge not in ("clamped", "pinned"):
        ap.error(f"--leading-edge {a.leading_edge}: allowed clamped or pinned")
    FROUDE, LEADING_EDGE = a.froude, a.leading_edge
    for key, v in (("--re", a.re), ("--mass-ratio", a.mass_ratio), ("--gamma", a.gamma)):
        if not (v > 0.0 and math.isfinite(v)):
            ap.error(f"{key} {v}: allowed a positive finite number")
    RE, MASS_RATIO, GAMMA = a.re, a.mass_ratio, a.gamma
    if not 0.0 < a.u <= 0.15:
        ap.error(f"--u {a.u}: allowed (0, 0.15] (lattice Mach sqrt(3) u, below 0.26)")
    if not 0.0 <= a.measure_from < 1.0:
        ap.error(f"--measure-from {a.measure_from}: allowed [0, 1)")
    def parse_band(key, text):
        if not text:
            return None
        try:
            b = [float(v) for v in text.split(",")]
            assert len(b) == 2 and 0.0 <= b[0] < b[1]
            return b
        except (ValueError, AssertionError):
            ap.error(f"{key} {text}: allowed LO,HI with 0 <= LO < HI")
    band, amp_band = parse_band("--st-band", a.st_band), parse_band("--amp-band", a.amp_band)
    if a.print_scene:
        c = case_numbers(a.print_scene, a.u, a.length_times)
        name = f"flapping_flag_N{a.print_scene}"
        path = os.path.join("/tmp", f"{name}.{os.getpid()}.toml")
        write_scene(name, c, path, f"out/{name}")
        with open(path) as f:
            sys.stdout.write(f.read())
        os.remove(path)
        return 0
    rows, failures = [], 0
    for n in [int(v) for v in a.resolutions.split(",")]:
        if n < 8:
            ap.error(f"--resolutions {n}: allowed at least 8 cells along L")
        c = case_numbers(n, a.u, a.length_times)
        name = f"flag_N{n}"
        d = os.path.abspath(os.path.join(a.out, name))
        os.makedirs(d, exist_ok=True)
        scene, run_dir = os.path.join(d, "scene.toml"), os.path.join(d, "run")
        if not (a.table_only and os.path.exists(scene)):
            kappa = write_scene(name, c, scene, run_dir)
        else:
            kappa = solid_check(scene)[0]
        gamma = kappa / (RHO_AIR * (c["u"] * C_LATTICE) ** 2 * c["length"] ** 3)
        print(f"{name}: dx {c['dx'] * 1e6:.5g} um, L {c['length'] * 1e6:.4g} um = {c['l_cells']:g} dx, "
              f"tau {c['tau']:.4f}, u {c['u']:g}, Re {c['u'] * c['l_cells'] / ((c['tau'] - 0.5) / 3):.4g}, "
              f"gamma {gamma:.4g} (D {kappa:.4g} J), M {MASS_RATIO:g}, {c['steps']} steps "
              f"({a.length_times:g} L/U), grid {c['nx']} x {c['ny']} x {c['nz']}", flush=True)
        if a.scene_only:
            print(scene)
            continue
        if not a.table_only:
            rc = run_case(scene, run_dir)
            if rc != 0:
                print(f"flapping_flag_study: {name}: run-coupled exit {rc} (see {run_dir}.launcher.log)",
                      file=sys.stderr)
                failures += 1
                continue
        if not os.path.exists(os.path.join(run_dir, "solid.h5")):
            print(f"flapping_flag_study: {name}: not run yet (no {run_dir}/solid.h5); left out")
            continue
        m = measure(run_dir, c, a.measure_from)
        rows.append((c, gamma, m))
        print(f"{name}: A/L {m['amp']:.4g}, St {m['st']:.4g} over {m['periods']} periods", flush=True)
    if a.scene_only or not rows:
        return 1 if failures else 0
    lines = [f"Trailing-edge transverse displacement from {a.measure_from:g} of each run on "
             f"({a.length_times:g} L/U in all): A / L peak to peak, St = f L / U.", "",
             "| L / dx | dx (um) | tau | Re | gamma | M | Fr | leading edge | periods | A / L | St |",
             "| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |"]
    for c, gamma, m in rows:
        lines.append(f"| {c['l_cells']:g} | {c['dx'] * 1e6:.4g} | {c['tau']:.4f} | {RE:g} | {gamma:.4g} | "
                     f"{MASS_RATIO:g} | {FROUDE:g} | {LEADING_EDGE} | {m['periods']} | {m['amp']:.3f} | "
                     f"{m['st']:.4f} |")
    path = os.path.join(a.out, "flapping_flag.md")
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"flapping_flag_study: table {path}")
    plot(a.out, rows, a.measure_from)
    for c, gamma, m in rows:
        if band:
            ok = m["amp"] >= 0.05 and band[0] <= m["st"] <= band[1]
            failures += not ok
            print(f"flapping_flag_study: check N {c['n']}: A/L {m['amp']:.3f} (flaps: >= 0.05), "
                  f"St {m['st']:.4f} in [{band[0]:g}, {band[1]:g}]: {'ok' if ok else 'FAILED'}")
        if amp_band:
            ok = amp_band[0] <= m["amp"] <= amp_band[1]
            failures += not ok
            print(f"flapping_flag_study: check N {c['n']}: A/L {m['amp']:.4f} in "
                  f"[{amp_band[0]:g}, {amp_band[1]:g}]: {'ok' if ok else 'FAILED'}")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
