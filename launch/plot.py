#!/usr/bin/python3
"""Plots of coupled runs like the paper's figures (Inoue et al. 2010, section 3, Figs. 5-14).

    /usr/bin/python3 launch/plot.py RUN_DIR [RUN_DIR ...] [--out DIR] [--label re|angle|ds|name]
                                   [--plane FRACTION] [--times T,T,...] [--vorticity-times T,...]
                                   [--formats png,pdf] [--dpi N] [--figures NAME,...]
    /usr/bin/python3 launch/plot.py --stats RUN_DIR [RUN_DIR ...]

RUN_DIR is a coupled run's output folder (launch/run-coupled.sh --output): solid.h5 is
required, monitor.h5 and field snapshots (fields_NNNNNN.h5) are plotted when present. With
several runs every time series has one line per run (and per sheet, G1 solid, G2 dashed),
labelled by a parameter of the run read from its outputs (the scene copy in solid.h5's
`scene_toml` attribute, common/run/provenance.hpp: [fluid] reynolds, the sheets' theta_deg and
base_um): --label re (Re), angle (theta), ds (span-wise gap between the sheets' bases), name
(the run's folder); by default the one that differs between the runs. Titles say what was
run (Re, angle, sheets, model), never a file name. One run with two sheets: G1 red, G2 blue,
as in the paper.

Time is measured from the release, t - t0 with t0 = rigid_steps dt_LB (the paper's
t0 = 6.7 us): series of the free sheet start there, forces and coefficients show the rigid
spin-up at negative times with a dotted line at the release. Lengths in um, times in us.

Writes into --out (default RUN_DIR/plots for one run, else plots/ in the runs' common
parent folder) each figure in every format of --formats (default png,pdf: a 300 dpi PNG and
a vector PDF beside it; svg allowed), and prints the path of each file written:
  displacement.png        marked CGP (middle of the top edge): stream-wise x, normal to the
                          plate y, span-wise z (Figs. 5, 7, 10)
  coefficients.png        C_D = C_x, C_L = C_z (span-wise: the sheet is turned about y), and
                          C_y normal to the plate (Eq. 33 with U_b of Eq. 34; Fig. 6)
  forces.png              fluid force on each sheet, x, y, z (Figs. 8, 13)
  strain.png              area strain at the top, middle and bottom of the leading edge (Fig. 14)
  energy.png              kinetic, elastic and total energy of the sheets
  monitor.png             fluid health: mass change and maximum Mach number (monitor.h5)
  displacement_sheets.png runs with two sheets: one row per run, G1 red, G2 blue (Fig. 10)
  strain_sheets.png       the CGPs of the sheet snapshots (sheets_NNNNNN.h5) coloured by their
                          area strain, red compressed, blue stretched, seen from downstream
                          and from above, at the snapshots nearest the times --times after
                          release (default the paper's 13.8, 15.6, 22.7 us of Fig. 11);
                          strain_sheets_<run folder>.png per run with several runs
  vorticity_y.png         y vorticity on the plane y = FRACTION L (default 1/2, Fig. 9; 1/3 for
                          Fig. 12), nearest grid plane (its height in um, and whether it lies
                          above the sheets, in the title), L the channel height ny dx, at the
                          snapshot nearest each time T of --vorticity-times after release
                          (default 13.4 us, Fig. 9's; vorticity_y_tT.png for several times);
                          vorticity_y_<run folder>[_tT].png per run with several runs. The
                          CGPs of the nearest sheet snapshot are drawn.
A time the run does not reach takes its nearest snapshot, and the title gives the time shown.

--stats prints, per run and sheet, tab-separated: scene, sheet, final and maximum (largest
|x|, signed) stream-wise displacement of the marked CGP in um, mean C_D and C_L over the last
half of the free phase, the oscillation frequency of the marked CGP after release in MHz and
the number of crossings it comes from (zero crossings of x minus its last-half mean, from the
end of the initial approach on, with a 5% hysteresis; nan with fewer than two crossings).
launch/sweep.sh uses it for its summary table.

Exit status: 0 done; 1 system error (cannot write the plots); 2 bad arguments, or a missing
or malformed run folder (one line on stderr naming the file and the dataset).
"""
import argparse
import os
import re
import sys

