#!/usr/bin/env bash
# Started by run-coupled.sh (inside the private network namespace when root): sets up the
# loopback for multicast, starts fluid, solid and optionally cosim-record, and supervises them.
#   bash launch/coupled-inner.sh ROOT SCENE OUTPUT PREFIX LOG QUIET
set -uo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$1 scene=$2 output=$3 prefix=$4 log=$5 quiet=$6
. "$root/launch/folders.sh"

# The survivor's grace: the scene's longer timeout ([coupling] handshake_timeout_s, default
# 120 s; peer_timeout_s, default 30 s), within which it notices its peer is gone, plus 30 s
# to write its checkpoint and outputs. COSIM_SURVIVOR_GRACE_S overrides it.
handshake_s=$(scene_value "$scene" coupling.handshake_timeout_s); peer_s=$(scene_value "$scene" coupling.peer_timeout_s)
grace=${COSIM_SURVIVOR_GRACE_S:-$(awk -v h="${handshake_s:-120}" -v p="${peer_s:-30}" \
  'BEGIN { m = (h + 0 > p + 0) ? h + 0 : p + 0; printf "%d", m + 30.999 }')}
# The survivor of a peer that ended with one of its documented codes after the handshake
# (it published stop_t, three copies on the loopback): no timeout to wait out, only its
# checkpoint and outputs to write. COSIM_STOP_GRACE_S overrides it.
stop_grace=${COSIM_STOP_GRACE_S:-30}
# A process stopped with SIGTERM gets this long to write its checkpoint before SIGKILL.
term_wait=30

# SIGINT or SIGTERM (from run-coupled.sh): the fluid stops the run at its next step (its
# checkpoint, stop_t to the solid, which writes its own); the servers run in sessions of
# their own (setsid), so a Ctrl-C on the terminal reaches them only through here.
# run-coupled.sh passes SIGINT on as SIGUSR1 (a background shell cannot trap SIGINT); the
# fluid gets the launcher's own signal, and names it in its reason.
interrupted=""; fluid=""
on_interrupt() {
  interrupted=$1
  [ -n "$fluid" ] && kill -"$1" "$(fluid_rank0)" 2>/dev/null
}
# The fluid process that hosts the coordinator: the fluid, or under mpirun (--ranks) its
# rank 0, which stops the run at its next step and then ends the other ranks (a signal to
# mpirun would end every rank at once, without a checkpoint).
fluid_rank0() {
  local p
  if [ -n "${COSIM_FLUID_RANKS:-}" ]; then
    for p in $(pgrep -P "$fluid" 2>/dev/null); do
      if tr '\0' '\n' <"/proc/$p/environ" 2>/dev/null | grep -qx 'OMPI_COMM_WORLD_RANK=0'; then echo "$p"; return; fi
    done
  fi
  echo "$fluid"
}
trap 'on_interrupt INT' USR1
trap 'on_interrupt TERM' INT TERM

if [ "$(id -u)" -eq 0 ]; then
  # A fresh namespace has lo down and no multicast route (DESIGN 2.3).
  ip link set lo up
  ip link set lo multicast on
  ip route add 224.0.0.0/4 dev lo 2>/dev/null || true
fi

