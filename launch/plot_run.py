"""Reading a coupled run for launch/plot.py and the studies: solid.h5, monitor.h5, the sheet
snapshots and the vorticity planes of a run folder (`Run`), and the crossing times and frequency
of a displacement series. A missing or malformed file raises RunError naming the file and the
dataset; launch/plot.py turns it into one line on stderr and exit status 2.
"""
import os
import re
import tomllib

import h5py
import numpy as np


class RunError(Exception):
    """A missing or malformed run folder; the message names the file and the dataset."""


# ----------------------------------------------------------------------------------------
# Reading a run

SERIES_1D = ("step", "time_s", "bulk_velocity_m_s", "kinetic_energy_J", "elastic_energy_J",
             "total_energy_J")
SERIES_3D = ("marked_displacement_um", "fluid_force_N", "force_coefficients", "leading_edge_strain")
PAPER_STRAIN_TIMES_US = (13.8, 15.6, 22.7)   # Fig. 11 (and Fig. 12), after release
PAPER_VORTICITY_TIMES_US = (13.4,)           # Fig. 9


def scene_metadata(scene_toml):
    """{'re': 40, 'angle': 90, 'ds': 4.1} from the run's copy of its scene (solid.h5's
    scene_toml attribute): [fluid] reynolds, the sheets' common theta_deg (90 when not given,
    solid/model/sheet_spec.hpp), and for two sheets the span-wise distance of their bases."""
    try:
        d = tomllib.loads(scene_toml)
    except tomllib.TOMLDecodeError:
        return {}
    out = {}
    reynolds = d.get("fluid", {}).get("reynolds")
    if isinstance(reynolds, (int, float)):
        out["re"] = reynolds
    sheets = d.get("sheet", [])
    if isinstance(sheets, list) and sheets:
        angles = {float(s.get("theta_deg", 90.0)) for s in sheets if isinstance(s, dict)}
        if len(angles) == 1:
            out["angle"] = angles.pop()
        bases = [s.get("base_um") for s in sheets if isinstance(s, dict)]
        if len(bases) == 2 and all(isinstance(b, list) and len(b) == 3 for b in bases):
            out["ds"] = abs(float(bases[1][2]) - float(bases[0][2]))
    return out


def time_text(t):
    """A time in µs for a title: 3 significant digits, round-off around 0 shown as 0."""
    return "0" if abs(t) < 5e-7 else f"{t:.3g}"


def text_attr(attrs, name, path):
    if name not in attrs:
        raise RunError(f"{path}: attribute {name} missing")
    v = attrs[name]
    if isinstance(v, bytes):
        return v.decode("utf-8", "replace")
    if isinstance(v, np.ndarray) and v.size == 1:
        v = v.item()
        return v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)
    return str(v)


def number_attr(attrs, name, path):
    if name not in attrs:
        raise RunError(f"{path}: attribute {name} missing")
    try:
        v = float(np.asarray(attrs[name]).reshape(-1)[0])
    except (TypeError, ValueError, IndexError):
        raise RunError(f"{path}: attribute {name} is not a number")
    if not np.isfinite(v):
        raise RunError(f"{path}: attribute {name} is not finite")
    return v


def read_dataset(f, name, path, ndim):
    if name not in f:
        raise RunError(f"{path}: dataset {name} missing")
    d = f[name]
    if not isinstance(d, h5py.Dataset):
        raise RunError(f"{path}: {name} is not a dataset")
    if d.ndim != ndim:
        raise RunError(f"{path}: dataset {name} has shape {d.shape}, expected {ndim} dimensions")
    try:
        return np.asarray(d[()], dtype=float)
    except (TypeError, ValueError, OSError) as e:
        raise RunError(f"{path}: dataset {name} cannot be read as numbers ({e})")


def open_h5(path):
    if not os.path.isfile(path):
        raise RunError(f"{path}: missing (not a coupled run's output folder?)")
    try:
        return h5py.File(path, "r")
    except OSError:
        raise RunError(f"{path}: not a readable HDF5 file")


