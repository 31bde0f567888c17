#!/usr/bin/env bash
# Started by run-coupled.sh (inside the private network namespace when root): sets up the
# loopback for multicast, starts fluid, solid and optionally lcm-logger, and supervises them.
#   bash launch/coupled-inner.sh ROOT SCENE OUTPUT PREFIX LOG QUIET
set -uo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$1 scene=$2 output=$3 prefix=$4 log=$5 quiet=$6
grace=${COSIM_SURVIVOR_GRACE_S:-45}

if [ "$(id -u)" -eq 0 ]; then
  # A fresh namespace has lo down and no multicast route (DESIGN 2.3).
  ip link set lo up
  ip link set lo multicast on
  ip route add 224.0.0.0/4 dev lo 2>/dev/null || true
fi

url=$(sed -n 's/^[[:space:]]*lcm_url[[:space:]]*=[[:space:]]*"\(.*\)".*/\1/p' "$scene" | head -1)
url=${url:-udpm://239.255.76.67:7667?ttl=0}
export COSIM_CHANNEL_PREFIX=$prefix COSIM_LCM_URL=$url
logger_pid=""
if [ "$log" -eq 1 ]; then
  lcm-logger -f -c "${prefix}.*" --lcm-url="$url" "$output/traffic.lcmlog" >"$output/logger.log" 2>&1 &
  logger_pid=$!
  sleep 0.3
  if ! kill -0 $logger_pid 2>/dev/null; then
    echo "run-coupled: lcm-logger did not start: $(head -1 "$output/logger.log")" >&2
    exit 1
  fi
fi

extra_pid=""
if [ -n "${COSIM_EXTRA_CMD:-}" ]; then
  bash -c "$COSIM_EXTRA_CMD" >"$output/extra.log" 2>&1 &
  extra_pid=$!
fi

"$root/build/fluid/fluid" "$scene" --output "$output" --channel-prefix "$prefix" $quiet \
  ${COSIM_FLUID_RESTART:+--restart "$COSIM_FLUID_RESTART"} ${COSIM_TIME_RATIO:+--time-ratio "$COSIM_TIME_RATIO"} \
  >"$output/fluid.log" 2>&1 &
fluid=$!
echo $fluid >"$output/fluid.pid"
${COSIM_SOLID_CMD:-$root/build/solid/solid} "$scene" --output "$output" --channel-prefix "$prefix" $quiet \
  ${COSIM_SOLID_RESTART:+--restart "$COSIM_SOLID_RESTART"} ${COSIM_TIME_RATIO:+--time-ratio "$COSIM_TIME_RATIO"} \
  >"$output/solid.log" 2>&1 &
solid=$!
echo $solid >"$output/solid.pid"
# The launcher's one progress line, and the fluid's other lines as they come (with --quiet
# only its closing summary): launch/progress.py, until the fluid ends.
/usr/bin/python3 "$root/launch/progress.py" "$output" --pid $fluid $quiet &
watcher=$!

# Wait for the first to end (wait -n -p: bash 5.1; a finished child stays a zombie, so
# kill -0 cannot tell).
wait -n -p first_pid $fluid $solid
s_first=$?
if [ "$first_pid" = "$fluid" ]; then first=fluid; other=solid; b=$solid; else first=solid; other=fluid; b=$fluid; fi
echo $s_first >"$output/$first.exit"

# The survivor should stop by itself (end of run, or its peer timeout); then it is killed.
# A process that refused its input (exit 2) may never have spoken to its peer, which
# would then wait for its whole handshake timeout: stop it at once.
if [ "$s_first" -eq 2 ]; then grace=2; fi
sleep "$grace" &
sleeper=$!
wait -n -p second_pid $b $sleeper
s_other=$?
if [ "$second_pid" = "$sleeper" ]; then
  echo "run-coupled: $other still running ${grace} s after $first ended; stopping it" >&2
  kill -TERM $b 2>/dev/null; sleep 1; kill -KILL $b 2>/dev/null
  wait $b; s_other=$?
else
  kill $sleeper 2>/dev/null; wait $sleeper 2>/dev/null
fi
echo $s_other >"$output/$other.exit"
wait $watcher 2>/dev/null
[ -n "$logger_pid" ] && kill -INT $logger_pid 2>/dev/null && wait $logger_pid 2>/dev/null
[ -n "$extra_pid" ] && kill -TERM $extra_pid 2>/dev/null && wait $extra_pid 2>/dev/null

for n in fluid solid; do
  s=$(cat "$output/$n.exit")
  if [ "$s" != 0 ]; then echo "run-coupled: $n exited $s: $(grep -v '^\s*$' "$output/$n.log" | tail -1)" >&2; fi
done
# The first failure's status, but a 4 (its peer stopped with an error) gives way to the
# peer's own 1, 2 or 3: the peer that published stop_t may end after the one it told.
if [ $s_first -eq 4 ] && [ $s_other -ge 1 ] && [ $s_other -le 3 ]; then exit $s_other; fi
if [ $s_first -ne 0 ]; then exit $s_first; fi
exit $s_other
