#!/usr/bin/env bash
# Runs a coupled scene: the fluid server (which hosts the coordinator) and the solid server
# as two processes talking over LCM (DESIGN 2.3, protocol/README.md).
#
#   bash launch/run-coupled.sh SCENE.toml [--output DIR] [--log] [--no-build] [--quiet]
#                              [--solid-cmd CMD] [--extra CMD] [--restart PATH]
#                              [--time-ratio N | --new-time-ratio N] [--ranks N]
#
# Each run has its own output folder: by default out/<scene name>/<UTC date-time>[-K]/
# (always new, created by the launch that gets it, so launches in the same second each get
# their own; $COSIM_OUTPUT_ROOT replaces out/); --output DIR must be new or hold no run (a
# folder with run.id, monitor.h5, solid.h5 or checkpoints/ is refused, never reused silently;
# of two launches given the same new DIR at once, the one that creates DIR/run.id runs),
# unless the run continues that folder's run (--restart; the folder's run is its run.id, or
# where that is gone the run its checkpoints carry). OUTPUT/run.id holds the run's id; every checkpoint carries
# it, and pruning keeps the newest three of this run only. OUTPUT/launcher.pid holds this
# launcher's process id (for a SIGINT or SIGTERM from elsewhere).
#
# --restart PATH continues a run from its coupled checkpoints (DESIGN 2.4). PATH is a
# checkpoint file (OUTPUT/checkpoints/fluid_N.h5 or solid_N.h5: both of step N are taken),
# or a folder of one run (its output folder, or a folder of checkpoints: the newest step N
# with both fluid_N.h5 and solid_N.h5 is taken); each server gets --restart with its file
# and refuses, in one line (exit 2), a checkpoint of another scene file (only [run] steps
# may differ: continuing a finished run for more steps), of another A_T, or one that fails
# its checksums. The launcher refuses a checkpoint of another run than OUTPUT's. Without
# --output, a restart continues the files of the checkpoints' own run folder (solid.h5 and
# monitor.h5 carry on from the checkpoints' rows; the snapshots up to N are kept and listed
# in the XDMF files; fluid.log and solid.log are appended to), else it gets a new folder.
# A restart that is refused leaves that folder's outputs as they were: the servers write
# nothing into it before both have accepted their checkpoints (the fluid then prints
# "fluid: restart accepted"), and without that line the launcher takes back what it added
# (its lines in the logs, the traffic log, its pid and exit files, a new run.id).
#
# --time-ratio N runs both servers with A_T = N instead of the scene's [coupling]
# time_ratio; a restart must keep its checkpoint's A_T. --new-time-ratio N restarts at
# A_T = N on purpose (what the watchdog's retry does).
#
# The terminal shows one updating progress line (launch/progress.py: phase spin-up or free,
# LB step, simulated time, MLUPS, each side's compute and wait shares, ETA; prefixed with
# $COSIM_RUN_LABEL when set), the line "fluid: sheet released at step N", and the fluid's
# header, warnings and closing summary; its monitor rows stay in OUTPUT/fluid.log. --quiet
# shows only the closing summary. The output folder gets scene.toml (a copy of the scene)
# and provenance_fluid.toml, provenance_solid.toml (common/run/provenance.hpp).
#
# The stability watchdog (DESIGN 6, docs/stability.md): when a sentinel stops the run and
# the scene's [watchdog] retry = true, the fluid prints "fluid: watchdog retry: time_ratio
# = M ..., from the newest checkpoint before step S, at most R retries" for a sentinel that a
# smaller dt_CG may cure. The launcher then moves the failed attempt's logs and its
# checkpoints after the restart point into OUTPUT/retry_K/, and runs again with A_T = M from
# the newest pair of checkpoints before step S (from step 0 if there is none), at most R
# times. Each retry is reported on a "run-coupled: watchdog retry" line and in the exit line.
#
# --ranks N runs the fluid's grid in N slabs along z over MPI ranks on this machine
# (launch/mpirun-local.sh: shared memory only, in the run's network namespace; [run] blocks
# in the scene sets the layout): the coordinator and the session run on rank 0 alone, so
# the solid sees no difference, and the outputs and checkpoints are those of one process,
# bit for bit (DESIGN 8, docs/scaling.md). A checkpoint restarts on any number of ranks.
#
# Installed (cmake --install), PREFIX/bin/cosim-run runs this script (PREFIX/share/cosim/launch/): the servers are PREFIX/bin's,
# nothing is built, and the default output folder is ./out/<scene name>/<UTC date-time>.
# The servers are build/fluid/fluid and build/solid/solid, or those of $COSIM_BUILD_DIR where it
# is set (launch/folders.sh: e.g. a second build for x86-64-v3 beside build/).
#
# --solid-cmd replaces the solid server with another solid process that speaks the
# protocol (it gets the same arguments: SCENE --output DIR --channel-prefix P [--quiet],
# and the token in COSIM_RUN_TOKEN, the run's key file in COSIM_RUN_KEY_FILE). --extra starts
# one more process in the same network namespace for the run's duration (tests use it for a
# foreign publisher); it sees COSIM_CHANNEL_PREFIX, COSIM_LCM_URL and the token, never the
# key, and is stopped at the end.
#
# Each run has a secret key for its message MACs (protocol/README.md section 8b):
# 32 random bytes as 64 hexadecimal digits in OUTPUT/run.key, mode 0600 (readable by this
# user only; a restart into the run's folder keeps it), named to both servers by
# COSIM_RUN_KEY_FILE; it never travels on the bus. The
# replay tool and cosim-log verify a traffic log with it (--key-file OUTPUT/run.key).
#
# As root, both processes run in a private network namespace (unshare -n; lo up with
# multicast, 224.0.0.0/4 routed to lo), so no packet leaves this machine; otherwise they
# run on the host with the scene's ttl=0 URL. Each run gets its own token and channel
# prefix. --log records every channel of the run with cosim-record (docs/logs.md) into
# OUTPUT/traffic.lcmlog, appended to by a restart (its lines: OUTPUT/record.log).
# When one process dies, the other is given time to notice and stop by itself (it writes
# its checkpoint, its output and the reason): the scene's longer timeout (handshake_timeout_s
# or peer_timeout_s, [coupling]) plus 30 s to write (COSIM_SURVIVOR_GRACE_S overrides it);
# after a fluid that ended with a documented code past the handshake (it published stop_t),
# only 30 s to write (COSIM_STOP_GRACE_S), and a solid still running then is reported as
# "did not exit within its grace ... after the fluid's stop_t"; then it is stopped with
# SIGTERM (it still writes its checkpoint), and killed 30 s later. A solid that exits 0 while
# the fluid still runs is reported as having left before the run's end, with its last step.
# SIGINT (Ctrl-C) or SIGTERM to the launcher interrupts the fluid, which stops the run at its
# next step: both servers write a checkpoint of that step and the reason, exit 1.
# The exit status is always one of the servers' documented codes 0-4: the first failure's
# (a 4, "the peer stopped with an error", gives way to that peer's own 1, 2 or 3; a server
# killed by a signal counts as 1); or 5: both servers completed the run (exit 0), but the
# recorder (--log) ended before it (killed, or stopped from elsewhere), so
# OUTPUT/traffic.lcmlog is partial (one line says so; OUTPUT/record.pid holds the
# recorder's process id); OUTPUT/fluid.exit and OUTPUT/solid.exit hold each
# process's own status, OUTPUT/fluid.log and OUTPUT/solid.log their output.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
. "$root/launch/folders.sh"

