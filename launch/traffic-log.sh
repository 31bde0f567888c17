# Sourced by launch/coupled-inner.sh (after folders.sh): records a run's LCM traffic with
# cosim-record (tools/record, docs/logs.md "Recording") into OUTPUT/traffic.lcmlog, appended to
# (a restart's traffic goes after the run's it continues); its own lines go to OUTPUT/record.log.

traffic_log_pid=""

# start_traffic_log OUTPUT CHANNEL_REGEX LCM_URL: 0 once the recorder listens (its subscription
# made: for udpm://, the multicast group joined; messages sent before would be missed), else
# 1 with the reason on stderr.
start_traffic_log() {
  local output=$1 channels=$2 url=$3 k from=0
  # A restart appends to record.log: look for this recorder's line past what was there.
  [ -f "$output/record.log" ] && from=$(stat -c %s "$output/record.log")
  # In a session of its own, as the servers (a Ctrl-C at the terminal reaches the launcher,
  # which stops the recorder only after the servers have ended and said so).
  setsid "$record_exe" "$output/traffic.lcmlog" --channels "$channels" --lcm-url "$url" \
    >>"$output/record.log" 2>&1 &
  traffic_log_pid=$!
  echo "$traffic_log_pid" >"$output/record.pid"
  for ((k = 0; k < 200; k++)); do
    if ! kill -0 "$traffic_log_pid" 2>/dev/null; then
      echo "run-coupled: cosim-record did not start: $(tail -1 "$output/record.log")" >&2
      traffic_log_pid=""
      return 1
    fi
    tail -c +$((from + 1)) "$output/record.log" | grep -q "^cosim-record: recording " && return 0
    sleep 0.05
  done
  echo "run-coupled: cosim-record not listening after 10 s; the log may lack the run's first messages" >&2
}

# stop_traffic_log OUTPUT: once the servers have ended, asks the recorder to stop; it writes
# what is still on its way first (at most 30 s) and says so on failure. A recorder that
# ended before it was asked (killed, or stopped by someone else: its process is a zombie
# by now) left a partial log: one line says so, and traffic_log_partial is set to 1.
traffic_log_partial=0
stop_traffic_log() {
  local output=$1 s state
  [ -n "$traffic_log_pid" ] || return 0
  state=$(sed -E 's/^[0-9]+ \(.*\) ([A-Za-z]).*/\1/' "/proc/$traffic_log_pid/stat" 2>/dev/null || echo gone)
  if [ "$state" = Z ] || [ "$state" = X ] || [ "$state" = gone ]; then
    wait "$traffic_log_pid"
    s=$?
    traffic_log_partial=1
    echo "run-coupled: cosim-record ended before the run did ($([ $s -gt 128 ] && echo "killed by signal $((s - 128))" || echo "exit $s")): $output/traffic.lcmlog is partial (launcher exit 5 when the run itself completed)" >&2
    traffic_log_pid=""
    return 0
  fi
  kill -INT "$traffic_log_pid" 2>/dev/null
  # A trapped signal interrupts wait (status > 128) while the recorder still drains: again.
  s=0
  while kill -0 "$traffic_log_pid" 2>/dev/null; do
    wait "$traffic_log_pid"
    s=$?
  done
  [ $s -eq 0 ] || echo "run-coupled: cosim-record exited $s: $(tail -1 "$output/record.log")" >&2
  traffic_log_pid=""
}
