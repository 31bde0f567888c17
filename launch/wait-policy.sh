#!/usr/bin/env bash
# The fluid's OpenMP wait policy in coupled runs, measured: each scene run through
# launch/run-coupled.sh with libgomp's default (threads spin a while after each parallel
# region, then sleep), OMP_WAIT_POLICY=passive (they sleep at once) and GOMP_SPINCOUNT=N
# (a short spin), interleaved, --repeat N rounds (default 3); prints the wall time per LB step
# of every run, then per scene and policy the median and range. On two cores the solid
# computes beside the fluid's threads, so a spinning thread takes the core it needs.
#
#   bash launch/wait-policy.sh [--scenes "coupled_small coupled_paper_grid coupled_round_trip"]
#                              [--repeat N] [--spincount N]
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
. "$root/launch/folders.sh"
scenes="coupled_small coupled_paper_grid coupled_round_trip"
repeat=3
spin=10000
while [ $# -gt 0 ]; do
  case "$1" in
    --scenes|--repeat|--spincount) [ $# -ge 2 ] || { echo "wait-policy: $1 needs a value" >&2; exit 2; } ;;
  esac
  case "$1" in
    --scenes) scenes=$2; shift ;;
    --repeat) repeat=$2; shift ;;
    --spincount) spin=$2; shift ;;
    *) echo "wait-policy: unknown argument $1 (--scenes \"A B\", --repeat N, --spincount N)" >&2; exit 2 ;;
  esac
  shift
done
[[ $repeat =~ ^[1-9][0-9]{0,2}$ ]] || { echo "wait-policy: --repeat '$repeat': allowed: 1 to 999" >&2; exit 2; }
[[ $spin =~ ^[0-9]{1,9}$ ]] || { echo "wait-policy: --spincount '$spin': allowed: 0 to 999999999" >&2; exit 2; }
for s in $scenes; do
  [ -f "$root/scenes/$s.toml" ] || { echo "wait-policy: --scenes: no scenes/$s.toml" >&2; exit 2; }
done
[ -x "$bin/fluid/fluid" ] || { echo "wait-policy: $bin/fluid/fluid is not built (bash launch/build.sh)" >&2; exit 2; }
dir=$(new_folder "$root/out/wait_policy")
mkdir -p "$dir"
echo "wait-policy: runs in $dir; $(getconf _NPROCESSORS_ONLN) cores, OMP_NUM_THREADS=${OMP_NUM_THREADS:-default}; load average $(cut -d' ' -f1-3 /proc/loadavg)"
policies="default passive spin$spin"
printf '%-20s %3s %-12s %12s %6s\n' scene rep policy "wall/step" load
for rep in $(seq 1 "$repeat"); do
  for s in $scenes; do
    for p in $policies; do
      out="$dir/$s/$p/$rep"
      mkdir -p "$(dirname "$out")"
      # libgomp ignores a value it does not know (its default); the launcher keeps a set one.
      case $p in
        default) env=(OMP_WAIT_POLICY=libgomp-default) ;;
        passive) env=(OMP_WAIT_POLICY=passive) ;;
        *) env=(OMP_WAIT_POLICY=libgomp-default GOMP_SPINCOUNT="$spin") ;;
      esac
      env "${env[@]}" bash "$root/launch/run-coupled.sh" "$root/scenes/$s.toml" --no-build --quiet --output "$out" \
        >"$out.launcher.log" 2>&1 || { echo "wait-policy: $s $p $rep failed: $out.launcher.log" >&2; exit 1; }
      w=$(sed -n 's/.*coupled run done, \([0-9]*\) LB steps in \([0-9.e+-]*\) s.*/\2 \1/p' "$out/fluid.log" | head -1)
      ms=$(echo "$w" | awk '{ printf "%.4g", 1e3 * $1 / $2 }')
      printf '%-20s %3s %-12s %9s ms %6s\n' "$s" "$rep" "$p" "$ms" "$(cut -d' ' -f1 /proc/loadavg)"
    done
  done
done | tee "$dir/runs.txt"
echo
echo "median (range) of the wall time per LB step, ms:"
awk '$4 ~ /^[0-9.e+-]+$/ { v[$1 " " $3] = v[$1 " " $3] " " $4 }
     END { for (k in v) { n = split(v[k], a, " ")
             for (i = 2; i <= n; ++i) { x = a[i] + 0; for (j = i - 1; j >= 1 && a[j] + 0 > x; --j) a[j + 1] = a[j]; a[j + 1] = x }
             m = n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
           printf "%-33s %9.4g (%.4g-%.4g), %d runs\n", k, m, a[1], a[n], n } }' "$dir/runs.txt" | sort
