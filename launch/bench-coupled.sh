#!/usr/bin/env bash
# Time per LB step of the coupled run, split per side into compute, waiting and (fluid)
# publishing (DESIGN 7), for the small coupled scene and the paper's grid, with the serial
# and the parallel scheme (protocol/README.md sections 5 and 14). Prints a table, then each
# side alone (cosim-replay of the serial run's log: the same work with its peer played
# in-process from the log, no waiting on a real peer) against the coupled wall time:
#   serial   wall / (fluid alone + solid alone)   the serial scheme's goal: <= 1.15
#   parallel wall / max(fluid alone, solid alone) the parallel scheme's goal: <= 1.10
#   bash launch/bench-coupled.sh [--no-build] [--scenes "coupled_small coupled_paper_grid"]
#                                [--propagation two-grid|in-place] [--repeat N]
# --repeat N (default 3) runs each scene N times: each time the serial scheme, each side alone
# and the parallel scheme back to back; a row per repetition, then per scene the range of
# each ratio and in how many repetitions it held its goal (whether the goals hold run after run).
# --propagation sets the scenes' [run] propagation (default: theirs, in place unless a scene says two-grid). Each call
# writes its runs to a folder of its own, out/bench/DATE-TIME/SCENE/REP/ (launch/folders.sh; with
# --propagation: SCENE_PROPAGATION/REP/), printed on the first line; earlier calls' folders are kept.
# The fluid runs with OpenMP's default threads unless OMP_NUM_THREADS is set; set
# OMP_WAIT_POLICY=passive so that its idle threads do not spin on the solid's core.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
. "$root/launch/folders.sh"
build=1
scenes="coupled_small coupled_paper_grid"
propagation=""
repeat=3
while [ $# -gt 0 ]; do
  case "$1" in --scenes|--propagation|--repeat)
    [ $# -ge 2 ] || { echo "bench-coupled: $1 needs a value" >&2; exit 2; } ;;
  esac
  case "$1" in
    --no-build) build=0 ;;
    --repeat) repeat="${2-}"; shift ;;
    --scenes) scenes="$2"; shift ;;
    --propagation) propagation="${2-}"; shift ;;
    *) echo "bench-coupled: unknown argument $1 (--no-build, --scenes \"A B\", --propagation P, --repeat N)" >&2; exit 2 ;;
  esac
  shift
done
[[ $repeat =~ ^[1-9][0-9]{0,2}$ ]] ||
  { echo "bench-coupled: --repeat: \"$repeat\" is not a number of repetitions from 1 to 999" >&2; exit 2; }
case "$propagation" in
  ""|two-grid|in-place) ;;
  *) echo "bench-coupled: --propagation: \"$propagation\" is not one of two-grid, in-place" >&2; exit 2 ;;
esac
if [ $build -eq 1 ]; then
  bash "$root/launch/bootstrap.sh"
  bash "$root/launch/build.sh" >/dev/null
fi
field() {  # field FILE REGEX: the number captured by the first (..) of the regex
  sed -n "s/$2/\1/p" "$1" | head -1
}
bench_root=$(new_folder "$root/out/bench")
mkdir -p "$bench_root"
echo "bench-coupled: runs in $bench_root; propagation ${propagation:-of the scenes}; $(getconf _NPROCESSORS_ONLN) cores, OMP_NUM_THREADS=${OMP_NUM_THREADS:-default}," \
  "OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-default}; load average $(cut -d' ' -f1-3 /proc/loadavg)"
printf '%-20s %3s %-8s %13s %5s %6s | %13s %10s %10s | %13s %10s | %9s\n' scene rep scheme grid CGPs steps \
  "fluid compute" "wait" "publish" "solid compute" "wait" "wall/step"