PROG = "plot.py"


def fail(message, status=2):
    print(f"{PROG}: {message}", file=sys.stderr)
    sys.exit(status)


try:
    import numpy as np
    import h5py  # noqa: F401  (checked here: a missing package is one line; used by plot_run)
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D
except ImportError as e:  # run with a Python without the packages (use /usr/bin/python3)
    fail(f"{e} (run with /usr/bin/python3; launch/bootstrap.sh installs python3-h5py, "
         "python3-matplotlib, python3-numpy)", 1)



# Reading a run, and the crossing statistics: launch/plot_run.py (also used by the studies).
from plot_run import (PAPER_STRAIN_TIMES_US, PAPER_VORTICITY_TIMES_US, Run, RunError,  # noqa: E402
                      crossing_frequency, open_h5, read_dataset, time_text)



# ----------------------------------------------------------------------------------------
# Labels, colours, figure helpers

LABEL_TEXT = {
    "re": lambda v: f"Re = {v:g}",
    "angle": lambda v: f"θ = {v:g}°",
    "ds": lambda v: f"Δs = {v:.2f} µm",
}
FORMATS = ["png", "pdf"]   # --formats
FIGURES = ("displacement", "coefficients", "forces", "strain", "energy", "monitor", "sheets",
           "strain_sheets", "vorticity")   # --figures
SHEET_COLOURS = ["tab:red", "tab:blue", "tab:green", "tab:purple"]   # G1 red, G2 blue (paper)
SHEET_STYLES = ["-", "--", ":", "-."]
RUN_COLOURS = plt.get_cmap("tab10").colors
COMPONENTS = ("x", "y", "z")


def choose_labels(runs, mode):
    """Sets run.label; returns the mode used. Sorts runs by the parameter (in place)."""
    if mode is None:
        mode = "name"
        if len(runs) > 1:
            for key in ("re", "angle", "ds"):
                values = [r.params.get(key) for r in runs]
                if None not in values and len(set(values)) > 1:
                    mode = key
                    break
    for r in runs:
        if mode != "name" and mode in r.params:
            r.label = LABEL_TEXT[mode](r.params[mode])
        else:
            r.label = r.tag
    if mode != "name" and all(mode in r.params for r in runs):
        runs.sort(key=lambda r: r.params[mode])
    seen = {}
    for r in runs:
        seen[r.label] = seen.get(r.label, 0) + 1
    for r in runs:
        if seen[r.label] > 1:   # the same scene (or value) twice: name the folders
            r.label = f"{r.label} ({os.path.basename(os.path.normpath(r.dir))})"
    return mode


def lines(runs):
    """(run, sheet index, colour, linestyle, label or None) for every sheet of every run."""
    out = []
    for i, r in enumerate(runs):
        for s in range(r.sheets):
            if len(runs) == 1:   # G1 red, G2 blue (dashed: symmetric pairs overlap)
                colour, style = SHEET_COLOURS[s % len(SHEET_COLOURS)], SHEET_STYLES[s % len(SHEET_STYLES)]
                label = f"G{s + 1}" if r.sheets > 1 else None
            else:
                colour, style = RUN_COLOURS[i % len(RUN_COLOURS)], SHEET_STYLES[s % len(SHEET_STYLES)]
                label = r.label + (f", G{s + 1}" if r.sheets > 1 else "")
            out.append((r, s, colour, style, label))
    return out


def what_was_run(r):
    """'Re = 40, θ = 90°, 1 sheet, corotational': from the run's outputs, no file name."""
    parts = [LABEL_TEXT[k](r.params[k]) for k in ("re", "angle", "ds") if k in r.params]
    parts.append(f"{r.sheets} sheet{'s' if r.sheets > 1 else ''}, {r.model}")
    return ", ".join(parts)


def describe(runs):
    if len(runs) == 1:
        return what_was_run(runs[0])
    text = f"{len(runs)} runs: " + ", ".join(r.label for r in runs)
    return text if len(text) <= 90 else f"{len(runs)} runs"


def time_label(runs):
    t0 = {round(r.t0_us, 6) for r in runs}
    release = f"$t_0$ = {t0.pop():.3g} µs" if len(t0) == 1 else "$t_0$ per run"
    return f"time after release $t - t_0$ (µs), {release}"