url=$(scene_value "$scene" coupling.lcm_url)
url=${url:-udpm://239.255.76.67:7667?ttl=0}
export COSIM_CHANNEL_PREFIX=$prefix COSIM_LCM_URL=$url
. "$root/launch/traffic-log.sh"
if [ "$log" -eq 1 ]; then
  start_traffic_log "$output" "${prefix}.*" "$url" || exit 1
fi

extra_pid=""
if [ -n "${COSIM_EXTRA_CMD:-}" ]; then
  env -u COSIM_RUN_KEY_FILE bash -c "$COSIM_EXTRA_CMD" >"$output/extra.log" 2>&1 &  # never the key
  extra_pid=$!
fi

# A restart appends to the logs of the run it continues (into a new folder: new logs).
if [ -n "${COSIM_FLUID_RESTART:-}" ]; then
  for n in fluid solid; do
    [ -s "$output/$n.log" ] && echo "==== run-coupled: $(date -u +%Y-%m-%dT%H:%M:%SZ): restart from $COSIM_FLUID_RESTART" >>"$output/$n.log"
    : >>"$output/$n.log"
  done
else
  : >"$output/fluid.log"; : >"$output/solid.log"
fi
fluid_from=$(stat -c %s "$output/fluid.log"); solid_from=$(stat -c %s "$output/solid.log")
# The fluid alone, or its grid over COSIM_FLUID_RANKS MPI ranks (run-coupled.sh --ranks)
# in this network namespace.
fluid_cmd=("$fluid_exe")
if [ -n "${COSIM_FLUID_RANKS:-}" ]; then
  fluid_cmd=(env COSIM_NETNS_PRIVATE=1 bash "$root/launch/mpirun-local.sh" "$COSIM_FLUID_RANKS" "${fluid_cmd[@]}")
fi
setsid "${fluid_cmd[@]}" "$scene" --output "$output" --channel-prefix "$prefix" $quiet \
  ${COSIM_FLUID_RESTART:+--restart "$COSIM_FLUID_RESTART"} ${COSIM_TIME_RATIO:+--time-ratio "$COSIM_TIME_RATIO"} \
  >>"$output/fluid.log" 2>&1 &
fluid=$!
[ -n "$interrupted" ] && kill -"$interrupted" $fluid 2>/dev/null
echo $fluid >"$output/fluid.pid"
setsid ${COSIM_SOLID_CMD:-$solid_exe} "$scene" --output "$output" --channel-prefix "$prefix" $quiet \
  ${COSIM_SOLID_RESTART:+--restart "$COSIM_SOLID_RESTART"} ${COSIM_TIME_RATIO:+--time-ratio "$COSIM_TIME_RATIO"} \
  >>"$output/solid.log" 2>&1 &
solid=$!
echo $solid >"$output/solid.pid"
# The launcher's one progress line, and the fluid's other lines as they come (with --quiet
# only its closing summary): launch/progress.py, until the fluid ends; from where this run's
# lines start in the logs (a restart appends to them).
/usr/bin/python3 "$root/launch/progress.py" "$output" --pid $fluid --solid-pid $solid $quiet \
  --from-bytes "$fluid_from" "$solid_from" &
watcher=$!

# ", at step N" for a fluid that ended its run (its closing line), else "".
fluid_end_step() {
  local n
  n=$(grep -oE 'coupled run done, [0-9]+ LB steps' "$output/fluid.log" 2>/dev/null | tail -1 | grep -oE '[0-9]+')
  [ -n "$n" ] && echo " at step $n, the run's end"
}
# ": after solid_state_t of step K, while the fluid waited for step K + 1 of N" for a solid
# that left early (the fluid's line naming the step it waited for), else "".
solid_early_step() {
  local k total
  k=$(grep -oE 'waited for solid_state_t of step [0-9]+' "$output/fluid.log" 2>/dev/null | tail -1 | grep -oE '[0-9]+$')
  total=$(scene_value "$scene" run.steps)
  [ -n "$k" ] && echo ": its last solid_state_t was of step $((k - 1)); the fluid waited for step $k${total:+ of $total}"
}

# Waits until process $1 or $2 ends (wait -n -p: bash 5.1; a finished child stays a zombie,
# so kill -0 cannot tell); a trapped signal interrupts the wait: wait again. Sets ended (the
# pid that ended) and ended_status.
wait_either() {
  ended=""
  while [ -z "${ended:-}" ]; do
    wait -n -p ended "$1" "$2"
    ended_status=$?
  done
}

wait_either $fluid $solid
first_pid=$ended s_first=$ended_status
if [ "$first_pid" = "$fluid" ]; then first=fluid; other=solid; b=$solid; else first=solid; other=fluid; b=$fluid; fi
echo $s_first >"$output/$first.exit"

# The survivor should stop by itself (end of run, or its peer timeout); then it is stopped.
# A process that refused its input (exit 2) may never have spoken to its peer, which
# would then wait for its whole handshake timeout: stop it at once.
if [ "$s_first" -eq 2 ]; then grace=2; fi
# The fluid ended with a documented code after the handshake: it published stop_t (the
# run's end, or the reason it stopped), so the solid has only its outputs to write.
after_stop=""
if [ "$first" = fluid ] && [ "$s_first" -le 4 ] && grep -q '^fluid: handshake accepted' "$output/fluid.log" 2>/dev/null; then
  after_stop="the fluid's stop_t (the fluid ended with exit $s_first$(fluid_end_step))"
  [ "$s_first" -eq 2 ] || grace=$stop_grace
fi
# Waits up to $2 seconds for process $1: 0 with its status in s_other once it has ended,
# 1 while it still runs.
wait_up_to() {
  sleep "$2" &
  local sleeper=$!
  wait_either "$1" $sleeper
  [ "$ended" = "$sleeper" ] && return 1
  kill $sleeper 2>/dev/null; wait $sleeper 2>/dev/null
  s_other=$ended_status
}
lingered=""
if ! wait_up_to $b "$grace"; then
  if [ -n "$after_stop" ]; then
    lingered="the $other did not exit within its grace of ${grace} s after $after_stop"
    echo "run-coupled: $lingered; stopping it (SIGTERM)" >&2
  else
    echo "run-coupled: $other still running ${grace} s after $first ended (the scene's timeouts + 30 s); stopping it (SIGTERM)" >&2
  fi
  kill -TERM $b 2>/dev/null
  if ! wait_up_to $b "$term_wait"; then
    echo "run-coupled: $other did not stop within ${term_wait} s of SIGTERM; killing it" >&2
    kill -KILL $b 2>/dev/null
    wait $b; s_other=$?
  fi
fi
echo $s_other >"$output/$other.exit"
wait $watcher 2>/dev/null
stop_traffic_log "$output"
[ -n "$extra_pid" ] && kill -TERM $extra_pid 2>/dev/null && wait $extra_pid 2>/dev/null

# The documented codes 0-4 only: a server killed by a signal (128 + N), or any other
# status, counts as 1 (a system error).
documented() { if [ "$1" -ge 0 ] && [ "$1" -le 4 ]; then echo "$1"; else echo 1; fi; }
# The last line of a server's log; under mpirun (--ranks) mpirun's note of a rank that died
# (which rank, which signal), else the fluid's own last line, not mpirun's closing notes.
last_line() {
  local died
  died=$(grep -m1 'mpirun noticed that process rank' "$output/$1.log" 2>/dev/null)
  if [ "$1" = fluid ] && [ -n "${COSIM_FLUID_RANKS:-}" ] && [ -n "$died" ]; then
    echo "$died"
  elif [ "$1" = fluid ] && [ -n "${COSIM_FLUID_RANKS:-}" ] && grep -q '^fluid: ' "$output/fluid.log"; then
    grep '^fluid: ' "$output/fluid.log" | tail -1
  else
    grep -v '^\s*$' "$output/$1.log" | tail -1
  fi
}
for n in fluid solid; do
  s=$(cat "$output/$n.exit")
  if [ -n "$lingered" ] && [ "$n" = "$other" ]; then
    echo "run-coupled: $lingered: stopped (status $s, counted as exit 1); a peer exits within seconds of stop_t (protocol/README.md 8, 9): $(last_line "$n")" >&2
  elif [ "$n" = solid ] && [ "$first" = solid ] && [ "$s_first" -eq 0 ] && [ "$(cat "$output/fluid.exit")" != 0 ]; then
    # A solid ends with 0 only after the fluid's stop_t(0): this one left before the end.
    echo "run-coupled: the solid exited 0 before the run's end$(solid_early_step) (a solid runs until the fluid's stop_t; protocol/README.md 9): $(last_line solid)" >&2
  elif [ "$s" -gt 128 ] && [ "$s" -lt 160 ]; then
    echo "run-coupled: $n was killed by signal $((s - 128)) (status $s, counted as exit 1): $(last_line "$n")" >&2
  elif [ "$s" != 0 ]; then
    echo "run-coupled: $n exited $s: $(last_line "$n")" >&2
  fi
done
s_first=$(documented "$s_first"); s_other=$(documented "$s_other")
# The first failure's status, but a 4 (its peer stopped with an error) gives way to the
# peer's own 1, 2 or 3: the peer that published stop_t may end after the one it told.
if [ $s_first -eq 4 ] && [ $s_other -ge 1 ] && [ $s_other -le 3 ]; then exit $s_other; fi
if [ $s_first -ne 0 ]; then exit $s_first; fi
if [ $s_other -ne 0 ]; then exit $s_other; fi
# The run completed but its traffic log (--log) is partial: the recorder ended before it.
[ "$traffic_log_partial" -eq 1 ] && exit 5
exit 0