class Run:
    """One coupled run's output folder."""

    def __init__(self, directory, plane=0.5):
        self.dir = directory
        if not os.path.isdir(directory):
            raise RunError(f"{directory}: no such run folder")
        self.tag = os.path.basename(os.path.normpath(os.path.abspath(directory)))
        self._read_solid()
        self._read_monitor()
        self._find_fields()
        self.label = self.tag

    def _read_solid(self):
        path = os.path.join(self.dir, "solid.h5")
        with open_h5(path) as f:
            self.scene = text_attr(f.attrs, "scene", path)
            # What was run, from the run's own copy of its scene (common/run/provenance.hpp);
            # outputs written before it carry none, and are labelled by their folder.
            self.params = scene_metadata(text_attr(f.attrs, "scene_toml", path)) if "scene_toml" in f.attrs else {}
            self.model = text_attr(f.attrs, "model", path) if "model" in f.attrs else "?"
            self.dt_lb = number_attr(f.attrs, "dt_lb_s", path)
            self.rigid_steps = number_attr(f.attrs, "rigid_steps", path)
            d = {name: read_dataset(f, name, path, 1) for name in SERIES_1D}
            d.update({name: read_dataset(f, name, path, 3) for name in SERIES_3D})
        n = d["step"].shape[0]
        if n < 2:
            raise RunError(f"{path}: dataset step has {n} row(s), at least 2 needed for a plot")
        sheets = d["marked_displacement_um"].shape[1]
        if sheets < 1:
            raise RunError(f"{path}: dataset marked_displacement_um has no sheet")
        for name in SERIES_1D:
            if d[name].shape != (n,):
                raise RunError(f"{path}: dataset {name} has shape {d[name].shape}, expected ({n},) "
                               "like step")
        for name in SERIES_3D:
            if d[name].shape != (n, sheets, 3):
                raise RunError(f"{path}: dataset {name} has shape {d[name].shape}, expected "
                               f"({n}, {sheets}, 3) (rows, sheets, x y z)")
        if self.dt_lb <= 0:
            raise RunError(f"{path}: attribute dt_lb_s is {self.dt_lb}, expected > 0")
        self.n, self.sheets = n, sheets
        self.t0_us = self.rigid_steps * self.dt_lb * 1e6
        self.t_us = d["time_s"] * 1e6 - self.t0_us          # time after release
        self.step = d["step"]
        self.disp = d["marked_displacement_um"]
        self.force_nN = d["fluid_force_N"] * 1e9
        self.coef = d["force_coefficients"]
        self.strain = d["leading_edge_strain"]
        self.energy = {k: d[f"{k}_energy_J"] for k in ("kinetic", "elastic", "total")}
        self.free = self.step >= self.rigid_steps            # the sheet moves from here on
        if np.count_nonzero(self.free) < 2:                 # a rigid run: show it all
            self.free = np.ones(n, dtype=bool)

    def _read_monitor(self):
        path = os.path.join(self.dir, "monitor.h5")
        self.monitor = None
        if not os.path.exists(path):
            return
        with open_h5(path) as f:
            m = {name: read_dataset(f, name, path, 1) for name in ("time_us", "mass", "max_mach")}
        n = m["time_us"].shape[0]
        for name in ("mass", "max_mach"):
            if m[name].shape != (n,):
                raise RunError(f"{path}: dataset {name} has shape {m[name].shape}, expected ({n},) "
                               "like time_us")
        if n >= 1:
            m["t_us"] = m["time_us"] - self.t0_us
            self.monitor = m

    def _find_fields(self):
        snaps, planes, sheets = [], [], []
        for name in os.listdir(self.dir):
            m = re.fullmatch(r"fields_(\d+)\.h5", name)
            if m:
                snaps.append((int(m.group(1)), name))
            m = re.fullmatch(r"plane_y(\d+)_(\d+)\.h5", name)
            if m:
                planes.append((int(m.group(2)), int(m.group(1)), name))
            m = re.fullmatch(r"sheets_(\d+)\.h5", name)
            if m:
                sheets.append((int(m.group(1)), name))
        self.field_snapshots = {step: os.path.join(self.dir, n) for step, n in snaps}
        # y-plane snapshots ([output] planes_every): per step, by cell row.
        self.plane_snapshots = {}
        for step, j, n in planes:
            self.plane_snapshots.setdefault(step, {})[j] = os.path.join(self.dir, n)
        self.sheet_snapshots = {step: os.path.join(self.dir, n) for step, n in sheets}
        self.last_fields = bool(self.field_snapshots or self.plane_snapshots)

    def step_after_release_us(self, step):
        return step * self.dt_lb * 1e6 - self.t0_us

    def nearest_step(self, steps, t_after_release_us):
        return min(steps, key=lambda s: abs(self.step_after_release_us(s) - t_after_release_us))

    def cgp_positions(self, step):
        """x, y and z (um) of the CGPs in the sheet snapshot nearest to `step`, or None."""
        if not self.sheet_snapshots:
            return None
        best = min(self.sheet_snapshots, key=lambda s: abs(s - step))
        path = self.sheet_snapshots[best]
        with open_h5(path) as f:
            if "position_um" not in f:
                return None
            p = np.asarray(f["position_um"][...], dtype=float)
        return dict(x=p[:, 0], y=p[:, 1], z=p[:, 2], step=best) if p.ndim == 2 and p.shape[1] == 3 else None

    def vorticity_plane(self, fraction, t_after_release_us):
        """omega_y on the x-z grid plane nearest y = fraction L, L = ny dx (the channel height),
        of the snapshot nearest the time after release (a whole-grid one where there is one)."""
        steps = set(self.field_snapshots) | set(self.plane_snapshots)
        step = self.nearest_step(steps, t_after_release_us)
        if step not in self.field_snapshots:
            return self._plane_file(fraction, self.plane_snapshots[step])
        path = self.field_snapshots[step]
        with open_h5(path) as f:
            dx = number_attr(f.attrs, "dx_um", path)
            time_us = number_attr(f.attrs, "time_us", path)
            step = number_attr(f.attrs, "step", path)
            if "vorticity" not in f or not isinstance(f["vorticity"], h5py.Dataset):
                raise RunError(f"{path}: dataset vorticity missing")
            w = f["vorticity"]
            if w.ndim != 4 or w.shape[3] != 3 or min(w.shape[:3]) < 1:
                raise RunError(f"{path}: dataset vorticity has shape {w.shape}, expected "
                               "(nz, ny, nx, 3)")
            nz, ny, nx = w.shape[:3]
            # The nearest cell centre, (j + 1/2) dx (the snapshots' and the sheets' frame).
            j = int(min(max(round(fraction * ny - 0.5), 0), ny - 1))
            try:
                plane = np.asarray(w[:, j, :, 1], dtype=float)   # [z][x], omega_y
            except (TypeError, ValueError, OSError) as e:
                raise RunError(f"{path}: dataset vorticity cannot be read ({e})")
        return dict(plane=plane, dx=dx, j=j, ny=ny, nx=nx, nz=nz, time_us=time_us,
                    step=int(step), path=path)

    def _plane_file(self, fraction, planes):
        """The y-plane snapshot (plane_yJ_NNNNNN.h5) whose row is nearest to fraction L."""
        rows = {}
        for j, path in planes.items():
            with open_h5(path) as f:
                rows[j] = (path, int(number_attr(f.attrs, "grid_ny", path)))
        j = min(rows, key=lambda r: abs(r + 0.5 - fraction * rows[r][1]))
        path, ny = rows[j]
        with open_h5(path) as f:
            dx = number_attr(f.attrs, "dx_um", path)
            time_us = number_attr(f.attrs, "time_us", path)
            step = number_attr(f.attrs, "step", path)
            w = f["vorticity"] if "vorticity" in f else None
            if w is None or w.ndim != 4 or w.shape[1] != 1 or w.shape[3] != 3:
                raise RunError(f"{path}: dataset vorticity missing or not (nz, 1, nx, 3)")
            plane = np.asarray(w[:, 0, :, 1], dtype=float)
            nz, nx = plane.shape
        return dict(plane=plane, dx=dx, j=j, ny=ny, nx=nx, nz=nz, time_us=time_us,
                    step=int(step), path=path)





