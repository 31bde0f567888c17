#!/usr/bin/python3
"""The error study's cases and runners (launch/error_study.py): scenes written from
scenes/ files, the processes run and timed with their peak memory, the settings and knobs, and the
cases with their references (Poiseuille start-up, the coupled sheet, the RCGP sheet)."""

from __future__ import annotations

import json
import math
import os
import re
import shutil
import statistics
import subprocess
import threading
import time
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import h5py
import numpy as np

from build_dir import build_dir

ROOT = Path(__file__).resolve().parent.parent
BUILD = build_dir(ROOT)
FLUID = BUILD / "fluid" / "fluid"
SOLID = BUILD / "solid" / "solid"
COUPLED = ROOT / "launch" / "run-coupled.sh"
DOC = ROOT / "docs" / "error-vs-runtime.md"
DOC_FIGURES = ROOT / "docs" / "figures" / "error-vs-runtime"

H_PAPER_UM = 0.2561  # Table 1's dx_LB = dx_CG


class StudyError(Exception):
    """A run failed or its output is not what was expected: one line for stderr."""


# ---------------------------------------------------------------------------------------
# Scenes: read a file of scenes/ with tomllib, change keys, write TOML back.

def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if not math.isfinite(v):
            raise ValueError(f"not a finite number: {v}")
        return repr(v)
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string for the characters used here
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    raise TypeError(f"cannot write {type(v).__name__} to TOML")


def toml_dumps(scene: dict) -> str:
    """Tables of scalars and arrays, and arrays of tables ([[sheet]]): what scenes use."""
    out = []
    for name, body in scene.items():
        if isinstance(body, list) and body and all(isinstance(t, dict) for t in body):
            for t in body:
                out.append(f"[[{name}]]")
                out.extend(f"{k} = {_toml_value(v)}" for k, v in t.items())
                out.append("")
        elif isinstance(body, dict):
            out.append(f"[{name}]")
            out.extend(f"{k} = {_toml_value(v)}" for k, v in body.items())
            out.append("")
        else:
            raise TypeError(f"top-level key {name} is not a table")
    return "\n".join(out)


def load_scene(name: str) -> dict:
    with open(ROOT / "scenes" / name, "rb") as f:
        return tomllib.load(f)


def write_scene(path: Path, scene: dict, comment: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    text = "".join(f"# {line}\n" for line in comment.splitlines()) + "\n" + toml_dumps(scene)
    path.write_text(text)
    return path


# ---------------------------------------------------------------------------------------
# Running and measuring.

@dataclass
class Measurement:
    walls_s: list[float] = field(default_factory=list)
    rss_kib: dict[str, int] = field(default_factory=dict)  # "process" or "fluid", "solid", "launcher"

    @property
    def wall_s(self) -> float:
        return statistics.median(self.walls_s)

    def add_rss(self, key: str, kib: int) -> None:
        self.rss_kib[key] = max(self.rss_kib.get(key, 0), int(kib))


def _env(threads: int) -> dict:
    env = dict(os.environ)
    env["OMP_NUM_THREADS"] = str(threads)
    return env


GNU_TIME = Path("/usr/bin/time")  # Debian's `time` (launch/bootstrap.sh)


def run_process(cmd: list[str], log: Path, threads: int) -> tuple[int, float, int]:
    """Runs one process; its exit code, wall time and its own peak RSS (KiB), as GNU time's
    %M reports it (ru_maxrss of a child of `time`). os.wait4's ru_maxrss of a child of this
    script would also count the Python image it was forked from before exec (about 48 MiB
    here), which hid any smaller process; it is the fallback where GNU time is missing."""
    maxrss = log.with_suffix(".maxrss")
    maxrss.unlink(missing_ok=True)
    timed = [str(GNU_TIME), "-q", "-f", "%M", "-o", str(maxrss)] + cmd if GNU_TIME.exists() else cmd
    with open(log, "w") as out:
        t0 = time.perf_counter()
        p = subprocess.Popen(timed, stdout=out, stderr=subprocess.STDOUT, env=_env(threads), cwd=ROOT)
        _, status, usage = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
    p.returncode = os.waitstatus_to_exitcode(status)
    try:
        kib = int(maxrss.read_text().split()[-1])
    except (OSError, ValueError, IndexError):
        kib = usage.ru_maxrss
    return p.returncode, wall, kib


def _vm_hwm_kib(pid: int, marker: str) -> int | None:
    """VmHWM of a live process whose command line mentions `marker`, else None."""
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as f:
            if marker.encode() not in f.read():
                return None  # not ours (a recycled pid)
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1])
    except (OSError, ValueError):
        return None
    return None  # a zombie has no memory map


