#!/usr/bin/env bash
# What a recorder keeps of a coupled run when it lags (docs/logs.md, "Why not lcm-logger"):
# lcm-logger (Debian's liblcm-bin) against cosim-record (tools/record), each as
# `run-coupled.sh --log` runs it, and prints two Markdown tables.
#
# 1. Under load: the 30-step parallel-scheme run of the replay tests (coupled_small, 10 rigid
#    steps), recorded N times by each recorder at `nice -n 19` beside one busy loop per core.
# 2. Stopped (root: a private network namespace): the recorder stopped (SIGSTOP) once it
#    listens, lcm-logplayer plays one complete log of table 1 onto the bus meanwhile, then the
#    recorder is continued and at once asked to stop (SIGINT); N tries each, cosim-record also
#    with the system's default socket buffer (--receive-buffer 0).
#
#   bash launch/record-under-load.sh [--runs N] [--no-build]
#
# The runs go to out/record-under-load/DATE-TIME/ (launch/folders.sh); nothing before is
# touched. N defaults to 3.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
. "$root/launch/folders.sh"

runs=3 build=1
while [ $# -gt 0 ]; do
  case $1 in
    --runs)
      [[ ${2:-} =~ ^[1-9][0-9]*$ ]] || { echo "record-under-load: --runs \"${2:-}\": give a whole number >= 1" >&2; exit 2; }
      runs=$2; shift 2 ;;
    --no-build) build=0; shift ;;
    *) echo "record-under-load: unknown argument \"$1\" (allowed: --runs N, --no-build; see --help)" >&2; exit 2 ;;
  esac
done
if [ $build -eq 1 ]; then
  bash "$root/launch/bootstrap.sh"
  bash "$root/launch/build.sh" >/dev/null
fi
for exe in fluid/fluid solid/solid tools/record/cosim-record tools/log/cosim-log; do
  [ -x "$bin/$exe" ] || { echo "record-under-load: $bin/$exe is missing: build first (bash launch/build.sh, or drop --no-build)" >&2; exit 2; }
done
command -v lcm-logger >/dev/null || { echo "record-under-load: lcm-logger is missing (Debian's liblcm-bin; launch/bootstrap.sh installs it)" >&2; exit 2; }

out=$(new_folder "$root/out/record-under-load")
mkdir -p "$out"
url="udpm://239.255.76.67:7667?ttl=0"

# The scene: coupled_small cut to 30 steps, 10 rigid, the parallel scheme, no field output.
sed -e 's/^steps *=.*/steps = 30/' -e 's/^rigid_steps *=.*/rigid_steps = 10/' -e 's/^fields_every *=.*/fields_every = 0/' \
  -e 's/^sheets_every *=.*/sheets_every = 0/' -e 's/^monitor_every *=.*/monitor_every = 10/' \
  -e 's/^\[coupling\]$/[coupling]\nscheme = "parallel"/' "$root/scenes/coupled_small.toml" >"$out/scene.toml"

# A build folder per recorder for the launcher: this build's servers, and in the place of
# cosim-record the recorder under test at nice 19. lcm-logger gets the arguments and the
# "listening" line the launcher used to give it (0.3 s after its start).
shim() {
  local d=$out/build-$1
  mkdir -p "$d/tools/record"
  ln -s "$bin/fluid" "$d/fluid"; ln -s "$bin/solid" "$d/solid"; cp "$bin/CMakeCache.txt" "$d/"
  if [ "$1" = lcm-logger ]; then
    cat >"$d/tools/record/cosim-record" <<'EOF'
#!/usr/bin/env bash
# cosim-record LOG --channels REGEX --lcm-url URL, done by lcm-logger as the launcher ran it.
( sleep 0.3; echo "cosim-record: recording (lcm-logger)" ) &
exec nice -n 19 lcm-logger -f -c "$3" --lcm-url="$5" "$1"
EOF
  else
    printf '#!/usr/bin/env bash\nexec nice -n 19 %q "$@"\n' "$bin/tools/record/cosim-record" >"$d/tools/record/cosim-record"
  fi
  chmod +x "$d/tools/record/cosim-record"
  echo "$d"
}

