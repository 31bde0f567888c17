#!/usr/bin/python3
"""Error against run time (DESIGN 6): one row per accuracy knob.

    /usr/bin/python3 launch/error_study.py [--short] [--out DIR] [--docs] [--repeats N]
                                           [--threads N] [--only KNOB,KNOB]

(launch/error-study.sh is the command to use: it builds first unless --no-build.)

Each knob is a list of settings. Each setting writes a scene (derived from a file of
scenes/) into OUT/runs/KNOB/SETTING/, runs the executables of ROOT/build on it (the fluid
alone, the solid alone, or both through launch/run-coupled.sh), measures the wall time
(median of --repeats runs of the whole command, start-up included) and the peak memory
(the maximum resident set size: of a single process as GNU time's %M reports it; for a
coupled run VmHWM of the fluid and of the solid process, read from /proc while they run, and the launcher's
ru_maxrss, the largest of all its descendants, as a check), and computes the
error of the run's HDF5 output against the knob's reference (analytic where one exists,
else the finest setting). A setting is on the best error-for-time front when no other
setting of its knob is both faster and more accurate.

Writes OUT/results.tsv (one line per setting), OUT/results.json, OUT/error-vs-runtime.md
(the tables) and OUT/figures/KNOB.png (error against wall time, log-log). Without --short,
or with --docs, also docs/error-vs-runtime.md and docs/figures/error-vs-runtime/KNOB.png.

Exit status: 0 done; 1 a run failed or its output could not be read (one line on stderr
naming the setting and the log); 2 bad arguments or a missing executable.
"""

from __future__ import annotations

import argparse
import datetime
import math
import os
import re
import shutil
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import h5py
import numpy as np

from error_study_cases import (AIR_NU_M2_S, BUILD, COUPLED_BASE_A_T, COUPLED_BASE_RIGID,
                               COUPLED_BASE_STEPS, COUPLED_REFERENCE_UM, COUPLED_REYNOLDS, DOC,
                               DOC_FIGURES, FLUID, H_PAPER_UM, Knob, LATTICE_SPEED_M_S,
                               Measurement, POISEUILLE_HEIGHT_UM, POISEUILLE_T_STAR,
                               POISEUILLE_U_MAX, PoiseuilleCase, ROOT, SOLID, Setting, StudyError,
                               acoustic_tau, coupled_base_scene, coupled_resolution_scene,
                               last_line, marked_displacement, pareto, parse_eigenfrequencies,
                               poiseuille_error, poiseuille_scene, poiseuille_ux, rcgp_scene,
                               run_coupled, run_process, stable_a_t, write_scene)
from error_study_report import (fmt_mib, load_text, machine_text, plot_knob, write_json,
                                write_markdown, write_tsv)


# ---------------------------------------------------------------------------------------
# The study.

@dataclass
class Plan:
    short: bool
    repeats: int
    threads: int
    out: Path


def _repeat(plan: Plan, setting: Setting, fn: Callable[[], tuple[int, float, dict[str, int]]], what: str,
            log: Path) -> None:
    m = Measurement()
    for _ in range(plan.repeats):
        rc, wall, rss = fn()
        if rc != 0:
            raise StudyError(f"{what}: exit {rc}: {last_line(log)} (log {log})")
        m.walls_s.append(wall)
        for k, v in rss.items():
            m.add_rss(k, v)
    setting.measurement = m
    print(f"  {setting.label:<28} wall {m.wall_s:8.2f} s (median of {len(m.walls_s)})  "
          + "  ".join(f"{k} {v / 1024:.1f} MiB" for k, v in m.rss_kib.items()), flush=True)