def run_coupled(scene: Path, output: Path, threads: int) -> tuple[int, float, dict[str, int]]:
    """launch/run-coupled.sh on `scene`: exit code, wall time, peak RSS of fluid and solid
    (VmHWM polled from /proc every 20 ms; the peak is reached at start-up, when the
    populations and the sheet's matrices are allocated) and of the launcher's largest
    descendant (ru_maxrss). The study's own folder `output` is emptied first, all but the
    scene when it lies there (a repeat replaces the run before it; the launcher never reuses
    a run's folder by itself)."""
    if output.is_dir():
        for p in output.iterdir():
            if p.resolve() == scene.resolve():
                continue
            if p.is_dir() and not p.is_symlink():
                shutil.rmtree(p)
            else:
                p.unlink()
    output.mkdir(parents=True, exist_ok=True)
    rss = {"fluid": 0, "solid": 0}
    done = threading.Event()

    def poll():
        pids: dict[str, int] = {}
        while not done.is_set():
            for name in rss:
                if name not in pids:
                    try:
                        pids[name] = int((output / f"{name}.pid").read_text().strip())
                    except (OSError, ValueError):
                        continue
                kib = _vm_hwm_kib(pids[name], str(output))
                if kib is not None:
                    rss[name] = max(rss[name], kib)
            done.wait(0.02)

    for stale in ("fluid.pid", "solid.pid"):
        (output / stale).unlink(missing_ok=True)
    poller = threading.Thread(target=poll, daemon=True)
    with open(output / "launcher.log", "w") as out:
        t0 = time.perf_counter()
        p = subprocess.Popen(["bash", str(COUPLED), str(scene), "--output", str(output), "--no-build",
                              "--quiet"], stdout=out, stderr=subprocess.STDOUT, env=_env(threads), cwd=ROOT)
        poller.start()
        _, status, usage = os.wait4(p.pid, 0)
        wall = time.perf_counter() - t0
    done.set()
    poller.join()
    p.returncode = os.waitstatus_to_exitcode(status)
    return p.returncode, wall, {"fluid": rss["fluid"], "solid": rss["solid"], "launcher": usage.ru_maxrss}


def last_line(path: Path) -> str:
    try:
        lines = [line for line in path.read_text(errors="replace").splitlines() if line.strip()]
    except OSError:
        return f"({path} unreadable)"
    return lines[-1] if lines else f"({path} is empty)"


# ---------------------------------------------------------------------------------------
# Settings and knobs.

@dataclass
class Setting:
    label: str            # as the table shows it
    value: float          # the knob's value (cells, A_T, ...), for ordering
    reference: bool = False   # the reference of a knob without an analytic one
    # filled by the study
    measurement: Measurement | None = None
    error: float | None = None
    extra: dict = field(default_factory=dict)   # further columns
    note: str = ""        # e.g. "refused by the coordinator: ..."
    front: bool = False


@dataclass
class Knob:
    key: str               # file names
    title: str
    kind: str              # "resolution" (errors must fall with resolution), "other", "not offered"
    setup: str             # what is fixed and what changes (markdown)
    reference: str         # what the error is measured against (markdown)
    error_name: str
    settings: list[Setting]
    memory_columns: list[str]  # "process" or "fluid", "solid"
    extra_columns: list[tuple[str, str]] = field(default_factory=list)  # (key, header)
    remarks: Callable[["Knob"], list[str]] | None = None
    rank: bool = True      # mark the best error-for-time front
    ref_short: str = "finest setting"  # the summary table's reference column


