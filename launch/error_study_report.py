#!/usr/bin/python3
"""The error study's output (launch/error_study.py): the tables, TSV, JSON, figures and
docs/error-vs-runtime.md."""

from __future__ import annotations

import json
import os
import platform
import re
import statistics
from pathlib import Path

from error_study_cases import Knob


# ---------------------------------------------------------------------------------------
# Output: tables, TSV, JSON, figures.

def fmt_mib(kib: int | None) -> str:
    return "-" if not kib else f"{kib / 1024:.1f}"


def knob_table(knob: Knob) -> list[str]:
    if knob.kind == "not offered":
        return ["| setting | status |", "| --- | --- |"] + [f"| {st.label} | {st.note} |" for st in knob.settings]
    head = ["setting", knob.error_name, "wall s"]
    for c in knob.memory_columns:
        head.append("peak RSS MiB" if c == "process" else f"peak RSS {c} MiB")
    head += [h for _, h in knob.extra_columns]
    head += ["on the front"]
    rows = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    for st in knob.settings:
        m = st.measurement
        if st.reference:
            err = "reference"
        elif st.error is not None:
            err = f"{st.error:.3e}"
        else:
            err = st.note or "-"
        cells = [st.label, err, f"{m.wall_s:.2f}" if m else "-"]
        for c in knob.memory_columns:
            cells.append(fmt_mib(m.rss_kib.get(c)) if m else "-")
        cells += [st.extra.get(k, "") for k, _ in knob.extra_columns]
        cells.append(("yes" if st.front else "") if knob.rank else "-")
        rows.append("| " + " | ".join(cells) + " |")
    return rows


def write_tsv(knobs: list[Knob], path: Path) -> None:
    lines = ["knob\tkind\tsetting\tvalue\terror\twall_s\tpeak_rss_mib\treference\tfront\tnote"]
    for k in knobs:
        for st in k.settings:
            m = st.measurement
            rss = max(m.rss_kib.values()) / 1024 if m and m.rss_kib else float("nan")
            lines.append("\t".join([k.key, k.kind.replace(" ", "_"), st.label, f"{st.value:.9g}",
                                    "nan" if st.error is None else f"{st.error:.9e}",
                                    "nan" if not m else f"{m.wall_s:.4f}", f"{rss:.2f}",
                                    "1" if st.reference else "0", "1" if st.front else "0",
                                    st.note.replace("\t", " ")]))
    path.write_text("\n".join(lines) + "\n")


def write_json(knobs: list[Knob], meta: dict, path: Path) -> None:
    data = {"meta": meta, "knobs": []}
    for k in knobs:
        data["knobs"].append({"key": k.key, "title": k.title, "kind": k.kind, "settings": [
            {"label": st.label, "value": st.value, "error": st.error, "reference": st.reference,
             "front": st.front, "note": st.note, "extra": st.extra,
             "walls_s": st.measurement.walls_s if st.measurement else [],
             "rss_kib": st.measurement.rss_kib if st.measurement else {}} for st in k.settings]})
    path.write_text(json.dumps(data, indent=1) + "\n")


def plot_knob(knob: Knob, path: Path) -> bool:
    pts = [st for st in knob.settings if st.error is not None and st.error > 0 and st.measurement]
    if len(pts) < 2:
        return False
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.6), dpi=110)
    x = [st.measurement.wall_s for st in pts]
    y = [st.error for st in pts]
    ax.plot(x, y, "o-", color="0.55", lw=1, label="settings (in knob order)")
    front = sorted((st for st in pts if st.front), key=lambda s: s.measurement.wall_s)
    if front:
        ax.plot([s.measurement.wall_s for s in front], [s.error for s in front], "s", ms=9, mfc="none",
                mec="C3", mew=1.6, label="best error-for-time front")
    for st in pts:
        ax.annotate(st.label, (st.measurement.wall_s, st.error), textcoords="offset points", xytext=(5, 4),
                    fontsize=8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    from matplotlib.ticker import FuncFormatter, NullFormatter
    plain = FuncFormatter(lambda v, _: f"{v:g}")
    for axis, values in ((ax.xaxis, x), (ax.yaxis, y)):
        axis.set_major_formatter(plain)
        # Within a decade the minor ticks carry the only labels; across decades they clutter.
        axis.set_minor_formatter(plain if max(values) / min(values) < 10 else NullFormatter())
    ax.tick_params(axis="both", which="both", labelsize=7)
    ax.set_xlabel("wall time, s (median)")
    ax.set_ylabel(knob.error_name)
    ax.set_title(knob.title, fontsize=9)
    ax.grid(True, which="both", lw=0.3, alpha=0.6)
    ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)
    return True


def machine_text() -> str:
    cpu = "unknown CPU"
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = ""
    try:
        kb = int(re.search(r"MemTotal:\s+(\d+)", Path("/proc/meminfo").read_text()).group(1))
        mem = f", {kb / 1024**2:.0f} GiB memory"
    except (OSError, AttributeError):
        pass
    return f"{cpu}, {os.cpu_count()} cores{mem}, {platform.system()} {platform.release()}"


