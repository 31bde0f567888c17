#!/usr/bin/env bash
# Runs a coupled scene: the fluid server (which hosts the coordinator) and the solid server
# as two processes talking over LCM (DESIGN 2.3, protocol/README.md).
#
#   bash launch/run-coupled.sh SCENE.toml [--output DIR] [--log] [--no-build] [--quiet]
#                              [--solid-cmd CMD] [--extra CMD] [--restart DIR] [--time-ratio N]
#
# --restart DIR continues a run from its coupled checkpoints (DESIGN 2.4): DIR holds
# fluid_NNNNNNNN.h5 and solid_NNNNNNNN.h5 (OUTPUT/checkpoints/ of the earlier run, written
# every [coupling] checkpoint_every steps and on a clean abort); the newest step N with
# both is taken, and each server gets --restart with its file. Give the earlier run's
# output folder as --output to continue its files (solid.h5 and monitor.h5 are rewritten
# from the checkpoints; the snapshots up to N are kept and listed in the XDMF files).
#
# --time-ratio N runs both servers with A_T = N instead of the scene's [coupling] time_ratio.
#
# The terminal shows one updating progress line (launch/progress.py: phase spin-up or free,
# LB step, simulated time, MLUPS, each side's compute and wait shares, ETA; prefixed with
# $COSIM_RUN_LABEL when set), the line "fluid: sheet released at step N", and the fluid's
# header, warnings and closing summary; its monitor rows stay in OUTPUT/fluid.log. --quiet
# shows only the closing summary. The output folder gets scene.toml (a copy of the scene)
# and provenance_fluid.toml, provenance_solid.toml (protocol/provenance.hpp).
#
# The stability watchdog (DESIGN 6, docs/stability.md): when a sentinel stops the run and
# the scene's [watchdog] retry = true, the fluid prints "fluid: watchdog retry: time_ratio
# = M ..., from the newest checkpoint before step S, at most R retries" for a sentinel that a
# smaller dt_CG may cure. The launcher then moves the failed attempt's logs and its
# checkpoints after the restart point into OUTPUT/retry_K/, and runs again with A_T = M from
# the newest pair of checkpoints before step S (from step 0 if there is none), at most R
# times. Each retry is reported on a "run-coupled: watchdog retry" line and in the exit line.
#
# --solid-cmd replaces build/solid/solid with another solid process that speaks the
# protocol (it gets the same arguments: SCENE --output DIR --channel-prefix P [--quiet],
# and the token in COSIM_RUN_TOKEN). --extra starts one more process in the same network
# namespace for the run's duration (tests use it for a foreign publisher); it sees
# COSIM_CHANNEL_PREFIX and COSIM_LCM_URL and is stopped at the end.
#
# As root, both processes run in a private network namespace (unshare -n; lo up with
# multicast, 224.0.0.0/4 routed to lo), so no packet leaves this machine; otherwise they
# run on the host with the scene's ttl=0 URL. Each run gets its own token and channel
# prefix. --log records every channel of the run with lcm-logger into OUTPUT/traffic.lcmlog.
# When one process dies, the other is given COSIM_SURVIVOR_GRACE_S seconds (default 45) to
# notice and stop by itself (it writes its output and the reason), then it is killed. The
# exit status is the first failure's (a 4, "the peer stopped with an error", gives way to
# that peer's own 1, 2 or 3); OUTPUT/fluid.exit and OUTPUT/solid.exit hold each
# process's own status, OUTPUT/fluid.log and OUTPUT/solid.log their output.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)