def pareto(settings: list[Setting]) -> None:
    """Marks the settings with an error and a time that no other setting beats on both."""
    pts = [s for s in settings if s.error is not None and s.measurement is not None and not s.reference]
    for s in pts:
        s.front = not any(o is not s and o.measurement.wall_s <= s.measurement.wall_s and o.error <= s.error
                          and (o.measurement.wall_s < s.measurement.wall_s or o.error < s.error)
                          for o in pts)


# ---------------------------------------------------------------------------------------
# Knob 1: grid resolution of a fluid validation case with an analytic solution.
#
# Plane Poiseuille flow started from rest (scenes/poiseuille.toml): walls at y = -1/2 and
# N - 1/2 (half-way bounce-back), a body force G along x switched on at t = 0. The analytic
# solution of u_t = nu u_yy + G, u(0) = u(H) = 0, u(y, 0) = 0 (H = N, y' = y + 1/2):
#   u = G y'(H - y') / (2 nu) - sum_{n odd} 4 G H^2 / (nu n^3 pi^3) sin(n pi y'/H) exp(-nu n^2 pi^2 t / H^2)

POISEUILLE_U_MAX = 0.05
POISEUILLE_T_STAR = 0.1  # t nu / H^2 at which the profile is compared


def poiseuille_analytic(n_cells: int, nu: float, g: float, steps: int) -> np.ndarray:
    y = np.arange(n_cells) + 0.5
    h = float(n_cells)
    u = g * y * (h - y) / (2.0 * nu)
    for n in range(1, 4001, 2):
        amp = 4.0 * g * h * h / (nu * n**3 * math.pi**3) * math.exp(-nu * n * n * math.pi**2 * steps / (h * h))
        if amp < 1e-18 * g * h * h / nu:
            break
        u -= amp * np.sin(n * math.pi * y / h)
    return u


@dataclass
class PoiseuilleCase:
    cells: int
    tau: float

    @property
    def nu(self) -> float:
        return (self.tau - 0.5) / 3.0

    @property
    def force(self) -> float:
        return 8.0 * self.nu * POISEUILLE_U_MAX / self.cells**2

    @property
    def steps(self) -> int:
        return max(1, round(POISEUILLE_T_STAR * self.cells**2 / self.nu))


def poiseuille_scene(case: PoiseuilleCase, out: Path, why: str, width: int | None = None,
                     precision: str | None = None) -> Path:
    """scenes/poiseuille.toml with N = case.cells across; `width` cells along x and z instead
    of the file's 8 (the flow does not depend on them: periodic), `precision` run.precision."""
    s = load_scene("poiseuille.toml")
    s["scene"] = {"name": f"poiseuille_n{case.cells}",
                  "description": f"Poiseuille start-up, {case.cells} cells across, tau {case.tau:.4f}"}
    s["grid"]["ny"] = case.cells
    if width is not None:
        s["grid"]["nx"] = s["grid"]["nz"] = width
    s["fluid"] = {"tau": case.tau}
    s["body_force"] = {"x": case.force}
    s["run"].update(steps=case.steps, monitor_every=case.steps, initial="rest")
    if precision is not None:
        s["run"]["precision"] = precision
    s["output"] = {"directory": str(out), "fields_every": case.steps}
    return write_scene(out / "scene.toml", s, f"error study (launch/error_study.py): {why}\n"
                       "from scenes/poiseuille.toml")


def poiseuille_ux(out: Path, case: PoiseuilleCase) -> np.ndarray:
    """u_x (lattice units) of every cell of the last step's field snapshot."""
    path = out / f"fields_{case.steps:06d}.h5"
    with h5py.File(path, "r") as f:
        u = f["u"][...][..., 0] / (float(f.attrs["dx_um"]) / float(f.attrs["dt_us"]))  # lattice units
        if int(f.attrs["step"]) != case.steps:
            raise StudyError(f"{path}: step {int(f.attrs['step'])}, expected {case.steps}")
    return u