# "EVENTS; solid_state_t steps A..B (N distinct): missing K (...); fluid_state_t ...; stop_t xK" of a log
# ("0" for an empty or missing one).
describe() {
  local s
  [ -s "$1" ] || { echo "0"; return; }
  s=$("$bin/tools/log/cosim-log" summary "$1" 2>&1) || { echo "unreadable: $(head -1 <<<"$s")"; return; }
  awk '/^log / { ev = $3 }
       /SOLID_STATE +[0-9]+ messages/ { side = "solid" } /FLUID_STATE +[0-9]+ messages/ { side = "fluid" }
       side != "" && /steps [0-9]+\.\.[0-9]+ \(/ { sub(/^ +/, ""); sub(/, duplicated.*/, ""); d[side] = $0; side = "" }
       /stop_t at step/ { n = split($0, a, " x"); stops = a[n] }
       END { printf "%s; solid_state_t %s; fluid_state_t %s; stop_t x%s", ev, d["solid"] ? d["solid"] : "none",
             d["fluid"] ? d["fluid"] : "none", stops ? stops : "0" }' <<<"$s"
}

busy=()
trap 'for p in "${busy[@]}"; do kill "$p" 2>/dev/null; done' EXIT
for ((k = 0; k < $(nproc); k++)); do (while :; do :; done) & busy+=($!); done

echo "CPU: $(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1), $(nproc) cores; runs in $out"
echo
echo "Under load (the recorder at nice 19 beside $(nproc) busy loops): what the log holds of the 30-step run"
echo
echo "| recorder | run | launcher exit | events; solid_state_t steps; fluid_state_t steps; stop_t copies |"
echo "|---|---|---|---|"
complete=""
for rec in lcm-logger cosim-record; do
  b=$(shim $rec)
  for ((i = 1; i <= runs; i++)); do
    o=$out/$rec-$i
    s=0
    COSIM_BUILD_DIR=$b bash "$root/launch/run-coupled.sh" "$out/scene.toml" --output "$o" --log --no-build --quiet \
      >"$o.launcher.log" 2>&1 || s=$?
    echo "| $rec | $i | $s | $(describe "$o/traffic.lcmlog") |"
    [ $rec = cosim-record ] && [ -z "$complete" ] && [ $s -eq 0 ] && complete=$o/traffic.lcmlog
  done
done

echo
if [ "$(id -u)" -ne 0 ] || ! unshare -n true 2>/dev/null; then
  echo "Stopped recorder: not measured (needs root for a private network namespace, unshare -n)"
  exit 0
fi
[ -n "$complete" ] || { echo "record-under-load: no complete log from cosim-record to play" >&2; exit 1; }
echo "Stopped recorder (SIGSTOP while lcm-logplayer plays $(describe "$complete" | cut -d';' -f1) messages, then SIGCONT and SIGINT at once)"
echo
echo "| recorder | try | events in the log |"
echo "|---|---|---|"
for rec in lcm-logger "cosim-record --receive-buffer 0" cosim-record; do
  for ((i = 1; i <= runs; i++)); do
    d=$out/stopped-${rec// /_}-$i
    mkdir -p "$d"
    case $rec in
      lcm-logger) start="lcm-logger -q -f -c 'COSIM_.*' --lcm-url='$url' $d/got.lcmlog & r=\$!; sleep 0.5" ;;
      *) start="$bin/tools/record/${rec% --*} $d/got.lcmlog --channels 'COSIM_.*' --lcm-url '$url' ${rec#cosim-record} >$d/rec.out 2>&1 & r=\$!
for k in \$(seq 200); do grep -q '^cosim-record: recording ' $d/rec.out && break; sleep 0.05; done" ;;
    esac
    cat >"$d/stopped.sh" <<EOF
ip link set lo up; ip link set lo multicast on; ip route add 224.0.0.0/4 dev lo
$start
kill -STOP \$r
timeout 60 lcm-logplayer --lcm-url='$url' $complete >/dev/null
kill -CONT \$r; kill -INT \$r; wait \$r
EOF
    unshare -n bash "$d/stopped.sh" >"$d/out.txt" 2>&1 || true
    echo "| $rec | $i | $(describe "$d/got.lcmlog" | cut -d';' -f1) |"
  done
done