usage() { echo "usage: bash launch/run-coupled.sh SCENE.toml [--output DIR] [--log] [--no-build] [--quiet] [--solid-cmd CMD] [--extra CMD] [--restart DIR] [--time-ratio N]" >&2; exit 2; }
[ $# -ge 1 ] || usage
scene=$1; shift
output=""; log=0; build=1; quiet=""; solid_cmd=""; extra=""; restart=""; time_ratio=""
while [ $# -gt 0 ]; do
  case "$1" in
    --output) [ $# -ge 2 ] || usage; output=$2; shift 2 ;;
    --log) log=1; shift ;;
    --no-build) build=0; shift ;;
    --quiet) quiet="--quiet"; shift ;;
    --solid-cmd) [ $# -ge 2 ] || usage; solid_cmd=$2; shift 2 ;;
    --extra) [ $# -ge 2 ] || usage; extra=$2; shift 2 ;;
    --restart) [ $# -ge 2 ] || usage; restart=$2; shift 2 ;;
    --time-ratio) [ $# -ge 2 ] || usage; time_ratio=$2; shift 2
      [[ "$time_ratio" =~ ^[1-9][0-9]{0,6}$ ]] && [ "$time_ratio" -le 1000000 ] || {
        echo "run-coupled: --time-ratio $time_ratio: allowed: an integer from 1 to 1000000 (A_T)" >&2; exit 2; } ;;
    *) echo "run-coupled: unknown option $1" >&2; usage ;;
  esac
done
[ -f "$scene" ] || { echo "run-coupled: $scene: no such scene file" >&2; exit 2; }

