#!/usr/bin/env bash
# The paper's single-graphene scene at full size, end to end (issue 8 item 4: under 3 minutes
# on this 2-core machine): scenes/paper/single_theta90_re40.toml (120 x 60 x 90, 200 CGPs,
# corotational, A_T = 150, 15000 rigid + 15000 free LB steps) run through launch/run-coupled.sh
# once per coupling scheme, fluid store and propagation, each timed from the launch to both exits. Prints a
# table (wall, and per LB step each side's compute / waiting / publishing from its log), then,
# for a scheme run in both stores, how far each float mode's solid.h5 is from the double one
# (launch/compare_solid_runs.py).
#   bash launch/paper-end-to-end.sh [--no-build] [--schemes "serial parallel"]
#                                   [--precisions "double mixed"]
#                                   [--propagations "two-grid in-place"] [--scene FILE]
# Defaults: the serial scheme (the paper's) in both stores, the scene's propagation (in place, the default),
# about 7 minutes here. Outputs in out/paper-end-to-end/DATE-TIME/SCHEME_PRECISION/, a folder of
# each call's own (launch/folders.sh; earlier calls' are kept; with --propagations:
# SCHEME_PRECISION_PROPAGATION/). OMP_WAIT_POLICY=passive is set unless given.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
. "$root/launch/folders.sh"
build=1
schemes="serial"
precisions="double mixed"
propagations=""
scene="$root/scenes/paper/single_theta90_re40.toml"
while [ $# -gt 0 ]; do
  case "$1" in
    --no-build) build=0 ;;
    --schemes) schemes="$2"; shift ;;
    --precisions) precisions="$2"; shift ;;
    --propagations) propagations="$2"; shift ;;
    --scene) scene="$2"; shift ;;
    *) echo "paper-end-to-end: unknown argument $1 (--no-build, --schemes \"serial parallel\", --precisions \"double mixed\", --propagations \"two-grid in-place\", --scene FILE)" >&2; exit 2 ;;
  esac
  shift
done
[ -f "$scene" ] || { echo "paper-end-to-end: --scene $scene: no such file" >&2; exit 2; }
for s in $schemes; do
  case "$s" in serial|parallel|implicit) ;; *) echo "paper-end-to-end: --schemes: \"$s\" is not one of serial, parallel, implicit" >&2; exit 2 ;; esac
done
for p in $precisions; do
  case "$p" in double|mixed|single|half) ;; *) echo "paper-end-to-end: --precisions: \"$p\" is not one of double, mixed, single, half" >&2; exit 2 ;; esac
done
for p in $propagations; do
  case "$p" in two-grid|in-place) ;; *) echo "paper-end-to-end: --propagations: \"$p\" is not one of two-grid, in-place" >&2; exit 2 ;; esac
done
if [ $build -eq 1 ]; then
  bash "$root/launch/bootstrap.sh"
  bash "$root/launch/build.sh" >/dev/null
fi
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
runs=$(new_folder "$root/out/paper-end-to-end")
mkdir -p "$runs"
field() {  # field FILE REGEX: the number captured by the first (..) of the regex
  sed -n "s/$2/\1/p" "$1" | head -1
}
echo "paper-end-to-end: $(basename "$scene") into $runs, $(getconf _NPROCESSORS_ONLN) cores, OMP_NUM_THREADS=${OMP_NUM_THREADS:-default}," \
  "OMP_WAIT_POLICY=$OMP_WAIT_POLICY; $(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo '?'); $(date -u '+%Y-%m-%d %H:%M UTC')"
printf '%-9s %-9s %-9s %9s | %13s %10s %10s | %13s %10s | %s\n' scheme store propag. "wall" \
  "fluid compute" "wait" "publish" "solid compute" "wait" "load average before"
for scheme in $schemes; do
  for precision in $precisions; do
   for propagation in ${propagations:-scene}; do
    out="$runs/${scheme}_$precision"
    run_line="[run]\nprecision = \"$precision\""
    if [ "$propagation" != scene ]; then
      out="${out}_$propagation"
      run_line="$run_line\npropagation = \"$propagation\""
    fi
    mkdir -p "$out"
    sed -e "s/^\[coupling\]\$/[coupling]\nscheme = \"$scheme\"/" -e "s/^\[run\]\$/$run_line/" \
      "$scene" > "$out.toml"
    load=$(cut -d' ' -f1-3 /proc/loadavg)
    start=$(date +%s.%N)
    bash "$root/launch/run-coupled.sh" "$out.toml" --no-build --quiet --output "$out" > "$out.launch.log" 2>&1 ||
      { echo "paper-end-to-end: $scheme/$precision/$propagation failed; see $out.launch.log, $out/fluid.log, $out/solid.log" >&2; exit 1; }
    wall=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
    f="$out/fluid.log"; s="$out/solid.log"
    printf '%-9s %-9s %-9s %7s s | %10s ms %7s ms %7s ms | %10s ms %7s ms | %s\n' "$scheme" "$precision" \
      "$(field "$f" '.* \([a-z-]*\) propagation).*')" "$wall" \
      "$(field "$f" '.*per LB step: compute \([0-9.e+-]*\) ms.*')" \
      "$(field "$f" '.*waiting \([0-9.e+-]*\) ms (for solid_state_t).*')" \
      "$(field "$f" '.*publishing \([0-9.e+-]*\) ms.*')" \
      "$(field "$s" '.*per LB step: compute \([0-9.e+-]*\) ms.*')" \
      "$(field "$s" '.*waiting \([0-9.e+-]*\) ms (for fluid_state_t).*')" "$load"
   done
  done
done
for scheme in $schemes; do
  for propagation in ${propagations:-scene}; do
    suffix=""
    [ "$propagation" = scene ] || suffix="_$propagation"
    d="$runs/${scheme}_double$suffix"
    for mode in mixed single half; do
      s="$runs/${scheme}_$mode$suffix"
      if [ -f "$d/solid.h5" ] && [ -f "$s/solid.h5" ]; then
        echo
        echo "$scheme scheme${suffix:+, ${propagation}}: precision $mode against double (solid.h5):"
        /usr/bin/python3 "$root/launch/compare_solid_runs.py" "$d" "$s"
      fi
    done
  done
done