usage() { echo "usage: bash launch/run-coupled.sh SCENE.toml [--output DIR] [--log] [--no-build] [--quiet] [--solid-cmd CMD] [--extra CMD] [--restart PATH] [--time-ratio N | --new-time-ratio N] [--ranks N]" >&2; exit 2; }
[ $# -ge 1 ] || usage
scene=$1; shift
output=""; log=0; build=1; ranks=""; quiet=""; solid_cmd=""; extra=""; restart=""; time_ratio=""; new_ratio=0
while [ $# -gt 0 ]; do
  case "$1" in
    --output) [ $# -ge 2 ] || usage; output=$2; shift 2 ;;
    --log) log=1; shift ;;
    --no-build) build=0; shift ;;
    --quiet) quiet="--quiet"; shift ;;
    --solid-cmd) [ $# -ge 2 ] || usage; solid_cmd=$2; shift 2 ;;
    --extra) [ $# -ge 2 ] || usage; extra=$2; shift 2 ;;
    --restart) [ $# -ge 2 ] || usage; restart=$2; shift 2 ;;
    --ranks) [ $# -ge 2 ] || usage; ranks=$2; shift 2
      [[ "$ranks" =~ ^[1-9][0-9]{0,3}$ ]] || {
        echo "run-coupled: --ranks $ranks: allowed: an integer from 1 to 9999 (MPI ranks of the fluid)" >&2; exit 2; } ;;
    --time-ratio|--new-time-ratio) [ $# -ge 2 ] || usage; [ "$1" = --new-time-ratio ] && new_ratio=1
      time_ratio=$2; shift 2
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
refuse() { echo "run-coupled: $*" >&2; exit 2; }
[ $new_ratio -eq 0 ] || [ -n "$restart" ] || refuse "--new-time-ratio: only with --restart (a fresh run takes --time-ratio N)"

[ "$installed" -eq 0 ] || build=0  # an installed launcher runs what is installed
if [ $build -eq 1 ]; then
  bash "$root/launch/bootstrap.sh"
  bash "$root/launch/build.sh" >/dev/null
fi
[ -x "$fluid_exe" ] || refuse "$fluid_exe is missing: build first (bash launch/build.sh, or drop --no-build)"
[ $log -eq 0 ] || [ -x "$record_exe" ] ||
  refuse "--log: $record_exe is missing: build first (bash launch/build.sh, or drop --no-build)"
if [ -n "$ranks" ] && [ "$installed" -eq 0 ]; then
  grep -q "COSIM_HAVE_MPI:INTERNAL=\(ON\|TRUE\|1\)" "$bin/CMakeCache.txt" 2>/dev/null ||
    refuse "--ranks $ranks: this build has no MPI (install libopenmpi-dev and openmpi-bin, then rebuild)"
fi
export COSIM_FLUID_RANKS=$ranks
name=$(basename "$scene" .toml)

# The run id a checkpoint carries ("run_id"; empty if it has none or is not HDF5: the
# servers then say what is wrong with it).
checkpoint_run_id() {
  /usr/bin/python3 -c 'import sys, h5py
with h5py.File(sys.argv[1], "r") as f:
    print(bytes(f["run_id"][()]).decode() if "run_id" in f else "")' "$1" 2>/dev/null || true
}
# Whose run a folder holds: its run.id, or where that is gone the run its checkpoints carry
# (empty: it names none).
folder_run_id() {
  local f id
  id=$(cat "$1/run.id" 2>/dev/null || true)
  [ -n "$id" ] && { echo "$id"; return; }
  for f in $(ls "$1/checkpoints" 2>/dev/null | grep -E '^(fluid|solid)_[0-9]{8}\.h5$'); do
    id=$(checkpoint_run_id "$1/checkpoints/$f"); [ -n "$id" ] && { echo "$id"; return; }
  done
}
# Whether a folder holds a run's outputs.
holds_run() { [ -f "$1/run.id" ] || [ -f "$1/monitor.h5" ] || [ -f "$1/solid.h5" ] || [ -d "$1/checkpoints" ]; }
# A new folder out/<scene name>/<UTC date-time>[-K] (COSIM_OUTPUT_ROOT instead of out/).
# An installed launcher's default is ./out/ (the prefix is not the user's).
out_root=$root/out
[ "$installed" -eq 0 ] || out_root=$PWD/out
run_folder() { new_folder "${COSIM_OUTPUT_ROOT:-$out_root}/$name"; }

export COSIM_FLUID_RESTART="" COSIM_SOLID_RESTART="" COSIM_NEW_TIME_RATIO=""
run_id=""
if [ -n "$restart" ]; then
  if [ -f "$restart" ]; then
    ckdir=$(cd "$(dirname "$restart")" && pwd)
    f=$(basename "$restart")
    [[ "$f" =~ ^(fluid|solid)_([0-9]{8})\.h5$ ]] ||
      refuse "--restart $restart: not a checkpoint file (allowed: OUTPUT/checkpoints/fluid_N.h5 or solid_N.h5, or a run's folder)"
    step=${BASH_REMATCH[2]}
    for side in fluid solid; do
      [ -f "$ckdir/${side}_$step.h5" ] || refuse "--restart $restart: no ${side}_$step.h5 beside it (a restart needs both sides' checkpoints of a step)"
    done
  elif [ -d "$restart" ]; then
    ckdir=$(cd "$restart" && pwd)
    [ -d "$ckdir/checkpoints" ] && ckdir=$ckdir/checkpoints
    step=$(newest_pair "$ckdir" "")
    [ -n "$step" ] || refuse "--restart $restart: no step with both fluid_N.h5 and solid_N.h5 (allowed: a checkpoint file, a run's output folder or its checkpoints folder)"
  else
    refuse "--restart $restart: no such file or folder"
  fi
  COSIM_FLUID_RESTART=$ckdir/fluid_$step.h5
  COSIM_SOLID_RESTART=$ckdir/solid_$step.h5
  run_id=$(checkpoint_run_id "$COSIM_FLUID_RESTART")
  solid_run=$(checkpoint_run_id "$COSIM_SOLID_RESTART")
  [ "$run_id" = "$solid_run" ] ||
    refuse "--restart $restart: fluid_$step.h5 is of run '$run_id', solid_$step.h5 of run '$solid_run' (allowed: both of one run)"
  if [ -z "$output" ]; then  # the checkpoints' own run folder, if they are in one
    parent=$(dirname "$ckdir")
    if [ "$(basename "$ckdir")" = checkpoints ] && [ "$(folder_run_id "$parent")" = "$run_id" ]; then
      output=$parent
    else
      output=$(run_folder)
    fi
  fi
  [ $new_ratio -eq 1 ] && COSIM_NEW_TIME_RATIO=1
fi
if [ -z "$output" ]; then
  output=$(run_folder) || refuse "cannot create a run folder under ${COSIM_OUTPUT_ROOT:-$out_root}/$name (allowed: a writable COSIM_OUTPUT_ROOT or --output DIR)"
fi
if [ -d "$output" ] && holds_run "$output"; then
  if [ -z "$restart" ]; then
    refuse "--output $output: holds an earlier run$([ -f "$output/run.id" ] && echo " ($(cat "$output/run.id"))") (allowed: a new or empty folder, e.g. the default out/$name/DATE-TIME, or --restart $output to continue that run)"
  fi
  # A folder that names no run takes no restart (it could be any run's).
  folder_run=$(folder_run_id "$output")
  [ -n "$folder_run" ] ||
    refuse "--restart $restart: $output holds a run's outputs but no run.id and no checkpoint naming its run (allowed: a new --output folder to continue run '$run_id' in)"
  if [ "$folder_run" != "$run_id" ]; then
    refuse "--restart $restart: a checkpoint of another run (run '$run_id'; $output is run '$folder_run') (allowed: a checkpoint of that folder's run, or a new --output folder to continue run '$run_id' in)"
  fi
fi
# A restart into a folder that holds a run: what this launch adds to the folder's own files
# (its logs, pid and exit files, run.id) is taken back unless the fluid says "restart
# accepted" (both servers accepted their checkpoints; they write nothing into the folder
# before): a refused restart leaves every file of the folder as it was.
kept_state=""
if [ -n "$restart" ] && [ -d "$output" ] && holds_run "$output"; then
  kept_state=$(mktemp -d "${TMPDIR:-/tmp}/cosim-restart.XXXXXX")
  for f in fluid.log solid.log record.log traffic.lcmlog extra.log; do
    [ -f "$output/$f" ] && stat -c %s "$output/$f" >"$kept_state/$f.size"
  done
  for f in run.id run.key launcher.pid fluid.pid solid.pid record.pid fluid.exit solid.exit; do
    [ -f "$output/$f" ] && cp -p "$output/$f" "$kept_state/$f"
  done
fi
# Puts the folder's own files back as kept_state found them.
take_back_attempt() {
  local f
  for f in fluid.log solid.log record.log traffic.lcmlog extra.log; do
    if [ -f "$kept_state/$f.size" ]; then truncate -s "$(cat "$kept_state/$f.size")" "$output/$f"; else rm -f "$output/$f"; fi
  done
  for f in run.id run.key launcher.pid fluid.pid solid.pid record.pid fluid.exit solid.exit; do
    if [ -f "$kept_state/$f" ]; then cp -p "$kept_state/$f" "$output/$f"; else rm -f "$output/$f"; fi
  done
}
mkdir -p "$output"
output=$(cd "$output" && pwd)
if [ -z "$run_id" ]; then
  run_id=$(date -u +%Y%m%dT%H%M%SZ)-$(od -An -N4 -tx1 /dev/urandom | tr -d ' \n')
fi
# The folder claimed for this run: run.id created only where none exists (noclobber: O_EXCL),
# so that of two launches given the same new --output at once one runs and one is refused.
if ! { [ -f "$output/run.id" ] && [ "$(cat "$output/run.id")" = "$run_id" ]; }; then
  (set -C; echo "$run_id" >"$output/run.id") 2>/dev/null ||
    refuse "--output $output: claimed by another launch at the same time (run '$(cat "$output/run.id" 2>/dev/null)') (allowed: a new or empty folder, e.g. the default out/$name/DATE-TIME)"
fi
export COSIM_RUN_ID=$run_id
echo $$ >"$output/launcher.pid"
[ -n "$restart" ] && echo "run-coupled: restarting run $run_id from step $((10#$step)) ($COSIM_FLUID_RESTART, $COSIM_SOLID_RESTART)"
token=$(od -An -N8 -tx1 /dev/urandom | tr -d ' \n')
prefix="COSIM_${token:0:8}_"
export COSIM_RUN_TOKEN=$token
# The run's key: one per run, not per launch. A restart into the run's folder keeps its key
# (the traffic log's earlier messages verify with the key the later ones carry); else it is
# written under umask 077 beside, then renamed into place.
if ! { [ -n "$restart" ] && [ -f "$output/run.key" ]; }; then
  (umask 077 && od -An -N32 -tx1 /dev/urandom | tr -d ' \n' >"$output/run.key.new" && echo >>"$output/run.key.new" &&
    mv -f "$output/run.key.new" "$output/run.key") || refuse "--output $output: cannot write the run's key file run.key"
fi
export COSIM_RUN_KEY_FILE=$output/run.key

export COSIM_SOLID_CMD=${solid_cmd:-$solid_exe}
export COSIM_EXTRA_CMD=$extra
# The fluid's OpenMP threads sleep while they wait (unless OMP_WAIT_POLICY is set): the solid
# computes on the same cores, and a thread that spins between parallel regions (libgomp's
# default) takes the core the solid needs (docs/results/wait-policy-20261206-0042.md).
export OMP_WAIT_POLICY=${OMP_WAIT_POLICY:-passive}
inner=(bash "$root/launch/coupled-inner.sh" "$root" "$scene" "$output" "$prefix" "$log" "$quiet")
retries=0; retried=""
# SIGINT (Ctrl-C) or SIGTERM: passed on to the supervisor (coupled-inner.sh), which
# passes it on to the fluid; the run then ends as usual, with both checkpoints and reasons.
inner_pid=""; interrupted=""
on_interrupt() {
  interrupted=$1
  echo "run-coupled: SIG$1: stopping the run at the fluid's next step (both servers write a checkpoint)" >&2
  [ -n "$inner_pid" ] && kill -"$(signal_for_inner)" "$inner_pid" 2>/dev/null
}
# SIGINT travels to the supervisor as SIGUSR1: a background shell cannot trap SIGINT.
signal_for_inner() { [ "$interrupted" = INT ] && echo USR1 || echo TERM; }
trap 'on_interrupt INT' INT
trap 'on_interrupt TERM' TERM
while :; do
  export COSIM_TIME_RATIO=$time_ratio
  rm -f "$output/fluid.exit" "$output/solid.exit" "$output/fluid.pid" "$output/solid.pid"
  # This attempt's lines of fluid.log start here (a restart appends to it).
  log_from=1
  [ -f "$output/fluid.log" ] && log_from=$(($(wc -l <"$output/fluid.log") + 1))
  echo "run-coupled: scene $scene, run $run_id, token $token, channels ${prefix}*, output $output${time_ratio:+, A_T = $time_ratio}"
  if [ "$(id -u)" -eq 0 ] && command -v unshare >/dev/null 2>&1; then
    launch=(unshare -n "${inner[@]}")
  else
    echo "run-coupled: not root: running on the host network with the scene's ttl=0 URL" >&2
    launch=("${inner[@]}")
  fi
  # In the background, so that a trapped signal is handled at once (bash runs a trap only
  # once a foreground command has ended).
  set +e
  "${launch[@]}" &
  inner_pid=$!
  [ -n "$interrupted" ] && kill -"$(signal_for_inner)" "$inner_pid" 2>/dev/null
  while :; do
    wait "$inner_pid"
    status=$?
    [ $status -gt 128 ] && kill -0 "$inner_pid" 2>/dev/null && continue
    break
  done
  inner_pid=""
  set -e
  if [ $status -eq 1 ] && [ "$(id -u)" -ne 0 ] && grep -q "cannot open LCM" "$output/fluid.log" 2>/dev/null; then
    echo "run-coupled: LCM could not open its multicast socket: enable multicast on lo" \
         "(ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo) or run as root" >&2
  fi
  [ -z "$interrupted" ] || break
  # The watchdog's retry ([watchdog] retry): the fluid names the new A_T, the step the
  # restart must precede and how many retries the scene allows.
  advice=$(tail -n +"$log_from" "$output/fluid.log" 2>/dev/null | grep -E '^fluid: watchdog retry: time_ratio = [0-9]+ ' | tail -1 || true)
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
  for f in fluid.log solid.log fluid.exit solid.exit record.log extra.log traffic.lcmlog; do
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
  old_ratio=${time_ratio:-$(scene_value "$scene" coupling.time_ratio)}
  retried="$retried${retried:+; }retry $retries: A_T ${old_ratio:-150} -> $next from $start"
  echo "run-coupled: watchdog retry $retries of $allowed: $why"
  echo "run-coupled: watchdog retry $retries of $allowed: A_T ${old_ratio:-150} -> $next, from $start; the failed attempt's logs are in $kept"
  time_ratio=$next
  export COSIM_NEW_TIME_RATIO=1
  token=$(od -An -N8 -tx1 /dev/urandom | tr -d ' \n')
  prefix="COSIM_${token:0:8}_"
  export COSIM_RUN_TOKEN=$token
  inner=(bash "$root/launch/coupled-inner.sh" "$root" "$scene" "$output" "$prefix" "$log" "$quiet")
done
fluid_exit=$(cat "$output/fluid.exit" 2>/dev/null || echo '?')
solid_exit=$(cat "$output/solid.exit" 2>/dev/null || echo '?')
if [ -n "$kept_state" ]; then
  if [ $retries -eq 0 ] && ! tail -n +"$log_from" "$output/fluid.log" 2>/dev/null | grep -q '^fluid: restart accepted'; then
    take_back_attempt
    rm -rf "$kept_state"
    echo "run-coupled: fluid exit $fluid_exit, solid exit $solid_exit: restart not accepted by both sides; every file of $output is as it was${interrupted:+; interrupted by SIG$interrupted}"
    if [ $status -ge 0 ] && [ $status -le 4 ]; then exit $status; fi
    exit 1
  fi
  rm -rf "$kept_state"
fi
echo "run-coupled: fluid exit $fluid_exit, solid exit $solid_exit; outputs in $output" \
     "(monitor.h5, solid.h5, fluid.log, solid.log$([ "$log" -eq 1 ] && echo ', traffic.lcmlog')$([ $status -eq 5 ] && echo ' (partial: the recorder ended before the run)'))${retried:+; watchdog retries: $retried}${interrupted:+; interrupted by SIG$interrupted}"
# Always one of the documented codes 0-4, or 5: the run completed, its traffic log (--log)
# is partial (anything else, e.g. unshare failing, is 1).
if [ $status -ge 0 ] && [ $status -le 5 ]; then exit $status; fi
exit 1
