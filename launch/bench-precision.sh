#!/usr/bin/env bash
# The fluid's precision modes in place against the bench's same-run roofline (issue 35 item 3;
# docs/results/precision-modes-20261206.md): REPS interleaved repetitions, each one run of
# build/fluid/bench per kernel level (--repeat 1, so every repetition measures its own roofline
# once before its rows), then per level, grid and mode the median and range of the step's MLUPS
# and of step / roofline. Needs build/fluid/bench.
#
#   bash launch/bench-precision.sh [--reps N] [--levels "x86-64-v4 x86-64-v3"] [--modes "double mixed single half"]
#                                  [--grids "paper box"] [--steps N] [--out DIR]
#
# Defaults: 5 repetitions, every level the bench runs among x86-64-v4 and x86-64-v3, the four
# modes, the paper grid and the 128^3 box, 60 steps, DIR = a new temporary folder (the raw bench
# outputs). Exit status: 0 done, 1 a bench run failed, 2 bad arguments.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
. "$root/launch/folders.sh"
reps=5 levels="x86-64-v4 x86-64-v3" modes="double mixed single half" grids="paper box" steps=60 out=""
while [ $# -gt 0 ]; do
  case "$1" in
    --reps) reps="$2"; shift ;;
    --levels) levels="$2"; shift ;;
    --modes) modes="$2"; shift ;;
    --grids) grids="$2"; shift ;;
    --steps) steps="$2"; shift ;;
    --out) out="$2"; shift ;;
    *) echo "bench-precision: unknown argument $1 (--reps N, --levels \"x86-64-v4 x86-64-v3\", --modes \"double mixed single half\", --grids \"paper box\", --steps N, --out DIR)" >&2; exit 2 ;;
  esac
  shift
done
case "$reps" in ''|*[!0-9]*) echo "bench-precision: --reps = '$reps': a whole number >= 1" >&2; exit 2 ;; esac
bench="$bin/fluid/bench"
[ -x "$bench" ] || { echo "bench-precision: $bench not found; build it: bash launch/build.sh -- --target bench" >&2; exit 1; }
[ -n "$out" ] || out=$(mktemp -d /tmp/bench-precision.XXXXXX)
mkdir -p "$out"
# Only the levels this CPU runs (the bench refuses the others in one line).
run_levels=""
for level in $levels; do
  if "$bench" --grids box --box 8 --steps 1 --repeat 1 --threads 1 --no-ib --level "$level" >/dev/null 2>&1; then
    run_levels="$run_levels $level"
  else
    echo "bench-precision: level $level skipped (this CPU does not run it)" >&2
  fi
done
for r in $(seq 1 "$reps"); do
  for level in $run_levels; do
    # shellcheck disable=SC2086
    OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive} "$bench" --grids $grids --threads 2 --precision $modes --no-ib \
      --propagation in-place --repeat 1 --steps "$steps" --level "$level" >"$out/r${r}_$level.txt" 2>&1 ||
      { echo "bench-precision: bench failed, see $out/r${r}_$level.txt" >&2; exit 1; }
  done
done
head -1 "$out/r1_$(echo $run_levels | cut -d' ' -f1).txt"
/usr/bin/python3 - "$out" $run_levels <<'EOF'
import re, statistics, sys
from pathlib import Path
out, levels = Path(sys.argv[1]), sys.argv[2:]
rows = {}  # (level, grid, mode) -> [(step MLUPS, step/roof %, roofline MLUPS)]
row = re.compile(r"^(paper \S+|box \S+ \S+)\s+(\d+)\s+(\w+)\s+AA\s+([\d.]+)\s+([\d.]+)\s+([\d.]+)\s+(\d+)%")
for f in sorted(out.glob("r*_*.txt")):
    level = f.stem.split("_", 1)[1]
    for line in f.read_text().splitlines():
        m = row.match(line)
        if m:
            rows.setdefault((level, m.group(1), m.group(3)), []).append(
                (float(m.group(4)), float(m.group(7)), float(m.group(6))))
print(f"{'level':10} {'grid':20} {'mode':7} {'n':>2} {'step MLUPS':>22} {'step/roof':>18} {'roofline MLUPS':>22}")
for (level, grid, mode), v in sorted(rows.items(), key=lambda kv: (levels.index(kv[0][0]), kv[0][1], kv[0][2])):
    def col(i, fmt):
        xs = [x[i] for x in v]
        return f"{fmt.format(statistics.median(xs))} ({fmt.format(min(xs))}-{fmt.format(max(xs))})"
    print(f"{level:10} {grid:20} {mode:7} {len(v):2} {col(0, '{:.1f}'):>22} {col(1, '{:.0f}%'):>18} {col(2, '{:.1f}'):>22}")
EOF
echo "raw bench outputs: $out"