declare -A wall fluid_alone solid_alone
for scene in $scenes; do
  dir="$bench_root/$scene${propagation:+_$propagation}"
  mkdir -p "$dir"
  for scheme in serial parallel; do
    # The scene with its scheme (the file both servers read; the replay needs its bytes).
    run_line="[run]"
    [ -n "$propagation" ] && run_line="[run]\npropagation = \"$propagation\""
    sed -e "s/^\[coupling\]$/[coupling]\nscheme = \"$scheme\"/" -e "s/^\[run\]$/$run_line/" \
      "$root/scenes/$scene.toml" > "$dir/$scheme.toml"
  done
  # Each repetition runs the serial scheme (logged), each side alone and the parallel scheme,
  # back to back, so that a change of the host's speed touches the four alike.
  for rep in $(seq 1 "$repeat"); do
    for scheme in serial parallel; do
      out="$dir/$rep/$scheme"
      mkdir -p "$out"
      log=()
      [ "$scheme" = serial ] && log=(--log)
      bash "$root/launch/run-coupled.sh" "$dir/$scheme.toml" --no-build --quiet --output "$out" "${log[@]}" \
        >"$out/launcher.log" 2>&1 ||
        { echo "bench-coupled: $scene/$rep/$scheme failed; see $out/launcher.log, $out/fluid.log, $out/solid.log" >&2; exit 1; }
      f="$out/fluid.log"; s="$out/solid.log"
      grid=$(field "$f" '.*grid *\([0-9]* x [0-9]* x [0-9]*\).*' | tr -d ' ')
      cgps=$(field "$f" '.*handshake accepted: solid model [a-z]*, \([0-9]*\) CGPs.*')
      steps=$(field "$f" '.*coupled run done, \([0-9]*\) LB steps.*')
      w=$(field "$f" '.*LB steps in \([0-9.e+-]*\) s.*')
      fc=$(field "$f" '.*per LB step: compute \([0-9.e+-]*\) ms.*')
      fw=$(field "$f" '.*waiting \([0-9.e+-]*\) ms (for solid_state_t).*')
      fp=$(field "$f" '.*publishing \([0-9.e+-]*\) ms.*')
      sc=$(field "$s" '.*per LB step: compute \([0-9.e+-]*\) ms.*')
      sw=$(field "$s" '.*waiting \([0-9.e+-]*\) ms (for fluid_state_t).*')
      ws=$(awk -v w="$w" -v n="$steps" 'BEGIN { printf "%.4g", 1e3 * w / n }')
      wall[$scene.$rep.$scheme]=$ws
      printf '%-20s %3s %-8s %13s %5s %6s | %10s ms %7s ms %7s ms | %10s ms %7s ms | %6s ms\n' "$scene" "$rep" \
        "$scheme" "$grid" "$cgps" "$steps" "$fc" "$fw" "$fp" "$sc" "$sw" "$ws"
      [ "$scheme" = serial ] || continue
      # Each side alone: cosim-replay runs it against the log with the peer in-process.
      for side in fluid solid; do
        rdir="$dir/$rep/alone_$side"
        "$bin/tools/replay/cosim-replay" "$out/traffic.lcmlog" --side $side --scene "$dir/$scheme.toml" \
          --output "$rdir" --quiet >/dev/null
        r="$rdir/$side.log"
        if [ $side = fluid ]; then
          a=$(field "$r" '.*LB steps in \([0-9.e+-]*\) s.*')
          fluid_alone[$scene.$rep]=$(awk -v w="$a" -v n="$steps" 'BEGIN { printf "%.4g", 1e3 * w / n }')
        else
          c=$(field "$r" '.*per LB step: compute \([0-9.e+-]*\) ms.*')
          x=$(field "$r" '.*waiting \([0-9.e+-]*\) ms (for fluid_state_t).*')
          solid_alone[$scene.$rep]=$(awk -v c="$c" -v x="$x" 'BEGIN { printf "%.4g", c + x }')
        fi
      done
    done
  done
done
echo "(serial: each side waits while the other computes; parallel: both compute the same step at once;"
echo " rigid spin-up steps take no substeps and run in the serial order in both schemes)"
echo
printf '%-20s %3s | %12s %12s | %13s %13s %7s | %15s %14s %7s\n' scene rep "fluid alone" "solid alone" \
  "serial wall" "/ (F + S)" "goal" "parallel wall" "/ max(F, S)" "goal"
for scene in $scenes; do
  for rep in $(seq 1 "$repeat"); do
    printf '%s %s %s %s %s %s\n' "$scene" "$rep" "${fluid_alone[$scene.$rep]}" "${solid_alone[$scene.$rep]}" \
      "${wall[$scene.$rep.serial]}" "${wall[$scene.$rep.parallel]}"
  done
done | awk -v n="$repeat" '
  { fa = $3; sa = $4; ws = $5; wp = $6; m = fa > sa ? fa : sa
    rs = ws / (fa + sa); rp = wp / m
    printf "%-20s %3s | %9.4g ms %9.4g ms | %10.4g ms %13.3f %7s | %12.4g ms %14.3f %7s\n", $1, $2, fa, sa, ws,
      rs, (rs <= 1.15 ? "<=1.15" : ">1.15!"), wp, rp, (rp <= 1.10 ? "<=1.10" : ">1.10!")
    ks[$1] += rs <= 1.15; kp[$1] += rp <= 1.10
    if (!($1 in order)) { order[$1] = ++scenes; name[scenes] = $1 }
    if (!($1 in mins) || rs < mins[$1]) mins[$1] = rs; if (!($1 in maxs) || rs > maxs[$1]) maxs[$1] = rs
    if (!($1 in minp) || rp < minp[$1]) minp[$1] = rp; if (!($1 in maxp) || rp > maxp[$1]) maxp[$1] = rp }
  END { if (n < 2) exit
    for (i = 1; i <= scenes; ++i) { s = name[i]
      printf "%-20s     serial / (F + S) %.3f-%.3f, within 1.15 in %d of %d; parallel / max(F, S) %.3f-%.3f, within 1.10 in %d of %d\n",
        s, mins[s], maxs[s], ks[s], n, minp[s], maxp[s], kp[s], n } }'
echo "(alone: the side's wall per LB step under cosim-replay of the serial run's log, its peer played"
echo " in-process from the log; the fluid's from its 'LB steps in' line, the solid's compute + waiting)"