def poiseuille_error(out: Path, case: PoiseuilleCase) -> float:
    """Relative L2 error of u_x over every cell at the last step against the analytic profile."""
    u = poiseuille_ux(out, case)
    exact = poiseuille_analytic(case.cells, case.nu, case.force, case.steps)[None, :, None]
    return float(np.sqrt(np.mean((u - exact) ** 2) / np.mean(np.broadcast_to(exact, u.shape) ** 2)))


# The air of Table 1 at the paper's dx: nu_lattice = nu_air / (c dx); with the channel of
# scenes/poiseuille.toml (32 cells of 0.2561 um) it is tau = 0.5 + 3 nu_lattice.
AIR_NU_M2_S = 1.5e-5
SOUND_SPEED_M_S = 331.5
LATTICE_SPEED_M_S = math.sqrt(3.0) * SOUND_SPEED_M_S
POISEUILLE_HEIGHT_UM = 32 * H_PAPER_UM


def acoustic_tau(cells: int) -> float:
    dx_m = POISEUILLE_HEIGHT_UM / cells * 1e-6
    return 0.5 + 3.0 * AIR_NU_M2_S / (LATTICE_SPEED_M_S * dx_m)


# ---------------------------------------------------------------------------------------
# Knobs 2, 3, 5: a coupled case, scenes/coupled_small.toml's family.
#
# Resolution: the same physical box (10.24 x 7.68 x 7.68 um), sheet, air and physical time at
# dx = 0.5122 / 2^k um. The sheet's CGPs nest: nx_cg = 2^(k+1) + 1, ny_cg = 5 2^k + 1 (3 x 6,
# 5 x 11, 9 x 21, 17 x 41), so the marked CGP (middle of the top row) stays at the same place;
# spacing dx_CG = dx, mass per CGP proportional to dx^2 (2e6 atoms at 0.2561 um), RCGP stages
# fixed at 9 (the same D and C at every dx). The fluid keeps Re and Mach (acoustic scaling:
# dt = dx / c, nu fixed in m^2/s, so tau - 1/2 grows with 1/dx) and A_T grows with 1/dx so
# that dt_CG stays the same fraction of the sheet's stable step (which falls as dx^2).

COUPLED_BASE_STEPS = 200       # at dx = 0.2561 um, as scenes/coupled_small.toml
COUPLED_BASE_RIGID = 50
COUPLED_BASE_A_T = 150
COUPLED_REYNOLDS = 5.0         # U_max x 10 cells / nu at tau = 0.8: coupled_small's flow
COUPLED_REFERENCE_UM = 10 * H_PAPER_UM


