#!/usr/bin/env bash
# The speed twin of launch/bit-identity.sh: the README's main job (the coupled run of
# launch/run-paper.sh, scenes/paper/single_theta90_re40_reduced.toml, without its plots) with
# this tree's build and with commit REV's, interleaved, and the ratio of their wall times.
#
#   bash launch/speed-against.sh REV [--repeat N] [--steps N] [--output DIR] [--no-build]
#
# REV is built in a git worktree under /tmp (/tmp/cosim-speed-against/<commit>, kept for the
# next call; launch/build.sh, targets fluid and solid); this tree is built first unless
# --no-build. Both builds run the same scene file (this tree's) through their own
# launch/run-coupled.sh --no-build --quiet, each run timed from the launch to both exits.
# --repeat N (default 5) rounds, each one run of each build, the order alternating from round
# to round (REV first in odd rounds) so that a drift of the machine's load hits both alike.
# --steps N runs N LB steps instead of the scene's 15000, the first half rigid as in the scene
# (a shorter check; the default is the main job as it is). Prints one row per round (wall
# times and this tree's / REV's) and the median ratio with its range; below 1: this tree is
# faster. Output: DIR (default out/speed-against-REV-<time>, never an existing folder) with
# the scene, each run's folder and log, and table.txt. Exit 0 when every run ended well, 1 when
# one failed (its log named), 2 for bad input.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
usage() { echo "usage: bash launch/speed-against.sh REV [--repeat N] [--steps N] [--output DIR] [--no-build]" >&2; exit 2; }
[ $# -ge 1 ] || usage
case "$1" in -*) usage ;; esac
rev=$1; shift
output=""; build=1; repeat=5; steps=""
while [ $# -gt 0 ]; do
  case "$1" in
    --repeat) [ $# -ge 2 ] || usage; repeat=$2; shift 2 ;;
    --steps) [ $# -ge 2 ] || usage; steps=$2; shift 2 ;;
    --output) [ $# -ge 2 ] || usage; output=$2; shift 2 ;;
    --no-build) build=0; shift ;;
    *) echo "speed-against: unknown option $1 (allowed: --repeat N, --steps N, --output DIR, --no-build)" >&2; exit 2 ;;
  esac
done
case "$repeat" in ''|*[!0-9]*|0) echo "speed-against: --repeat $repeat: must be an integer >= 1" >&2; exit 2 ;; esac
if [ -n "$steps" ]; then
  case "$steps" in ''|*[!0-9]*|0|1) echo "speed-against: --steps $steps: must be an integer >= 2" >&2; exit 2 ;; esac
fi
commit=$(git -C "$root" rev-parse --verify --quiet "$rev^{commit}") || {
  echo "speed-against: REV = $rev is not a commit of $root" >&2; exit 2; }
short=${commit:0:10}
output=${output:-$root/out/speed-against-$short-$(date -u +%Y%m%d-%H%M%S)}
if [ -e "$output" ]; then echo "speed-against: --output $output exists; give a new folder" >&2; exit 2; fi
mkdir -p "$output"

scene=$output/main_job.toml
source_scene=$root/scenes/paper/single_theta90_re40_reduced.toml
if [ -n "$steps" ]; then
  sed -e "s/^steps = [0-9]*/steps = $steps/" -e "s/^rigid_steps = [0-9]*/rigid_steps = $((steps / 2))/" \
    "$source_scene" > "$scene"
else
  cp "$source_scene" "$scene"
fi

here=${COSIM_BUILD_DIR:-$root/build}
if [ $build -eq 1 ]; then
  bash "$root/launch/bootstrap.sh"
  bash "$root/launch/build.sh" -- --target fluid solid >/dev/null
fi
[ -x "$here/fluid/fluid" ] && [ -x "$here/solid/solid" ] || {
  echo "speed-against: no fluid and solid in $here; build them (launch/build.sh) or leave out --no-build" >&2; exit 2; }
# The reference build: a worktree of REV with its own build/ (kept for the next call).
ref=/tmp/cosim-speed-against/$commit
if [ ! -x "$ref/build/fluid/fluid" ] || [ ! -x "$ref/build/solid/solid" ]; then
  [ -d "$ref" ] || git -C "$root" worktree add --quiet --force --detach "$ref" "$commit"
  COSIM_BUILD_DIR=$ref/build bash "$ref/launch/build.sh" -- --target fluid solid >/dev/null
fi

echo "speed-against: $(basename "$source_scene")${steps:+ at $steps steps}, $repeat rounds;" \
  "$(lscpu | sed -n 's/^Model name: *//p' | head -1), $(getconf _NPROCESSORS_ONLN) cores," \
  "load $(cut -d' ' -f1-3 /proc/loadavg); output $output"
# One run of `tree` (its root and build folder) into `name`; prints its wall time in seconds.
run_one() {
  local dir=$1 bin=$2 name=$3 start end status=0
  start=$(date +%s.%N)
  COSIM_BUILD_DIR=$bin bash "$dir/launch/run-coupled.sh" "$scene" --output "$output/$name" --no-build --quiet \
    > "$output/$name.log" 2>&1 || status=$?
  end=$(date +%s.%N)
  if [ $status -ne 0 ]; then
    echo "speed-against: $name exited $status; see $output/$name.log" >&2
    return 1
  fi
  /usr/bin/python3 -c "import sys; print(f'{float(sys.argv[2]) - float(sys.argv[1]):.2f}')" "$start" "$end"
}

rows=$output/walls.txt
: > "$rows"
for ((k = 1; k <= repeat; k++)); do
  if [ $((k % 2)) -eq 1 ]; then
    t_ref=$(run_one "$ref" "$ref/build" "$short-$k") || exit 1
    t_here=$(run_one "$root" "$here" "HEAD-$k") || exit 1
  else
    t_here=$(run_one "$root" "$here" "HEAD-$k") || exit 1
    t_ref=$(run_one "$ref" "$ref/build" "$short-$k") || exit 1
  fi
  echo "$k $t_ref $t_here" >> "$rows"
  echo "speed-against: round $k: $short $t_ref s, this tree $t_here s"
done
/usr/bin/python3 - "$rows" "$short" <<'EOF' | tee "$output/table.txt"
import statistics, sys
rows = [line.split() for line in open(sys.argv[1])]
short = sys.argv[2]
print(f"{'round':>5}  {short + ' s':>12}  {'this tree s':>12}  {'this / ' + short:>18}")
ratios = []
for k, ref, here in rows:
    r = float(here) / float(ref)
    ratios.append(r)
    print(f"{k:>5}  {float(ref):12.2f}  {float(here):12.2f}  {r:18.3f}")
ref_med = statistics.median(float(r[1]) for r in rows)
here_med = statistics.median(float(r[2]) for r in rows)
print(f"median {ref_med:11.2f}  {here_med:12.2f}  {statistics.median(ratios):18.3f}"
      f"  (range {min(ratios):.3f}-{max(ratios):.3f}, {len(ratios)} rounds)")
EOF
