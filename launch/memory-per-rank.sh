#!/usr/bin/env bash
# Peak memory of each fluid rank while it writes snapshots and checkpoints, against the rank
# count (docs/scaling.md; issue 32): scenes/coupled_paper_grid.toml on a grid 8 times the
# paper's (240 x 120 x 180, the same dx: 5.18 million cells, 788 MB of populations in one
# process), 4 LB steps with a field snapshot, a monitor row and a checkpoint at steps 2 and
# 4, run in one process and over 1 to RANKS ranks (launch/run-coupled.sh --ranks N: more
# ranks than cores allowed), ROUNDS rounds interleaved. Prints the fluid's end-of-run line of
# each run ("fluid: peak memory ... per rank: ..."; getrusage's largest resident set, which
# a snapshot or checkpoint sets: the populations and the snapshot's fields of the rank's
# planes).
#
#   bash launch/memory-per-rank.sh [--ranks RANKS] [--rounds ROUNDS] [--output DIR]
#
# RANKS: 4 by default; ROUNDS: 2; DIR: out/memory-per-rank (its runs replaced). Exit 0 when
# every run completed, 1 when one failed (its logs named), 2 for bad arguments.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
ranks=4 rounds=2 out="$root/out/memory-per-rank"
die() { echo "memory-per-rank: $*" >&2; exit 2; }
while [ $# -gt 0 ]; do
  case "$1" in
    --ranks) [ $# -ge 2 ] || die "--ranks needs a value"; ranks=$2; shift 2 ;;
    --rounds) [ $# -ge 2 ] || die "--rounds needs a value"; rounds=$2; shift 2 ;;
    --output) [ $# -ge 2 ] || die "--output needs a value"; out=$2; shift 2 ;;
    *) die "unknown option $1 (allowed: --ranks N, --rounds N, --output DIR)" ;;
  esac
done
[[ $ranks =~ ^[1-9][0-9]?$ ]] || die "--ranks $ranks: an integer from 1 to 99"
[[ $rounds =~ ^[1-9][0-9]?$ ]] || die "--rounds $rounds: an integer from 1 to 99"
mkdir -p "$out"
scene="$out/paper_grid_x8.toml"
sed -e 's/^nx = 120$/nx = 240/' -e 's/^ny = 60$/ny = 120/' -e 's/^nz = 90$/nz = 180/' \
    -e 's/^steps = 300$/steps = 4/' -e 's/^monitor_every = 100$/monitor_every = 2/' \
    -e 's/^rigid_steps = 100$/rigid_steps = 2\ncheckpoint_every = 2\npeer_timeout_s = 600/' \
    -e 's/^\[output\]$/[output]\nfields_every = 2/' \
    "$root/scenes/coupled_paper_grid.toml" > "$scene"
grep -q '^nz = 180$' "$scene" && grep -q '^fields_every = 2$' "$scene" && grep -q '^checkpoint_every = 2$' "$scene" ||
  die "scenes/coupled_paper_grid.toml no longer has the keys this script edits"
status=0
for round in $(seq 1 "$rounds"); do
  for n in 0 $(seq 1 "$ranks"); do
    name=$([ "$n" -eq 0 ] && echo "one_process" || echo "ranks$n")
    run="$out/round$round/$name"
    rm -rf "$run"
    mkdir -p "$out/round$round"
    args=()
    [ "$n" -gt 0 ] && args=(--ranks "$n")
    if bash "$root/launch/run-coupled.sh" "$scene" --output "$run" --no-build --quiet "${args[@]}" > "$run.log" 2>&1 &&
       line=$(grep -m1 'fluid: peak memory' "$run/fluid.log"); then
      printf 'round %s  %-12s %s\n' "$round" "$name" "$line"
    else
      echo "memory-per-rank: round $round, $name failed: see $run.log and $run/fluid.log" >&2
      status=1
    fi
    rm -rf "$run/checkpoints" "$run"/fields_*.h5  # 1.7 GB per run
  done
done
exit $status