def load_text() -> str:
    try:
        return " ".join(Path("/proc/loadavg").read_text().split()[:3])
    except OSError:
        return "?"


def write_markdown(knobs: list[Knob], meta: dict, path: Path, figures: Path, figure_prefix: str) -> None:
    lines = [
        "# Error against run time",
        "",
        f"Command: `{meta['command']}` ({meta['elapsed_s'] / 60:.1f} min here; `--short` is the quick version "
        "that the test `ErrorStudyShortRuns` runs). Every number below is written by that command "
        "(`launch/error_study.py`; each case's definition is in `launch/error_study_cases.py`); nothing is typed in.",
        "",
        f"- Date: {meta['date']}",
        f"- Machine: {meta['machine']}; load average {meta['load_start']} at the start, {meta['load_end']} at "
        f"the end (the machine is shared with other work: wall times are noisy)",
        f"- Build: `build/` ({meta['build_type']}); every process on {meta['threads']} OpenMP thread(s) "
        "(`--threads`): with more threads than idle cores OpenMP's barriers, not the arithmetic, set the "
        "time of small grids",
        f"- Wall time: the median of {meta['repeats']} runs of the whole command (process start-up, RCGP "
        "construction and the LCM handshake included: what a user waits for); the full runs' times are in "
        "`results.json` of the output folder",
        "- Peak memory: the largest resident set. A process alone: its ru_maxrss as GNU time (`/usr/bin/time "
        "-f %M`) reports it (`os.wait4` on a child of the study would also count the Python image it was "
        "forked from). A coupled run: VmHWM of the fluid and of the solid process, read from `/proc` every "
        "20 ms while they run (their pids from `OUTPUT/fluid.pid`, `OUTPUT/solid.pid`)",
        "- On the front: no other setting of the same knob is both faster and more accurate (a reference "
        "setting has no error and is not ranked)",
        f"- Outputs of the runs: `{meta['out']}` (scenes, logs, HDF5, `results.tsv`, `results.json`)",
        "",
        "| knob | settings | reference | best error | its wall time | on the front |",
        "| --- | --- | --- | --- | --- | --- |",
    ]
    for k in knobs:
        errs = [st for st in k.settings if st.error is not None]
        best = min(errs, key=lambda s: s.error) if errs else None
        lines.append(f"| [{k.title}](#{_anchor(k)}) | {len(k.settings)} | "
                     f"{k.ref_short} | "
                     f"{f'{best.error:.3e} ({best.label})' if best else '-'} | "
                     f"{f'{best.measurement.wall_s:.2f} s' if best and best.measurement else '-'} | "
                     f"{', '.join(st.label for st in k.settings if st.front) or '-'} |")
    lines.append("")
    for i, k in enumerate(knobs, 1):
        lines += [f"## {i}. {k.title}", "", f"<a id=\"{_anchor(k)}\"></a>", "", k.setup, "",
                  f"Reference: {k.reference}", ""]
        lines += knob_table(k)
        lines.append("")
        if k.remarks:
            lines += [r for r in k.remarks(k) if r]
        spread = spread_remark(k)
        if spread:
            lines.append(spread)
        if k.remarks or spread:
            lines.append("")
        png = figures / f"{k.key}.png"
        if png.exists():
            lines += [f"![{k.title}]({figure_prefix}{k.key}.png)", ""]
    path.write_text("\n".join(lines))


def spread_remark(k: Knob) -> str:
    """How far apart the repeats of one setting are, against how far apart the settings are."""
    timed = [st for st in k.settings if st.measurement and len(st.measurement.walls_s) > 1]
    if len(timed) < 2:
        return ""
    spreads = [max(st.measurement.walls_s) - min(st.measurement.walls_s) for st in timed]
    medians = [st.measurement.wall_s for st in timed]
    worst = max(range(len(timed)), key=lambda i: spreads[i] / medians[i])
    text = (f"Wall time between repeats of one setting: spread (largest - smallest) {statistics.median(spreads):.2f} s "
            f"in the median, at most {100 * spreads[worst] / medians[worst]:.0f} % of the median "
            f"({timed[worst].label}); the settings' medians span {min(medians):.2f} to {max(medians):.2f} s.")
    ranked = [i for i, st in enumerate(timed) if not st.reference and st.error is not None]
    if k.rank and len(ranked) > 1 and (max(medians[i] for i in ranked) - min(medians[i] for i in ranked)
                                       < max(spreads[i] for i in ranked)):
        text += (" The ranked settings differ in time by less than the largest spread between their repeats "
                 "(start-up dominates), so the time order on this row's front is within the noise.")
    return text


def _anchor(k: Knob) -> str:
    return "knob-" + k.key.replace("_", "-")


if __name__ == "__main__":  # a module, not a command: --help says what it is and who uses it
    import argparse
    argparse.ArgumentParser(description=__doc__.split("\n")[0], epilog=__doc__,
                            formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    print("launch/error_study_report.py: a module of launch/error_study.py; nothing to run here")
