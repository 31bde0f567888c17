"""Peak memory of each process for the paper's scenes (issue 8 item 6; DESIGN 7).

Runs each scene through launch/run-coupled.sh for a few LB steps (one rigid, then free
steps with substeps, every output due at each step: planes, sheets, monitor), which
allocates everything a full run holds (populations, the solid model, the output buffers;
the peak is reached at once), and reads the "peak memory" line that both servers print at
the end of a run (getrusage ru_maxrss). Prints one table row per scene.

    /usr/bin/python3 launch/peak_memory.py [--scene NAME ...] [--set SECTION.KEY=VALUE ...]
                                           [--out DIR]

Scenes are names under scenes/paper/ without .toml (default: the single sheet and the pair
at ds = 1.02 um, each at full size and reduced). --set overrides a key of every scene (e.g.
run.precision="mixed"). Exit status: 0 done; 1 a run failed or printed no peak; 2 bad
arguments.
"""
from __future__ import annotations

import argparse
import re
import shutil
import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
COUPLED = ROOT / "launch" / "run-coupled.sh"
DEFAULT = ["single_theta90_re40", "single_theta90_re40_reduced", "pair_ds01p02_re40", "pair_ds01p02_re40_reduced"]
OVERRIDES = {"run.steps": "4", "run.monitor_every": "1", "coupling.rigid_steps": "1",
             "output.planes_every": "1", "output.sheets_every": "1"}


def set_key(text: str, dotted: str, value: str) -> str:
    """`text` with [section] key = value (replaced, or added at the end of the section)."""
    section, key = dotted.split(".", 1)
    at = text.find(f"[{section}]\n")
    if at < 0:
        return text.rstrip("\n") + f"\n\n[{section}]\n{key} = {value}\n"
    end = text.find("\n[", at + 1)
    end = len(text) if end < 0 else end
    body = text[at:end]
    pattern = re.compile(r"^" + re.escape(key) + r"\s*=.*$", re.M)
    body = pattern.sub(f"{key} = {value}", body, count=1) if pattern.search(body) else \
        body.rstrip("\n") + f"\n{key} = {value}\n"
    return text[:at] + body + text[end:]


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", action="append", help="a scene of scenes/paper/ (repeatable)")
    ap.add_argument("--set", action="append", default=[], metavar="SECTION.KEY=VALUE")
    ap.add_argument("--out", type=Path, default=ROOT / "out" / "peak-memory")
    a = ap.parse_args()
    overrides = dict(OVERRIDES)
    for item in a.set:
        if "=" not in item or "." not in item.split("=", 1)[0]:
            print(f"peak_memory: --set {item}: expected SECTION.KEY=VALUE", file=sys.stderr)
            return 2
        k, v = item.split("=", 1)
        overrides[k] = v
    print(f"{'scene':<30} {'grid':>12} {'CGPs':>5} {'model':>13} {'fluid MiB':>10} {'solid MiB':>10}", flush=True)
    status = 0
    for name in a.scene or DEFAULT:
        source = ROOT / "scenes" / "paper" / f"{name}.toml"
        if not source.exists():
            print(f"peak_memory: --scene {name}: no {source}", file=sys.stderr)
            return 2
        text = source.read_text()
        for k, v in overrides.items():
            text = set_key(text, k, v)
        cfg = tomllib.loads(text)
        a.out.mkdir(parents=True, exist_ok=True)
        scene = a.out / f"{name}.toml"
        scene.write_text(text)
        out = a.out / name
        shutil.rmtree(out, ignore_errors=True)  # the script's own run folder, replaced
        p = subprocess.run(["bash", str(COUPLED), str(scene), "--output", str(out), "--no-build", "--quiet"],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, cwd=ROOT)
        peaks = {}
        for side in ("fluid", "solid"):
            log = out / f"{side}.log"
            m = re.search(rf"{side}: peak memory ([0-9.]+) MiB", log.read_text() if log.exists() else "")
            peaks[side] = m.group(1) if m else "-"
        if p.returncode != 0 or "-" in peaks.values():
            status = 1
            print(f"peak_memory: {name}: exit {p.returncode}: {(p.stdout.strip().splitlines() or [''])[-1]}",
                  file=sys.stderr)
        g = cfg["grid"]
        cgps = sum(s["nx_cg"] * s["ny_cg"] for s in cfg.get("sheet", []))
        print(f"{name:<30} {g['nx']:>4}x{g['ny']}x{g['nz']:<4} {cgps:>5} {cfg['solid']['model']:>13} "
              f"{peaks['fluid']:>10} {peaks['solid']:>10}", flush=True)
    return status


if __name__ == "__main__":
    sys.exit(main())