def coupled_resolution_scene(level: int, out: Path) -> tuple[Path, int]:
    """Level k: dx = 0.5122 / 2^k um. Returns the scene and the step compared (the same
    physical time at every level)."""
    scale = 2**level  # cells per 0.5122 um
    h = 2.0 * H_PAPER_UM / scale
    s = load_scene("coupled_small.toml")
    base = s["grid"]
    s["scene"] = {"name": f"coupled_dx{level}",
                  "description": f"coupled_small's family at dx = {h:.6g} um"}
    s["grid"] = {"nx": base["nx"] * scale // 2, "ny": base["ny"] * scale // 2, "nz": base["nz"] * scale // 2,
                 "dx_um": h}
    s["fluid"] = {"reynolds": COUPLED_REYNOLDS, "reference_length_um": COUPLED_REFERENCE_UM}
    steps = COUPLED_BASE_STEPS * scale // 2
    s["run"] = {"steps": steps, "monitor_every": max(1, steps // 4)}
    s["output"] = {"directory": str(out), "fields_every": 0, "sheets_every": 0}
    s["coupling"].update(time_ratio=COUPLED_BASE_A_T * scale // 2, rigid_steps=COUPLED_BASE_RIGID * scale // 2,
                         peer_timeout_s=120.0)
    s["solid"] = {"model": "rcgp", "stages": 9}
    sheet = s["sheet"][0]
    sheet.update(nx_cg=2 * scale + 1, ny_cg=5 * scale + 1, spacing_um=h,
                 atoms_per_cgp=2e6 * (h / H_PAPER_UM) ** 2)
    compared = (COUPLED_BASE_STEPS // 2 - 1) * scale  # the coarsest level's last step, same time
    return write_scene(out / "scene.toml", s, "error study (launch/error_study.py): grid resolution of a "
                       f"coupled case, dx = {h:.6g} um\nfrom scenes/coupled_small.toml"), compared


def coupled_base_scene(out: Path, a_t: int, name: str, why: str) -> Path:
    """scenes/coupled_small.toml with A_T = a_t and no snapshots."""
    s = load_scene("coupled_small.toml")
    s["scene"] = {"name": name, "description": f"coupled_small with A_T = {a_t}"}
    s["output"] = {"directory": str(out), "fields_every": 0, "sheets_every": 0}
    s["coupling"].update(time_ratio=a_t, peer_timeout_s=120.0)
    return write_scene(out / "scene.toml", s, f"error study (launch/error_study.py): {why}\n"
                       "from scenes/coupled_small.toml")


def marked_displacement(out: Path, step: int | None = None) -> tuple[np.ndarray, float]:
    """The marked CGP's displacement (um, 3-vector) at `step` (default: the last row) and its time."""
    path = out / "solid.h5"
    with h5py.File(path, "r") as f:
        steps = f["step"][...]
        row = len(steps) - 1 if step is None else int(np.searchsorted(steps, step))
        if row >= len(steps) or steps[row] != (steps[-1] if step is None else step):
            raise StudyError(f"{path}: no row for step {step}")
        return f["marked_displacement_um"][row, 0, :].astype(float), float(f["time_s"][row])


def stable_a_t(scene: Path, log: Path) -> tuple[int, str]:
    """The smallest A_T the solid's stable step allows for a coupled scene (solid --check)."""
    env = _env(1)
    env["COSIM_RUN_TOKEN"] = "0123456789abcdef"
    r = subprocess.run([str(SOLID), str(scene), "--check"], capture_output=True, text=True, env=env, cwd=ROOT)
    log.write_text(r.stdout + r.stderr)
    m = re.search(r"dt_LB = ([0-9.eE+-]+) s.*stable step of the model ([0-9.eE+-]+) s", r.stdout)
    if r.returncode != 0 or not m:
        raise StudyError(f"solid --check {scene}: exit {r.returncode}, no stable step in its header (log {log})")
    dt_lb, stable = float(m.group(1)), float(m.group(2))
    return math.ceil(dt_lb / stable), f"dt_LB = {dt_lb:.4g} s, stable step {stable:.4g} s"


# ---------------------------------------------------------------------------------------
# Knob 4: the RCGP truncation range (solid alone, `solid --check`).

def rcgp_scene(out: Path, stages: int, truncation: int, scaling: str) -> Path:
    s = load_scene("sheet_free_vibration.toml")
    s["scene"] = {"name": f"rcgp_s{stages}_r{truncation}_{scaling}",
                  "description": f"the paper's 5 x 40 sheet, {stages} stages, truncation range {truncation}"}
    s["solid"] = {"model": "rcgp", "flexural_scaling": scaling, "stages": stages, "truncation_range": truncation}
    s["output"] = {"directory": str(out)}
    return write_scene(out / "scene.toml", s, "error study (launch/error_study.py): RCGP truncation range\n"
                       "from scenes/sheet_free_vibration.toml")


def parse_eigenfrequencies(text: str) -> list[float]:
    m = re.search(r"eigenfrequencies in vacuum: (.*)", text)
    if not m:
        return []
    return [float(x) for x in re.findall(r"([0-9.eE+-]+) Hz", m.group(1))]


if __name__ == "__main__":  # a module, not a command: --help says what it is and who uses it
    import argparse
    argparse.ArgumentParser(description=__doc__.split("\n")[0], epilog=__doc__,
                            formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    print("launch/error_study_cases.py: a module of launch/error_study.py; nothing to run here")