# ----------------------------------------------------------------------------------------
# Statistics for the sweep's table

def crossing_times(t_us, x):
    """The times (us) at which x crosses its last-half mean: the zero crossings of x - mean
    after the first one (the end of the initial approach), with a hysteresis of 5% of the
    largest excursion from there on, so that round-off and the creeping tail of a settled
    sheet are not counted. An empty list when x does not move."""
    n = x.size
    if n < 4 or not np.isfinite(x).all():
        return []
    d = x - np.mean(x[n // 2:])
    changes = np.nonzero(d[:-1] * d[1:] < 0)[0]
    if changes.size == 0:
        return []
    amp = np.max(np.abs(d[changes[0]:]))
    if not amp > 1e-9:       # um: no motion to speak of
        return []
    h = 0.05 * amp
    state, last_zero, crossings = 0, None, []
    for i in range(1, n):
        if d[i - 1] * d[i] < 0:
            a, b = d[i - 1], d[i]
            last_zero = t_us[i - 1] + (t_us[i] - t_us[i - 1]) * (a / (a - b))
        s = 1 if d[i] > h else (-1 if d[i] < -h else 0)
        if s == 0:
            continue
        if state != 0 and s != state and last_zero is not None:
            crossings.append(last_zero)
        state = s
    if d[changes[0] + 1] != 0 and (not crossings or crossings[0] > t_us[changes[0] + 1]):
        # the first crossing ends the approach from the rest position: it counts too
        a, b = d[changes[0]], d[changes[0] + 1]
        crossings.insert(0, t_us[changes[0]] + (t_us[changes[0] + 1] - t_us[changes[0]]) * (a / (a - b)))
    return crossings


def crossing_frequency(t_us, x):
    """(frequency in MHz, number of crossings) from crossing_times: (nan, crossings) with
    fewer than two."""
    crossings = crossing_times(t_us, x)
    if len(crossings) < 2 or crossings[-1] <= crossings[0]:
        return float("nan"), len(crossings)
    return (len(crossings) - 1) / (2.0 * (crossings[-1] - crossings[0])), len(crossings)   # 1/us = MHz


if __name__ == "__main__":  # a module, not a command: --help says what it is and who uses it
    import argparse
    argparse.ArgumentParser(description=__doc__.split("\n")[0], epilog=__doc__,
                            formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    print("launch/plot_run.py: a module of launch/plot.py and launch/paper_readings.py; nothing to run here")