def knob_fluid_resolution(plan: Plan) -> Knob:
    cells = [8, 16, 32] if plan.short else [8, 16, 32, 64, 128, 256]
    knob = Knob(
        key="resolution_fluid", title="Grid resolution: fluid validation case (Poiseuille start-up)",
        kind="resolution",
        setup=(f"Plane Poiseuille flow started from rest ({'`scenes/poiseuille.toml`'}: 8 x N x 8 cells, "
               "walls at y = -1/2 and N - 1/2 with half-way bounce-back, periodic in x and z), driven by a "
               f"body force G = 8 nu U / N^2 (U = {POISEUILLE_U_MAX} = the steady centre-line speed over c, "
               f"Mach {POISEUILLE_U_MAX * math.sqrt(3):.3f}), compared at the dimensionless time "
               f"t nu / H^2 = {POISEUILLE_T_STAR}, while the profile is still developing. Diffusive scaling: "
               "tau = 0.8 at every N (nu = 0.1 in lattice units), so the time step in units of H^2 / nu falls "
               "as 1/N^2 and the run takes N^2 steps."),
        reference=("Analytic: u(y, t) = G y'(H - y') / (2 nu) - sum over odd n of 4 G H^2 / (nu n^3 pi^3) "
                   "sin(n pi y'/H) exp(-nu n^2 pi^2 t / H^2), y' = y + 1/2, H = N (the series to 1e-18 of the "
                   "steady amplitude). Error: relative L2 norm of u_x - u over all cells of the last step's "
                   "field snapshot."),
        error_name="relative L2 error of u_x", settings=[], memory_columns=["process"], ref_short="analytic",
        extra_columns=[("tau", "tau"), ("steps", "steps"), ("order", "observed order")])
    for n in cells:
        case = PoiseuilleCase(n, 0.8)
        st = Setting(f"N = {n}", n)
        st.extra.update(tau=f"{case.tau:.3f}", steps=str(case.steps))
        out = plan.out / "runs" / knob.key / f"n{n:03d}"
        scene = poiseuille_scene(case, out, f"grid resolution, Poiseuille start-up, N = {n} (diffusive scaling)")
        log = out / "fluid.log"
        _repeat(plan, st, lambda: (lambda r: (r[0], r[1], {"process": r[2]}))(
            run_process([str(FLUID), str(scene), "--quiet", "--threads", str(plan.threads)], log, plan.threads)),
            f"{knob.key} {st.label}", log)
        st.error = poiseuille_error(out, case)
        knob.settings.append(st)
    _orders(knob)
    knob.remarks = lambda k: [_order_remark(k, "second order expected: the wall slip of half-way bounce-back "
                                               "at fixed tau and the time step, O(dt) = O(dx^2) here")]
    return knob


def knob_fluid_acoustic(plan: Plan) -> Knob:
    cells = [8, 16, 32, 64, 128]
    knob = Knob(
        key="resolution_fluid_acoustic",
        title="Grid resolution in the project's own units (Poiseuille, fixed air viscosity): no convergence",
        kind="scaling",
        setup=(f"The same Poiseuille start-up in a channel of fixed physical height ({POISEUILLE_HEIGHT_UM:.4g} um) "
               "refined as the servers refine a physical scene: dt = dx / c with c = sqrt(3) x 331.5 m/s "
               f"(acoustic scaling), the viscosity of air fixed ({AIR_NU_M2_S:g} m^2/s), so "
               "tau = 1/2 + 3 nu / (c dx) grows with N; compared at the same t nu / H^2 and the same U."),
        reference="Analytic, as above.",
        error_name="relative L2 error of u_x", settings=[], memory_columns=["process"], ref_short="analytic",
        extra_columns=[("tau", "tau"), ("steps", "steps"), ("order", "observed order")])
    for n in cells:
        case = PoiseuilleCase(n, acoustic_tau(n))
        st = Setting(f"N = {n}", n)
        st.extra.update(tau=f"{case.tau:.3f}", steps=str(case.steps))
        out = plan.out / "runs" / knob.key / f"n{n:03d}"
        scene = poiseuille_scene(case, out, f"Poiseuille start-up, N = {n}, acoustic scaling (air's viscosity)")
        log = out / "fluid.log"
        _repeat(plan, st, lambda: (lambda r: (r[0], r[1], {"process": r[2]}))(
            run_process([str(FLUID), str(scene), "--quiet", "--threads", str(plan.threads)], log, plan.threads)),
            f"{knob.key} {st.label}", log)
        st.error = poiseuille_error(out, case)
        knob.settings.append(st)
    _orders(knob)
    magic = 0.5 + math.sqrt(3.0 / 16.0)
    knob.remarks = lambda k: [
        "The error stops falling once tau passes the value where half-way bounce-back is exact for BGK "
        f"(tau = 1/2 + sqrt(3/16) = {magic:.3f}, He et al. 1997): the wall slip relative to U is proportional "
        "to (16 (tau - 1/2)^2 - 3) / N^2, and with tau - 1/2 proportional to N it tends to a constant (a "
        "Knudsen-number error, fixed by the physical dx / c and nu). A resolution study of this fluid therefore holds tau "
        "(diffusive scaling, the row above); refining a physical scene at fixed air viscosity converges "
        "only to that floor. This row is not on the resolution test's list."]
    return knob


def _orders(knob: Knob) -> None:
    prev = None
    for st in knob.settings:
        if prev is not None and prev.error and st.error and not st.reference and not prev.reference:
            st.extra["order"] = f"{math.log(prev.error / st.error) / math.log(st.value / prev.value):.2f}"
        prev = st


def _order_remark(knob: Knob, why: str) -> str:
    orders = [st.extra["order"] for st in knob.settings if "order" in st.extra]
    return f"Observed orders between successive settings: {', '.join(orders)} ({why})." if orders else ""