def style():
    plt.rcParams.update({
        "font.size": 9.5, "axes.titlesize": 9.5, "axes.labelsize": 9.5, "legend.fontsize": 8.5,
        "figure.titlesize": 11, "lines.linewidth": 1.2, "axes.grid": True, "grid.alpha": 0.3,
        "grid.linewidth": 0.6, "xtick.direction": "in", "ytick.direction": "in",
        "xtick.top": True, "ytick.right": True, "xtick.minor.visible": True,
        "ytick.minor.visible": True, "axes.formatter.useoffset": True,
        "axes.formatter.use_mathtext": True, "axes.formatter.limits": (-3, 4),
        "savefig.dpi": 300, "figure.dpi": 150, "legend.framealpha": 0.85,
        "pdf.fonttype": 42, "svg.fonttype": "none",   # text stays text in the vector files
    })


def panels(n, title, runs, height=2.2, width=7.0):
    fig, axes = plt.subplots(n, 1, figsize=(width, 0.9 + height * n), sharex=True,
                             constrained_layout=True, squeeze=False)
    fig.suptitle(f"{title}\n{describe(runs)}")
    return fig, axes[:, 0]


def release_line(ax, first):
    ax.axvline(0.0, color="0.35", ls=":", lw=1.0, zorder=1)
    if first:
        ax.annotate("release", xy=(0.0, 1.0), xycoords=("data", "axes fraction"),
                    xytext=(3, -3), textcoords="offset points", ha="left", va="top",
                    fontsize=8, color="0.3")


def robust_ylim(ax, runs, values, keep):
    """y limits over the samples kept (not the first 10% of the spin-up, where the impulsive
    start is orders of magnitude off); True when something is off scale."""
    lo, hi, rest_lo, rest_hi = np.inf, -np.inf, np.inf, -np.inf
    for r, v in zip(runs, values):
        v = np.asarray(v)
        k = keep(r)
        vv, rest = v[k], v[~k]
        vv, rest = vv[np.isfinite(vv)], rest[np.isfinite(rest)]
        if vv.size:
            lo, hi = min(lo, vv.min()), max(hi, vv.max())
        if rest.size:
            rest_lo, rest_hi = min(rest_lo, rest.min()), max(rest_hi, rest.max())
    if not np.isfinite(lo):
        return False
    pad = 0.06 * (hi - lo) if hi > lo else max(abs(hi), 1e-30) * 0.1
    lo, hi = lo - pad, hi + pad
    ax.set_ylim(lo, hi)
    return bool(rest_lo < lo or rest_hi > hi)


def round_off(ax, values, reference, unit):
    """A component that is zero to round-off (below 1e-8 of the figure's largest) is drawn
    flat on the figure's scale rather than as magnified noise; True when it was."""
    finite = [np.abs(v[np.isfinite(v)]) for v in values]
    largest = max((f.max() for f in finite if f.size), default=0.0)
    if not (reference > 0 and largest < 1e-8 * reference):
        return False
    ax.set_ylim(-0.05 * reference, 0.05 * reference)
    ax.annotate(f"zero to round-off (largest |value| {largest:.1e}{unit})", xy=(0.99, 0.94),
                xycoords="axes fraction", ha="right", va="top", fontsize=7.5, color="0.3")
    return True


def not_startup(r):
    return r.step >= 0.1 * r.rigid_steps