# The newest step N (8 digits) for which DIR holds both fluid_N.h5 and solid_N.h5, below
# BEFORE when given; empty if none.
newest_pair() {
  local dir=$1 before=$2 f n
  for f in $(ls "$dir" 2>/dev/null | grep -E '^fluid_[0-9]{8}\.h5$' | sort -r); do
    n=${f#fluid_}; n=${n%.h5}
    if [ -n "$before" ] && [ $((10#$n)) -ge "$before" ]; then continue; fi
    if [ -f "$dir/solid_$n.h5" ]; then echo "$n"; return; fi
  done
}
scene=$(cd "$(dirname "$scene")" && pwd)/$(basename "$scene")
export COSIM_FLUID_RESTART="" COSIM_SOLID_RESTART=""
if [ -n "$restart" ]; then
  [ -d "$restart" ] || { echo "run-coupled: --restart $restart: no such folder" >&2; exit 2; }
  restart=$(cd "$restart" && pwd)
  step=$(newest_pair "$restart" "")
  [ -n "$step" ] || { echo "run-coupled: --restart $restart: no step with both fluid_N.h5 and solid_N.h5 (allowed: a checkpoints folder of a coupled run)" >&2; exit 2; }
  COSIM_FLUID_RESTART=$restart/fluid_$step.h5
  COSIM_SOLID_RESTART=$restart/solid_$step.h5
  echo "run-coupled: restarting from step $((10#$step)) ($COSIM_FLUID_RESTART, $COSIM_SOLID_RESTART)"
fi

if [ $build -eq 1 ]; then
  bash "$root/launch/bootstrap.sh"
  bash "$root/launch/build.sh" >/dev/null
fi
name=$(basename "$scene" .toml)
output=${output:-$root/out/$name}
mkdir -p "$output"
output=$(cd "$output" && pwd)
token=$(od -An -N8 -tx1 /dev/urandom | tr -d ' \n')
prefix="COSIM_${token:0:8}_"
export COSIM_RUN_TOKEN=$token

export COSIM_SOLID_CMD=${solid_cmd:-$root/build/solid/solid}
export COSIM_EXTRA_CMD=$extra
inner=(bash "$root/launch/coupled-inner.sh" "$root" "$scene" "$output" "$prefix" "$log" "$quiet")
retries=0; retried=""
while :; do
  export COSIM_TIME_RATIO=$time_ratio
  rm -f "$output/fluid.exit" "$output/solid.exit" "$output/fluid.pid" "$output/solid.pid"
  echo "run-coupled: scene $scene, token $token, channels ${prefix}*, output $output${time_ratio:+, A_T = $time_ratio}"
  if [ "$(id -u)" -eq 0 ] && command -v unshare >/dev/null 2>&1; then
    set +e
    unshare -n "${inner[@]}"
    status=$?
    set -e
  else
    echo "run-coupled: not root: running on the host network with the scene's ttl=0 URL" >&2
    set +e
    "${inner[@]}"
    status=$?
    set -e
    if [ $status -eq 1 ] && grep -q "cannot open LCM" "$output/fluid.log" 2>/dev/null; then
      echo "run-coupled: LCM could not open its multicast socket: enable multicast on lo" \
           "(ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo) or run as root" >&2
    fi
  fi
  # The watchdog's retry ([watchdog] retry): the fluid names the new A_T, the step the
  # restart must precede and how many retries the scene allows.
  advice=$(grep -E '^fluid: watchdog retry: time_ratio = [0-9]+ ' "$output/fluid.log" 2>/dev/null | tail -1 || true)
  [ $status -ne 0 ] && [ -n "$advice" ] || break
  next=$(sed -E 's/.*time_ratio = ([0-9]+) .*/\1/' <<<"$advice")
  before=$(sed -E 's/.*before step ([0-9]+),.*/\1/' <<<"$advice")
  allowed=$(sed -E 's/.*at most ([0-9]+) retries.*/\1/' <<<"$advice")
  if [ "$retries" -ge "$allowed" ]; then
    echo "run-coupled: watchdog: no retry left ($retries of $allowed done)" >&2
    break
  fi
  retries=$((retries + 1))
  why=$(grep -hE 'coupled run stopped|handshake refused|watchdog [a-z_]+ at step' "$output/fluid.log" "$output/solid.log" 2>/dev/null | tail -1 | cut -c1-300)
  kept=$output/retry_$retries
  mkdir -p "$kept"
  for f in fluid.log solid.log fluid.exit solid.exit logger.log extra.log traffic.lcmlog; do
    [ -f "$output/$f" ] && mv "$output/$f" "$kept/"
  done
  from=$(newest_pair "$output/checkpoints" "$before")
  # Checkpoints after the restart point belong to the failed attempt (its trip included).
  if [ -d "$output/checkpoints" ]; then
    for f in $(ls "$output/checkpoints" | grep -E '^(fluid|solid)_[0-9]{8}\.h5$'); do
      n=${f#*_}; n=${n%.h5}
      if [ -z "$from" ] || [ $((10#$n)) -gt $((10#$from)) ]; then mkdir -p "$kept/checkpoints"; mv "$output/checkpoints/$f" "$kept/checkpoints/"; fi
    done
  fi
  if [ -n "$from" ]; then
    COSIM_FLUID_RESTART=$output/checkpoints/fluid_$from.h5
    COSIM_SOLID_RESTART=$output/checkpoints/solid_$from.h5
    start="step $((10#$from)) (its checkpoints)"
  else
    COSIM_FLUID_RESTART=""; COSIM_SOLID_RESTART=""
    start="step 0 (no checkpoint before step $before)"
  fi
  old_ratio=${time_ratio:-$(sed -n 's/^[[:space:]]*time_ratio[[:space:]]*=[[:space:]]*\([0-9]*\).*/\1/p' "$scene" | head -1)}
  retried="$retried${retried:+; }retry $retries: A_T ${old_ratio:-150} -> $next from $start"
  echo "run-coupled: watchdog retry $retries of $allowed: $why"
  echo "run-coupled: watchdog retry $retries of $allowed: A_T ${old_ratio:-150} -> $next, from $start; the failed attempt's logs are in $kept"
  time_ratio=$next
  token=$(od -An -N8 -tx1 /dev/urandom | tr -d ' \n')
  prefix="COSIM_${token:0:8}_"
  export COSIM_RUN_TOKEN=$token
  inner=(bash "$root/launch/coupled-inner.sh" "$root" "$scene" "$output" "$prefix" "$log" "$quiet")
done
echo "run-coupled: fluid exit $(cat "$output/fluid.exit" 2>/dev/null || echo '?'), solid exit" \
     "$(cat "$output/solid.exit" 2>/dev/null || echo '?'); outputs in $output" \
     "(monitor.h5, solid.h5, fluid.log, solid.log$([ "$log" -eq 1 ] && echo ', traffic.lcmlog'))${retried:+; watchdog retries: $retried}"
exit $status