def knob_coupled_resolution(plan: Plan) -> Knob:
    levels = [0, 1, 2] if plan.short else [0, 1, 2, 3]
    dxs = [2.0 * H_PAPER_UM / 2**k for k in levels]
    dt_base = H_PAPER_UM * 1e-6 / LATTICE_SPEED_M_S  # dt_LB at 0.2561 um
    sheets = ", ".join(f"{2 * 2**k + 1} x {5 * 2**k + 1}" for k in levels)
    taus = ", ".join(f"{0.5 + 3 * 0.05 * (COUPLED_REFERENCE_UM / h) / COUPLED_REYNOLDS:.3g}" for h in dxs)
    a_ts = ", ".join(str(COUPLED_BASE_A_T * 2**k // 2) for k in levels)
    steps = ", ".join(str(COUPLED_BASE_STEPS * 2**k // 2) for k in levels)
    t_cmp = (COUPLED_BASE_STEPS // 2 - 1) * 2 * dt_base
    knob = Knob(
        key="resolution_coupled", title="Grid resolution: coupled case (a sheet in channel flow)",
        kind="resolution",
        setup=("`scenes/coupled_small.toml`'s channel (10.24 x 7.68 x 7.68 um: Blasius inlet, outflow, plate, "
               "free-slip top, periodic span) with one sheet at 90 deg, the same physical sheet at every dx: "
               f"CGP spacing dx_CG = dx_LB, the CGPs nested ({sheets} for dx = "
               f"{', '.join(f'{h:.6g}' for h in dxs)} um) so that the marked CGP stays at the same place, 2e6 "
               "atoms per CGP at 0.2561 um scaled with dx^2, RCGP stages fixed at 9 (the same C and D); the "
               f"fluid at Re {COUPLED_REYNOLDS:g} on {COUPLED_REFERENCE_UM:.4g} um (tau = 0.8 at 0.2561 um) and "
               "U/c = 0.05 at every dx, so with dt = dx / c and the air's viscosity fixed, tau - 1/2 doubles "
               f"with each halving of dx ({taus}); A_T doubles too ({a_ts}), keeping dt_CG the same fraction "
               f"of the sheet's stable step (which falls as dx^2). {COUPLED_BASE_RIGID * dt_base * 1e9:.3g} ns "
               f"of rigid spin-up, then the sheet is free; {COUPLED_BASE_STEPS * dt_base * 1e9:.3g} ns in all "
               f"({steps} LB steps). One OpenMP thread per process (the serial scheme runs one side at a "
               "time)."),
        reference=("The finest grid (no analytic solution). Error: |d(T) - d_ref(T)| / |d_ref(T)| of the marked "
                   f"CGP's displacement vector d (middle of the top row) at T = {t_cmp * 1e9:.4g} ns (the "
                   "coarsest grid's last step, the last time every grid writes); also shown: the same over "
                   "every output time of the free phase "
                   "(RMS of |d - d_ref| over RMS |d_ref| on the coarsest grid's times)."),
        error_name="relative error of the marked CGP's displacement at T", settings=[],
        memory_columns=["fluid", "solid"], ref_short="finest grid",
        extra_columns=[("grid", "grid"), ("sheet", "CGPs"), ("tau", "tau"), ("a_t", "A_T"),
                       ("traj", "error over the free phase"), ("order", "observed order")])
    runs = {}
    for level in levels:
        h = 2.0 * H_PAPER_UM / 2**level
        st = Setting(f"dx = {h:.6g} um", 1.0 / h, reference=(level == levels[-1]))
        out = plan.out / "runs" / knob.key / f"dx{level}"
        scene, compared = coupled_resolution_scene(level, out)
        cfg = tomllib.loads(scene.read_text())
        g = cfg["grid"]
        st.extra.update(grid=f"{g['nx']} x {g['ny']} x {g['nz']}",
                        sheet=f"{cfg['sheet'][0]['nx_cg']} x {cfg['sheet'][0]['ny_cg']}",
                        tau=f"{0.5 + 3 * 0.05 * (COUPLED_REFERENCE_UM / h) / COUPLED_REYNOLDS:.2f}",
                        a_t=str(cfg["coupling"]["time_ratio"]))
        _repeat(plan, st, lambda: run_coupled(scene, out, plan.threads), f"{knob.key} {st.label}",
                out / "launcher.log")
        runs[level] = (st, out, compared)
        knob.settings.append(st)
    ref_st, ref_out, ref_step = runs[levels[-1]]
    d_ref, t_ref = marked_displacement(ref_out, ref_step)
    # The free phase on the coarsest grid's output times (steps rigid..last of level 0).
    coarse_steps = range(COUPLED_BASE_RIGID // 2, COUPLED_BASE_STEPS // 2)
    scale_ref = 2**levels[-1]
    with h5py.File(ref_out / "solid.h5", "r") as f:
        ref_traj = f["marked_displacement_um"][[s * scale_ref for s in coarse_steps], 0, :]
    for level in levels[:-1]:
        st, out, step = runs[level]
        d, t = marked_displacement(out, step)
        if abs(t - t_ref) > 1e-6 * t_ref:
            raise StudyError(f"{knob.key}: {out} compares t = {t} s against the reference's {t_ref} s")
        st.error = float(np.linalg.norm(d - d_ref) / np.linalg.norm(d_ref))
        with h5py.File(out / "solid.h5", "r") as f:
            traj = f["marked_displacement_um"][[s * 2**level for s in coarse_steps], 0, :]
        st.extra["traj"] = f"{np.sqrt(np.mean(np.sum((traj - ref_traj) ** 2, axis=1)) / np.mean(np.sum(ref_traj ** 2, axis=1))):.3e}"
    ref_st.extra["traj"] = "reference"
    _orders(knob)
    knob.remarks = lambda k: [
        f"The reference's marked CGP at T: d = ({d_ref[0]:.5f}, {d_ref[1]:.3e}, {d_ref[2]:.1e}) um.",
        _order_remark(k, "against the finest grid, which carries its own error; the fluid's tau changes with dx, "
                         "the immersed boundary's kernel width (2 dx) and the sheet's discretisation too")]
    return knob


def knob_time_ratio(plan: Plan) -> Knob:
    knob = Knob(
        key="time_ratio", title="A_T = dt_LB / dt_CG (the solid's substeps per LB step)", kind="other",
        setup=("`scenes/coupled_small.toml` (40 x 30 x 30 cells, dx = 0.2561 um, a 5 x 10 sheet at 90 deg, "
               "50 rigid + 150 free LB steps, serial scheme) with only `[coupling] time_ratio` changed."),
        reference=("The largest A_T (no analytic solution). Error: |d(T) - d_ref(T)| / |d_ref(T)| of the marked "
                   "CGP's displacement at the last step. The fluid's sample at the CGPs is held over an LB "
                   "interval whatever A_T is, so this row isolates the solid's substepping."),
        error_name="relative error of the marked CGP's displacement", settings=[],
        memory_columns=["fluid", "solid"], ref_short="largest A_T",
        extra_columns=[("dt", "dt_CG / stable step"), ("order", "observed order")])
    probe_dir = plan.out / "runs" / knob.key / "check"
    probe = coupled_base_scene(probe_dir, COUPLED_BASE_A_T, "coupled_at_check", "the stable A_T")
    a_min, stable_text = stable_a_t(probe, probe_dir / "solid_check.log")
    values = [a_min, 150, 600] if plan.short else [a_min, 75, 150, 300, 600, 1200]
    ref_value = 2400 if plan.short else 4800
    values = sorted({v for v in values if v >= a_min}) + [ref_value]
    ratio = float(re.search(r"stable step ([0-9.eE+-]+)", stable_text).group(1))
    dt_lb = float(re.search(r"dt_LB = ([0-9.eE+-]+)", stable_text).group(1))
    runs = []
    for v in values:
        st = Setting(f"A_T = {v}", v, reference=(v == ref_value))
        st.extra["dt"] = f"{dt_lb / v / ratio:.3f}"
        out = plan.out / "runs" / knob.key / f"a{v:05d}"
        scene = coupled_base_scene(out, v, f"coupled_at{v}", f"A_T = {v}")
        _repeat(plan, st, lambda: run_coupled(scene, out, plan.threads), f"{knob.key} {st.label}",
                out / "launcher.log")
        runs.append((st, out))
        knob.settings.append(st)
    d_ref, _ = marked_displacement(runs[-1][1])
    for st, out in runs[:-1]:
        d, _ = marked_displacement(out)
        st.error = float(np.linalg.norm(d - d_ref) / np.linalg.norm(d_ref))
    _orders_inverse(knob)

    # One below the stable limit: the coordinator must refuse it.
    refused = Setting(f"A_T = {a_min - 1}", a_min - 1)
    out = plan.out / "runs" / knob.key / f"a{a_min - 1:05d}"
    scene = coupled_base_scene(out, a_min - 1, f"coupled_at{a_min - 1}", f"A_T = {a_min - 1}, below the stable limit")
    rc, _, _ = run_coupled(scene, out, plan.threads)
    if rc == 0:
        raise StudyError(f"{knob.key}: A_T = {a_min - 1} is below the stable limit ({stable_text}) "
                         f"but the run was not refused ({out})")
    reason = last_line(out / "fluid.log").split("; the largest")[0]
    refused.note = f"refused (exit {rc}): {reason}"
    knob.settings.insert(0, refused)
    knob.remarks = lambda k: [
        f"The sheet's stable step caps A_T from below: {stable_text}, so A_T >= {a_min}; "
        f"A_T = {a_min - 1} is refused at the handshake (the row without a time).",
        _order_remark(k, "against the largest A_T. Velocity Verlet alone is second order in dt_CG, but the "
                         "fluid's reaction on a CGP, -g dA with g = 2 rho (U_B - u), depends on the CGP's "
                         "velocity U_B and is taken with the velocity at the start of each substep "
                         "(`solid/coupling/solid_coupler.hpp`), which is first order")]
    return knob


def _orders_inverse(knob: Knob) -> None:
    """Orders in 1 / A_T (dt_CG): log(e1/e2) / log(A2/A1)."""
    prev = None
    for st in knob.settings:
        if prev is not None and prev.error and st.error and not st.reference:
            st.extra["order"] = f"{math.log(prev.error / st.error) / math.log(st.value / prev.value):.2f}"
        prev = st


TRUNCATION_SUBSTEPS = 20000


def knob_truncation(plan: Plan) -> Knob:
    knob = Knob(
        key="truncation_range", title="RCGP truncation range of the CG kernel", kind="other",
        setup=("The paper's 5 x 40 sheet (`scenes/sheet_free_vibration.toml`: rcgp, released from a 0.5 um "
               f"tip deflection) for {TRUNCATION_SUBSTEPS} substeps of the paper's dt_CG, built with "
               "`[solid] truncation_range` 2 and 3 (the values the construction accepts; range r projects on "
               "a periodic cell of 2 r + 1 CGPs a side) at several `stages` with the paper's flexural scaling "
               "(9 stages: the paper's 0.2561 um). The wall time is the whole run (construction, the sheet's "
               "dense eigenproblem, the substeps)."),
        reference=("The widest range (3) at the same stage count. Error: RMS over the records of |w_2 - w_3| "
                   "over RMS |w_3|, w the marked CGP's displacement (all of `solid.h5`'s records, every 100 "
                   "substeps), i.e. how much the integrated sheet changes with the range. Also shown: f1 of "
                   "the sheet in vacuum as `solid` prints it."),
        error_name="relative difference of the marked CGP's trajectory from range 3", settings=[],
        memory_columns=["process"], extra_columns=[("f", "f1, f2, f3 (Hz)")], rank=False,
        ref_short="range 3")
    stage_counts = [1, 5] if plan.short else [1, 3, 5, 9]
    for stages in stage_counts:
        group = {}
        for rng in (2, 3):
            st = Setting(f"stages {stages}, range {rng}", stages * 10 + rng, reference=(rng == 3))
            out = plan.out / "runs" / knob.key / f"s{stages}_r{rng}"
            scene = rcgp_scene(out, stages, rng, "paper")
            log = out / "solid.log"
            cmd = [str(SOLID), str(scene), "--substeps", str(TRUNCATION_SUBSTEPS), "--quiet"]
            rc, _, _ = run_process([str(SOLID), str(scene), "--check"], log, plan.threads)
            if rc != 0:
                st.note = f"construction fails (exit {rc}): {last_line(log).split(': ', 1)[-1]}"
                st.reference = False
                print(f"  {st.label:<28} {st.note}", flush=True)
                knob.settings.append(st)
                continue
            _repeat(plan, st, lambda: (lambda r: (r[0], r[1], {"process": r[2]}))(
                run_process(cmd, log, plan.threads)), f"{knob.key} {st.label}", log)
            f = parse_eigenfrequencies(log.read_text())
            st.extra["f"] = ", ".join(f"{x:.5g}" for x in f[:3])
            with h5py.File(out / "solid.h5", "r") as h:
                group[rng] = h["marked_displacement_um"][:, 0, :].astype(float)
            knob.settings.append(st)
        if 2 in group and 3 in group:
            w2, w3 = group[2], group[3]
            knob.settings[-2].error = float(np.sqrt(np.mean(np.sum((w2 - w3) ** 2, axis=1))
                                                    / np.mean(np.sum(w3 ** 2, axis=1))))
        elif 2 in group:
            knob.settings[-2].note = "no range 3 to compare with"
    failed = [st for st in knob.settings if st.note.startswith("construction fails")]

    def cost_line(k: Knob) -> str:
        pairs = []
        for stages in stage_counts:
            r2 = next((s for s in k.settings if s.label == f"stages {stages}, range 2" and s.measurement), None)
            r3 = next((s for s in k.settings if s.label == f"stages {stages}, range 3" and s.measurement), None)
            if r2 and r3:
                pairs.append(f"stages {stages}: {r2.measurement.wall_s:.2f} s and {fmt_mib(r2.measurement.rss_kib['process'])} MiB "
                             f"against {r3.measurement.wall_s:.2f} s and {fmt_mib(r3.measurement.rss_kib['process'])} MiB")
        return ("Not ranked: at every stage count range 2 gives the same sheet faster and in less memory "
                "(range 2 against range 3, " + "; ".join(pairs) + "): range 2 is the front.") if pairs else ""

    knob.remarks = lambda k: [cost_line(k),
        "The finite sheet takes only the construction's elastic constants and bending rigidities "
        "(`docs/solid.md` section 3), and moment matching restores exactly those after each truncation, "
        "so the range leaves the integrated sheet the same to the size of the differences above; what it "
        "changes is the CG lattice's own dispersion at finite wavelength (`docs/solid.md` section 2), "
        "which the sheet model does not use. Range 3 costs the construction's time and memory (the "
        "stage-1 cell holds 1568 atoms instead of 800).",
        ("Range 3 does not build " + ", ".join(st.label.split(",")[0].replace("stages ", "") for st in failed)
         + " stages: the construction stops at "
         + ", ".join(sorted({m.group(0) for st in failed for m in [re.search(r"RCGP stage \d+", st.note)] if m}))
         + ", where the moment-matched kernel is not positive (K(q) < 0, the row above); so the paper's "
           "sheet (9 stages) can only be built with range 2.") if failed else ""]
    return knob


def knob_scheme(plan: Plan, schemes: list[tuple[str, dict]]) -> Knob:
    ref_a_t = 2400 if plan.short else 4800
    knob = Knob(
        key="coupling_scheme", title="Coupling scheme", kind="other",
        setup=("`scenes/coupled_small.toml` (A_T = 150) with each scheme the servers offer: `serial`, the paper's "
               "staggered scheme (the solid integrates its A_T substeps with the fluid sampled at the start of the "
               "LB step, the reaction held at each substep's starting velocity), and `implicit` "
               "(`[coupling] scheme = \"implicit\"`, protocol/README.md 13: sub-iterations per LB step with "
               "Aitken relaxation until the sample is the fluid before the step at the markers where that "
               "step's impulses are spread, and the reaction at the end velocity of each substep), and `parallel` "
               "(`[coupling] scheme = \"parallel\"`, protocol/README.md 14: both sides compute the same LB step at "
               "once, the solid's interval driven by the fluid sample of the step before, a one-step lag)."),
        reference=(f"The serial scheme at A_T = {ref_a_t} (no analytic solution). Error: |d - d_ref| / |d_ref| of the "
                   "marked CGP's displacement at the last step."),
        error_name="relative error of the marked CGP's displacement", settings=[],
        memory_columns=["fluid", "solid"], rank=len(schemes) > 1, ref_short=f"serial, A_T = {ref_a_t}")
    runs = []
    for name, patch, a_t, is_ref in [(n, p, COUPLED_BASE_A_T, False) for n, p in schemes] + [
            ("serial_reference", {}, ref_a_t, True)]:
        st = Setting(name if not is_ref else f"serial, A_T = {ref_a_t}", len(knob.settings), reference=is_ref)
        out = plan.out / "runs" / knob.key / name
        scene = coupled_base_scene(out, a_t, f"coupled_{name}", f"coupling scheme {name}, A_T = {a_t}")
        if patch:
            cfg = tomllib.loads(scene.read_text())
            for table, keys in patch.items():
                cfg.setdefault(table, {}).update(keys)
            write_scene(scene, cfg, f"error study: coupling scheme {name}")
        _repeat(plan, st, lambda: run_coupled(scene, out, plan.threads), f"{knob.key} {st.label}",
                out / "launcher.log")
        iterations = re.search(r"implicit scheme: .*?([0-9.]+) iterations a step on average",
                               (out / "solid.log").read_text() if (out / "solid.log").exists() else "")
        if iterations:
            st.note = f"{iterations.group(1)} sub-iterations a step on average"
        runs.append((st, out))
        knob.settings.append(st)
    d_ref, _ = marked_displacement(runs[-1][1])
    for st, out in runs[:-1]:
        d, _ = marked_displacement(out)
        st.error = float(np.linalg.norm(d - d_ref) / np.linalg.norm(d_ref))
    return knob


def population_mib(log: Path) -> str:
    """The population memory the fluid's header reports ("memory   X MiB of populations")."""
    m = re.search(r"memory\s+([0-9.]+) MiB of populations", log.read_text(errors="replace"))
    return m.group(1) if m else "?"


# The fluid's precision modes ([run] precision), the reference first.
PRECISION_MODES = ("double", "mixed", "single", "half")


def knob_precision(plan: Plan) -> Knob:
    sizes = [32] if plan.short else [32, 64]
    knob = Knob(
        key="precision", title="Floating-point precision of the fluid's population store", kind="other",
        setup=("The fluid's precision modes (`[run] precision`, issue 35): \"double\" (the default), \"mixed\" "
               "(32-bit float storage, the arithmetic double; called \"single\" before issue 35), \"single\" "
               "(float storage and float arithmetic) and \"half\" (16-bit storage of f_q - w_q, FP16S, float "
               "arithmetic); the solid is double only. The case is "
               "the Poiseuille start-up of the resolution row (tau = 0.8, U = "
               f"{POISEUILLE_U_MAX}, compared at t nu / H^2 = {POISEUILLE_T_STAR}) on an N x N x N box (x and z "
               "periodic, so the flow is the same as on 8 x N x 8; the larger grid makes the population memory "
               "visible in the peak RSS). Each N is run in every mode."),
        reference=("Analytic, as the resolution row (relative L2 error of u_x over all cells). The column "
                   "\"vs double\" is the relative L2 difference of u_x between a float mode's run and the double run "
                   "of the same N: the round-off that its store and arithmetic add (`SinglePrecisionWithinTolerance` "
                   "bounds mixed's by (steps + 1) 2^-24 (1/3 + 2 U) per velocity component; "
                   "`FloatArithmeticWithinTolerance` and `HalfStoreWithinTolerance` hold single's and half's to "
                   "their measured tolerances)."),
        error_name="relative L2 error of u_x", settings=[], memory_columns=["process"], ref_short="analytic",
        extra_columns=[("steps", "steps"), ("populations", "populations MiB"), ("vs_double", "vs double")])
    for n in sizes:
        case = PoiseuilleCase(n, 0.8)
        runs: dict[str, Path] = {}
        for i, precision in enumerate(PRECISION_MODES):
            st = Setting(f"{precision}, N = {n}", n + 0.25 * i)
            out = plan.out / "runs" / knob.key / f"{precision}_n{n:03d}"
            scene = poiseuille_scene(case, out, f"precision {precision}, Poiseuille start-up on {n}^3",
                                     width=n, precision=precision)
            log = out / "fluid.log"
            _repeat(plan, st, lambda: (lambda r: (r[0], r[1], {"process": r[2]}))(
                run_process([str(FLUID), str(scene), "--quiet", "--threads", str(plan.threads)], log,
                            plan.threads)), f"{knob.key} {st.label}", log)
            st.error = poiseuille_error(out, case)
            st.extra.update(steps=str(case.steps), populations=population_mib(log))
            runs[precision] = out
            knob.settings.append(st)
        u_d = poiseuille_ux(runs["double"], case)
        knob.settings[-len(PRECISION_MODES)].extra["vs_double"] = "-"
        for k, mode in enumerate(PRECISION_MODES[1:], start=1 - len(PRECISION_MODES)):
            u_s = poiseuille_ux(runs[mode], case)
            knob.settings[k].extra["vs_double"] = f"{float(np.sqrt(np.mean((u_s - u_d) ** 2) / np.mean(u_d ** 2))):.2e}"
    def remarks(k: Knob) -> list[str]:
        m = len(PRECISION_MODES)
        groups = [k.settings[i:i + m] for i in range(0, len(k.settings) - m + 1, m)]
        times = "; ".join(f"N = {int(g[0].value)}: " + ", ".join(
                              f"{mode} {s.measurement.wall_s / g[0].measurement.wall_s:.2f}"
                              for mode, s in zip(PRECISION_MODES[1:], g[1:]))
                          for g in groups if all(s.measurement for s in g))
        return [
            "The mixed mode rounds every population to float once per step (unit round-off 2^-24 = 6e-8); the "
            "single mode also computes the collision in float. \"vs double\" is their difference from the double "
            "run, to be read against the scheme's own error against the analytic solution (measured in issue 35: "
            "mixed stays far below it; single's float arithmetic raised the N = 64 error from 1.2e-4 to 2.1e-4). "
            "The half mode rounds every stored f_q - w_q to 11 significant bits per step (FP16S, "
            "fluid/lattice/half.hpp). Mixed and single halve the population memory, half quarters it "
            "(\"populations MiB\"; the peak RSS also holds the process, its "
            "libraries, the output buffers and the macroscopic fields). "
            f"Wall time of each float mode's run over the double run's: {times} (one thread; the whole command, "
            "start-up and output included; the kernel's own speed in each mode: `docs/performance.md`)."]
    knob.remarks = remarks
    return knob


# Coupling schemes the servers offer: (name, scene keys that select it).
SCHEMES: list[tuple[str, dict]] = [("serial", {}), ("implicit", {"coupling": {"scheme": "implicit"}}),
                                  ("parallel", {"coupling": {"scheme": "parallel"}})]



# ---------------------------------------------------------------------------------------

def build_type() -> str:
    try:
        m = re.search(r"^CMAKE_BUILD_TYPE:\w+=(.*)$", (BUILD / "CMakeCache.txt").read_text(), re.M)
        return m.group(1) or "default flags" if m else "?"
    except OSError:
        return "?"


KNOBS = ["resolution_fluid", "resolution_fluid_acoustic", "resolution_coupled", "time_ratio",
         "truncation_range", "coupling_scheme", "precision"]


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description="error against run time, one row per accuracy knob (DESIGN 6)")
    ap.add_argument("--short", action="store_true", help="fewer and cheaper settings, 1 repeat (about 2 min)")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "error-study", help="output folder")
    ap.add_argument("--docs", action="store_true", help="also write docs/ with --short")
    ap.add_argument("--repeats", type=int, help="runs per setting (default 3, 1 with --short)")
    ap.add_argument("--threads", type=int, default=1, help="OpenMP threads per process (default 1)")
    ap.add_argument("--only", help="comma-separated knobs (" + ", ".join(KNOBS) + ")")
    args = ap.parse_args(argv)
    repeats = args.repeats if args.repeats is not None else (1 if args.short else 3)
    if repeats < 1 or args.threads < 1:
        ap.error("--repeats and --threads must be at least 1")
    only = KNOBS if not args.only else [k.strip() for k in args.only.split(",")]
    for k in only:
        if k not in KNOBS:
            ap.error(f"--only {k}: unknown knob (allowed: {', '.join(KNOBS)})")
    for exe in (FLUID, SOLID):
        if not os.access(exe, os.X_OK):
            print(f"error_study: {exe} missing: build first (launch/build.sh)", file=sys.stderr)
            return 2
    out = args.out.resolve()
    if out.exists():
        shutil.rmtree(out / "runs", ignore_errors=True)
        shutil.rmtree(out / "figures", ignore_errors=True)
    out.mkdir(parents=True, exist_ok=True)
    plan = Plan(args.short, repeats, args.threads, out)
    command = "bash launch/error-study.sh" + (" --short" if args.short else "")
    meta = {"command": command, "date": datetime.datetime.now().astimezone().strftime("%Y-%m-%d %H:%M %Z"),
            "machine": machine_text(), "load_start": load_text(), "threads": args.threads, "repeats": repeats,
            "build_type": build_type(), "short": args.short,
            "out": os.path.relpath(out, ROOT) if out.is_relative_to(ROOT) else str(out)}
    t0 = time.perf_counter()
    knobs: list[Knob] = []
    try:
        for number, key in enumerate(only, 1):
            print(f"{key} (knob {number} of {len(only)}):", flush=True)
            os.environ["COSIM_RUN_LABEL"] = f"knob {number} of {len(only)} {key}"
            if key == "resolution_fluid":
                knobs.append(knob_fluid_resolution(plan))
            elif key == "resolution_fluid_acoustic":
                if args.short:
                    print("  (full study only)", flush=True)
                    continue
                knobs.append(knob_fluid_acoustic(plan))
            elif key == "resolution_coupled":
                knobs.append(knob_coupled_resolution(plan))
            elif key == "time_ratio":
                knobs.append(knob_time_ratio(plan))
            elif key == "truncation_range":
                knobs.append(knob_truncation(plan))
            elif key == "coupling_scheme":
                knobs.append(knob_scheme(plan, SCHEMES))
            elif key == "precision":
                knobs.append(knob_precision(plan))
            for st in knobs[-1].settings if knobs else []:
                if st.error is not None:
                    print(f"    {st.label:<26} error {st.error:.3e}", flush=True)
    except StudyError as e:
        print(f"error_study: {e}", file=sys.stderr)
        return 1
    except (OSError, KeyError, ValueError) as e:
        print(f"error_study: {type(e).__name__}: {e}", file=sys.stderr)
        return 1
    for k in knobs:
        if k.rank:
            pareto(k.settings)
    meta["load_end"] = load_text()
    meta["elapsed_s"] = time.perf_counter() - t0
    figures = out / "figures"
    for k in knobs:
        plot_knob(k, figures / f"{k.key}.png")
    write_tsv(knobs, out / "results.tsv")
    write_json(knobs, meta, out / "results.json")
    write_markdown(knobs, meta, out / "error-vs-runtime.md", figures, "figures/")
    print(f"error_study: {len(knobs)} knobs in {meta['elapsed_s']:.0f} s; tables in {out / 'error-vs-runtime.md'}")
    if not args.short or args.docs:
        DOC_FIGURES.mkdir(parents=True, exist_ok=True)
        for old in DOC_FIGURES.glob("*.png"):
            old.unlink()
        for png in figures.glob("*.png"):
            shutil.copy2(png, DOC_FIGURES / png.name)
        write_markdown(knobs, meta, DOC, DOC_FIGURES, "figures/error-vs-runtime/")
        print(f"error_study: wrote {DOC.relative_to(ROOT)} and {DOC_FIGURES.relative_to(ROOT)}/")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