def legend(fig, ax, handles_labels, outside):
    handles, labels = handles_labels
    if len(labels) < 2:
        return
    if outside:
        ax.legend(handles, labels, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    else:
        ax.legend(handles, labels, loc="best")


def collect_legend(entries):
    handles, labels = [], []
    for colour, style, label in entries:
        if label is not None and label not in labels:
            handles.append(Line2D([], [], color=colour, ls=style))
            labels.append(label)
    return handles, labels


def save(fig, out, name, written):
    """NAME.png (300 dpi) and its vector twins (--formats) side by side."""
    base = os.path.join(out, os.path.splitext(name)[0])
    try:
        for fmt in FORMATS:
            fig.savefig(f"{base}.{fmt}", bbox_inches="tight")
            written.append(f"{base}.{fmt}")
    except OSError as e:
        fail(f"{base}.{fmt}: cannot write ({e.strerror or e})", 1)
    finally:
        plt.close(fig)


def unique_name(stem, used):
    """stem.png, else stem_2.png, ...: two runs never overwrite each other's figure."""
    stem = re.sub(r"[^A-Za-z0-9_.-]+", "_", stem)
    name, k = f"{stem}.png", 2
    while name in used:
        name, k = f"{stem}_{k}.png", k + 1
    used.add(name)
    return name


# ----------------------------------------------------------------------------------------
# Figures

def time_series_figure(runs, out, written, name, title, rows, free_only, outside, unit=""):
    """rows: (panel title, y label, function(run, sheet) -> values per row). Series of the free
    sheet (free_only) start at the release; the others show the spin-up at negative times."""
    fig, axes = panels(len(rows), title, runs)
    ls = lines(runs)
    shown = lambda r: r.free if free_only else not_startup(r)
    per_panel = [[value(r, s)[shown(r)] for r, s, *_ in ls] for _, _, value in rows]
    reference = max((np.nanmax(np.abs(v)) for panel in per_panel for v in panel
                     if v.size and np.isfinite(v).any()), default=0.0)
    for p, (ax, (ptitle, ylabel, value)) in enumerate(zip(axes, rows)):
        for r, s, colour, style, label in ls:
            v = value(r, s)
            k = r.free if free_only else slice(None)
            ax.plot(r.t_us[k], v[k], color=colour, ls=style, label=label)
        if free_only:
            ax.axhline(0.0, color="0.6", lw=0.6, zorder=0)
        else:
            release_line(ax, p == 0)
        if not round_off(ax, per_panel[p], reference, unit) and not free_only:
            if robust_ylim(ax, [r for r, *_ in ls], [value(r, s) for r, s, *_ in ls], not_startup):
                ptitle += " (start-up transient off scale)"
        ax.set_title(ptitle, loc="left")
        ax.set_ylabel(ylabel)
    if free_only:
        axes[0].set_xlim(left=0.0)
    axes[-1].set_xlabel(time_label(runs))
    legend(fig, axes[0], collect_legend([(c, st, lb) for _, _, c, st, lb in ls]), outside)
    save(fig, out, name, written)


def displacement_figure(runs, out, written, outside):
    rows = [("(a) stream-wise", r"$\Delta x$ (µm)", lambda r, s: r.disp[:, s, 0]),
            ("(b) normal to the plate", r"$\Delta y$ (µm)", lambda r, s: r.disp[:, s, 1]),
            ("(c) span-wise", r"$\Delta z$ (µm)", lambda r, s: r.disp[:, s, 2])]
    time_series_figure(runs, out, written, "displacement.png",
                       "Displacement of the marked CGP (middle of the top edge) after release",
                       rows, True, outside, " µm")


def coefficient_figure(runs, out, written, outside):
    rows = [("(a) drag, stream-wise", r"$C_D = C_x$", lambda r, s: r.coef[:, s, 0]),
            ("(b) lift, span-wise (the sheet is turned about y)", r"$C_L = C_z$",
             lambda r, s: r.coef[:, s, 2]),
            ("(c) normal to the plate", r"$C_y$", lambda r, s: r.coef[:, s, 1])]
    time_series_figure(runs, out, written, "coefficients.png",
                       r"Force coefficients $C = F / (\rho_f U_b^2 A / 2)$ (Eq. 33, $U_b$ of Eq. 34)",
                       rows, False, outside)


def force_figure(runs, out, written, outside):
    rows = [("(a) stream-wise", r"$F_x$ (nN)", lambda r, s: r.force_nN[:, s, 0]),
            ("(b) normal to the plate", r"$F_y$ (nN)", lambda r, s: r.force_nN[:, s, 1]),
            ("(c) span-wise", r"$F_z$ (nN)", lambda r, s: r.force_nN[:, s, 2])]
    time_series_figure(runs, out, written, "forces.png", "Fluid force on each sheet",
                       rows, False, outside, " nN")


def strain_figure(runs, out, written, outside):
    rows = [("(a) top of the leading edge", r"$\varepsilon_l$", lambda r, s: r.strain[:, s, 2]),
            ("(b) middle", r"$\varepsilon_l$", lambda r, s: r.strain[:, s, 1]),
            ("(c) bottom (at the plate)", r"$\varepsilon_l$", lambda r, s: r.strain[:, s, 0])]
    time_series_figure(runs, out, written, "strain.png",
                       r"Area strain $\varepsilon_l = (|\delta A_l| - |\delta A_{l0}|) / |\delta A_{l0}|$"
                       " on the leading edge", rows, True, outside)


def energy_figure(runs, out, written):
    fig, axes = panels(3, "Energy of the sheets (all sheets of a run) after release", runs)
    for p, (ax, key) in enumerate(zip(axes, ("kinetic", "elastic", "total"))):
        for i, r in enumerate(runs):
            colour = RUN_COLOURS[i % len(RUN_COLOURS)] if len(runs) > 1 else "k"
            ax.plot(r.t_us[r.free], r.energy[key][r.free], color=colour,
                    label=r.label if len(runs) > 1 else None)
        ax.set_title(f"({'abc'[p]}) {key}", loc="left")
        ax.set_ylabel(f"$E_{{\\rm {dict(kinetic='kin', elastic='el', total='tot')[key]}}}$ (J)")
    axes[0].set_xlim(left=0.0)
    axes[-1].set_xlabel(time_label(runs))
    legend(fig, axes[0], axes[0].get_legend_handles_labels(), len(runs) > 4)
    save(fig, out, "energy.png", written)


def monitor_figure(runs, out, written):
    have = [r for r in runs if r.monitor is not None]
    if not have:
        return
    fig, axes = panels(2, "Fluid health (monitor.h5)", have, height=2.0)
    for i, r in enumerate(runs):
        if r.monitor is None:
            continue
        m = r.monitor
        colour = RUN_COLOURS[i % len(RUN_COLOURS)] if len(runs) > 1 else "k"
        label = r.label if len(runs) > 1 else None
        mass0 = m["mass"][0] if m["mass"][0] != 0 else 1.0
        axes[0].plot(m["t_us"], 100.0 * (m["mass"] / mass0 - 1.0), "o-", ms=2.5, color=colour,
                     label=label)
        axes[1].plot(m["t_us"], m["max_mach"], "o-", ms=2.5, color=colour, label=label)
    axes[0].set_title("(a) total mass", loc="left")
    axes[0].set_ylabel(r"$M / M(0) - 1$ (%)")
    axes[1].set_title("(b) largest Mach number on the grid", loc="left")
    axes[1].set_ylabel(r"max $|u| / c_s$")
    for p, ax in enumerate(axes):
        release_line(ax, p == 0)
    axes[-1].set_xlabel(time_label(have))
    legend(fig, axes[0], axes[0].get_legend_handles_labels(), len(have) > 4)
    save(fig, out, "monitor.png", written)


def sheets_figure(runs, out, written):
    """Fig. 10: a row per run, the marked CGPs of G1 (red) and G2 (blue)."""
    n = len(runs)
    fig, axes = plt.subplots(n, 2, figsize=(8.0, 0.9 + 1.7 * n), sharex=True,
                             constrained_layout=True, squeeze=False)
    fig.suptitle("Displacement of the marked CGPs of each sheet after release (G1 red, G2 blue dashed)\n"
                 + describe(runs))
    for i, r in enumerate(runs):
        for c, (comp, name) in enumerate(((0, "stream-wise"), (2, "span-wise"))):
            ax = axes[i, c]
            for s in range(r.sheets):
                ax.plot(r.t_us[r.free], r.disp[r.free, s, comp],
                        color=SHEET_COLOURS[s % len(SHEET_COLOURS)],
                        ls=SHEET_STYLES[s % len(SHEET_STYLES)], label=f"G{s + 1}")
            ax.axhline(0.0, color="0.6", lw=0.6, zorder=0)
            ax.set_title(f"{r.label}: {name}", loc="left")
            ax.set_ylabel(rf"$\Delta {'xyz'[comp]}$ (µm)")
    axes[0, 0].set_xlim(left=0.0)
    for ax in axes[-1]:
        ax.set_xlabel(r"$t - t_0$ (µs)")
    h, lb = axes[0, 0].get_legend_handles_labels()
    if len(lb) > 1:
        axes[0, 0].legend(h, lb, loc="best")
    save(fig, out, "displacement_sheets.png", written)


def strain_sheets_figure(run, out, written, name, times):
    """Fig. 11: the CGPs coloured by area strain at the snapshots nearest the times after the
    release, seen from downstream (z, y) and from above (x, z). Red compressed, blue stretched."""
    free = sorted(s for s in run.sheet_snapshots if s >= run.rigid_steps)
    if not free:
        return
    picks = sorted({run.nearest_step(free, t) for t in times})
    data = []
    for step in picks:
        with open_h5(run.sheet_snapshots[step]) as f:
            p = read_dataset(f, "position_um", run.sheet_snapshots[step], 2)
            e = read_dataset(f, "area_strain", run.sheet_snapshots[step], 1)
            t = float(f.attrs["time_us"]) if "time_us" in f.attrs else float("nan")
        data.append((step, t, np.asarray(p, float), np.asarray(e, float)))
    vmax = max(float(np.max(np.abs(d[3]))) for d in data)
    vmax = vmax if vmax > 0 else 1e-12
    n = len(data)
    fig, axes = plt.subplots(2, n, figsize=(2.6 * n + 1.2, 6.0), constrained_layout=True,
                             squeeze=False)
    fig.suptitle(f"Area strain of the sheets (red compressed, blue stretched)\n{what_was_run(run)}")
    sc = None
    for c, (step, t, p, e) in enumerate(data):
        ax = axes[0, c]
        sc = ax.scatter(p[:, 2], p[:, 1], c=e, cmap="RdBu", vmin=-vmax, vmax=vmax, s=11,
                        edgecolors="0.45", linewidths=0.3)
        ax.set_title(f"from downstream, $t - t_0$ = {time_text(t - run.t0_us)} µs", fontsize=8.5)
        ax.set_xlabel(r"span-wise $z$ (µm)")
        ax.set_ylabel(r"height $y$ (µm)")
        ax.set_aspect("equal", adjustable="datalim")
        ax = axes[1, c]
        ax.scatter(p[:, 0], p[:, 2], c=e, cmap="RdBu", vmin=-vmax, vmax=vmax, s=11,
                   edgecolors="0.45", linewidths=0.3)
        ax.set_title(f"from above, step {step}", fontsize=8.5)
        ax.set_xlabel(r"stream-wise $x$ (µm)")
        ax.set_ylabel(r"span-wise $z$ (µm)")
        ax.set_aspect("equal", adjustable="datalim")
    cb = fig.colorbar(sc, ax=axes, shrink=0.8, pad=0.02)
    cb.set_label(r"area strain $\varepsilon_l$")
    save(fig, out, name, written)


def vorticity_figure(run, out, written, fraction, name, asked_us):
    v = run.vorticity_plane(fraction, asked_us)
    w, dx = v["plane"], v["dx"]
    fig, ax = plt.subplots(figsize=(7.0, 0.9 + 7.0 * v["nz"] / max(v["nx"], 1) * 0.85),
                           constrained_layout=True)
    finite = np.abs(w[np.isfinite(w)])
    vmax = float(np.percentile(finite, 99.5)) if finite.size else 1.0
    vmax = vmax if vmax > 0 else 1.0
    extent = (-0.5 * dx, (v["nx"] - 0.5) * dx, -0.5 * dx, (v["nz"] - 0.5) * dx)
    im = ax.imshow(w, origin="lower", extent=extent, cmap="RdBu_r", vmin=-vmax, vmax=vmax,
                   interpolation="nearest", aspect="equal")
    cb = fig.colorbar(im, ax=ax, shrink=0.9, pad=0.02, extend="both")
    cb.set_label(r"$\omega_y$ (1/µs)")
    ax.set_xlabel(r"stream-wise $x$ (µm)")
    ax.set_ylabel(r"span-wise $z$ (µm)")
    ax.grid(False)
    ax.tick_params(which="both", color="0.2")
    ly = v["ny"] * dx
    frac = f"{fraction:.3g} L"
    for value, text in ((0.5, "L/2"), (1 / 3, "L/3"), (0.25, "L/4"), (2 / 3, "2L/3")):
        if abs(fraction - value) < 2e-3:
            frac = text
    t_rel = v["time_us"] - run.t0_us
    y_plane = (v["j"] + 0.5) * dx   # the cell centre, as in fields.xmf and the sheets' frame
    cgps = run.cgp_positions(v["step"])
    where = ""
    if cgps is not None and y_plane > float(np.max(cgps["y"])):
        where = f"; the plane lies above the sheets (their top at y = {float(np.max(cgps['y'])):.2f} µm)"
    shown = f"$t - t_0$ = {time_text(t_rel)} µs"
    if abs(t_rel - asked_us) > 0.5 * max(run.dt_lb * 1e6, 1e-9) and abs(t_rel - asked_us) > 1e-3:
        shown += f" (nearest snapshot to {time_text(asked_us)} µs)"
    ax.set_title(f"y vorticity on the plane y = {frac} = {y_plane:.2f} µm (grid plane j = {v['j']} of "
                 f"{v['ny']}, L = {ly:.2f} µm){where}\n"
                 f"{what_was_run(run)}\n{shown}, t = {v['time_us']:.3g} µs", fontsize=9.5)
    ax.annotate("flow", xy=(0.13, 0.06), xytext=(0.02, 0.06), xycoords="axes fraction",
                textcoords="axes fraction", va="center", fontsize=8,
                arrowprops=dict(arrowstyle="->", color="k", lw=1.0))
    if cgps is not None:  # the sheets seen from above (Figs. 9, 12)
        ax.plot(cgps["x"], cgps["z"], "o", ms=2.2, color="k", mec="none",
                label=f"CGPs (step {cgps['step']})")
        ax.legend(loc="upper right", fontsize=7, frameon=True)
    else:
        ax.annotate("no sheet snapshots ([output] sheets_every): the plane alone",
                    xy=(0.99, 0.015), xycoords="axes fraction", ha="right", va="bottom",
                    fontsize=7, color="0.25")
    save(fig, out, name, written)
def stats(runs):
    for r in runs:
        k = r.free
        t = r.t_us[k]
        late = k & (r.t_us >= t[0] + 0.5 * (t[-1] - t[0]))
        for s in range(r.sheets):
            x = r.disp[k, s, 0]
            imax = int(np.nanargmax(np.abs(x))) if np.isfinite(x).any() else 0
            print("\t".join([
                r.scene, f"G{s + 1}", f"{x[-1]:.4g}", f"{x[imax]:.4g}",
                f"{np.mean(r.coef[late, s, 0]):.4g}", f"{np.mean(r.coef[late, s, 2]):.4g}",
                "{:.4g}\t{}".format(*crossing_frequency(t, x))]))


# ----------------------------------------------------------------------------------------

class Parser(argparse.ArgumentParser):
    def error(self, message):   # one line, exit 2
        fail(f"{message} (usage: plot.py RUN_DIR [RUN_DIR ...] [--out DIR] "
             "[--label re|angle|ds|name] [--plane FRACTION] [--times T,...] [--vorticity-times T,...] "
             "[--formats png,pdf] | --stats RUN_DIR ...)")


def times_list(text, option):
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        values = []
    if not values or not all(np.isfinite(v) for v in values):
        fail(f"{option} {text}: expected comma-separated times in µs after the release, e.g. 13.8,15.6,22.7")
    return values


def main():
    p = Parser(prog=PROG, description="Plots of coupled runs like the paper's Figs. 5-14.")
    p.add_argument("runs", nargs="+", metavar="RUN_DIR")
    p.add_argument("--out", help="folder for the PNGs (default RUN_DIR/plots, or plots/ in the "
                                 "runs' common parent folder)")
    p.add_argument("--label", choices=("re", "angle", "ds", "name"),
                   help="what names each run in the legends (default: the parameter that differs)")
    p.add_argument("--plane", type=float, default=0.5,
                   help="vorticity plane y = FRACTION L (default 0.5; the paper's Fig. 12: 1/3)")
    p.add_argument("--times", default=",".join(f"{t:g}" for t in PAPER_STRAIN_TIMES_US),
                   help="strain of the sheets at the snapshots nearest these times after release, µs "
                        "(default the paper's Fig. 11: 13.8,15.6,22.7)")
    p.add_argument("--vorticity-times", default=",".join(f"{t:g}" for t in PAPER_VORTICITY_TIMES_US),
                   help="vorticity plane at the snapshots nearest these times after release, µs "
                        "(default Fig. 9's 13.4; Fig. 12: 13.8,15.6,22.7)")
    p.add_argument("--dpi", type=float, default=300.0, help="resolution of the PNGs (default 300)")
    p.add_argument("--formats", default="png,pdf",
                   help="file formats of every figure, from png, pdf, svg (default png,pdf)")
    p.add_argument("--figures", default=",".join(FIGURES),
                   help="which figures, from " + ", ".join(FIGURES) + " (default all)")
    p.add_argument("--stats", action="store_true", help="print the summary statistics, no plots")
    a = p.parse_args()
    wanted = {f.strip() for f in a.figures.split(",") if f.strip()}
    if not wanted or not wanted <= set(FIGURES):
        fail(f"--figures {a.figures}: expected a comma-separated list from " + ", ".join(FIGURES))
    if not 0.0 <= a.plane <= 1.0:
        fail(f"--plane {a.plane}: expected a fraction of the channel height in [0, 1]")
    strain_times = times_list(a.times, "--times")
    vorticity_times = times_list(a.vorticity_times, "--vorticity-times")
    FORMATS[:] = [f.strip() for f in a.formats.split(",") if f.strip()]
    if not FORMATS or any(f not in ("png", "pdf", "svg") for f in FORMATS):
        fail(f"--formats {a.formats}: expected a comma-separated list from png, pdf, svg")
    try:
        runs = [Run(d) for d in a.runs]
    except RunError as e:
        fail(str(e))
    choose_labels(runs, a.label)
    if a.stats:
        stats(runs)
        return
    if a.out:
        out = a.out
    elif len(runs) == 1:
        out = os.path.join(runs[0].dir, "plots")
    else:
        out = os.path.join(os.path.commonpath([os.path.abspath(r.dir) for r in runs]), "plots")
    try:
        os.makedirs(out, exist_ok=True)
    except OSError as e:
        fail(f"{out}: cannot create the output folder ({e.strerror or e})", 1)

    style()
    if not 10.0 <= a.dpi <= 1200.0:
        fail(f"--dpi {a.dpi:g}: expected 10 to 1200")
    plt.rcParams["savefig.dpi"] = a.dpi
    written = []
    many = sum(r.sheets for r in runs) > 4          # long legends go beside the panels
    try:
        if "displacement" in wanted:
            displacement_figure(runs, out, written, many)
        if "coefficients" in wanted:
            coefficient_figure(runs, out, written, many)
        if "forces" in wanted:
            force_figure(runs, out, written, many)
        if "strain" in wanted:
            strain_figure(runs, out, written, many)
        if "energy" in wanted:
            energy_figure(runs, out, written)
        if "monitor" in wanted:
            monitor_figure(runs, out, written)
        if "sheets" in wanted and any(r.sheets > 1 for r in runs):
            sheets_figure(runs, out, written)
        used = set()   # one file per run and figure: named by the run's folder, made unique
        for r in runs if "strain_sheets" in wanted else []:
            stem = "strain_sheets" if len(runs) == 1 else f"strain_sheets_{r.tag}"
            strain_sheets_figure(r, out, written, unique_name(stem, used), strain_times)
        for r in [r for r in runs if r.last_fields and "vorticity" in wanted]:
            for t in vorticity_times:
                stem = "vorticity_y" if len(runs) == 1 else f"vorticity_y_{r.tag}"
                if len(vorticity_times) > 1:
                    stem += f"_t{t:g}"
                vorticity_figure(r, out, written, a.plane, unique_name(stem, used), t)
    except RunError as e:
        fail(str(e))
    for path in written:
        print(path)


if __name__ == "__main__":
    try:
        main()
    except KeyboardInterrupt:
        fail("interrupted", 1)
    except Exception as e:   # never a traceback: one line naming what went wrong
        fail(f"internal error: {type(e).__name__}: {e}", 1)
