#!/usr/bin/env bash
# lcm-spy on the project's channels, with the message types built for Java (docs/logs.md).
#
#   bash launch/lcm-spy.sh [--url URL]            lcm-spy on this network (a run on the host)
#   bash launch/lcm-spy.sh --run OUTPUT_DIR       lcm-spy inside a running run's private network
#                                                 namespace (root; the fluid's OUTPUT/fluid.pid)
#   bash launch/lcm-spy.sh --replay LOG [--speed S]  lcm-logplayer plays LOG to lcm-spy in a
#                                                 private network namespace of their own (root)
#   bash launch/lcm-spy.sh --types                headless: the types lcm-spy finds by fingerprint
#   bash launch/lcm-spy.sh --check LOG [--fields] headless: decode every event of LOG the way
#                                                 lcm-spy does, per channel (exit 1 if any fails)
#   common: [--java-dir DIR] (default build/java) [--build-only]
#
# The types: lcm-gen --java on protocol/lcm/*.lcm, javac against Debian's liblcm-java
# (/usr/share/java/lcm.jar), into DIR/cosimlcm.jar (rebuilt when a .lcm file is newer).
# Needs javac and java (default-jdk-headless), liblcm-java and, for lcm-spy's charts,
# libjchart2d-java; without them it says so in one line and exits 1. lcm-spy is a Swing GUI:
# it needs a display (DISPLAY; an X server's unix socket also works inside a network
# namespace, a TCP display such as ssh -X's localhost:10 does not). Debian's /usr/bin/lcm-spy
# passes -Xincgc, which Java 9 and later refuse ("Unrecognized option: -Xincgc"), so this
# script starts lcm.spy.Spy itself with the same class path and options otherwise.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
default_url="udpm://239.255.76.67:7667?ttl=0"

die() { local c=$1; shift; echo "lcm-spy.sh: $*" >&2; exit "$c"; }
usage() {  # one line: what was wrong, then the usage
  echo "lcm-spy.sh: ${1:-missing arguments}; usage: bash launch/lcm-spy.sh [--url URL | --run OUTPUT_DIR |" \
       "--replay LOG [--speed S] | --types | --check LOG [--fields]] [--java-dir DIR] [--build-only]" >&2
  exit 2
}

mode=spy url=$default_url run_dir="" log="" speed=1 fields="" java_dir=$root/build/java build_only=0
while [ $# -gt 0 ]; do
  case "$1" in
    --url) [ $# -ge 2 ] || usage "--url needs a value"; url=$2; shift 2 ;;
    --run) [ $# -ge 2 ] || usage "--run needs a value"; mode=run; run_dir=$2; shift 2 ;;
    --replay) [ $# -ge 2 ] || usage "--replay needs a value"; mode=replay; log=$2; shift 2 ;;
    --speed) [ $# -ge 2 ] || usage "--speed needs a value"; speed=$2; shift 2 ;;
    --types) mode=types; shift ;;
    --check) [ $# -ge 2 ] || usage "--check needs a value"; mode=check; log=$2; shift 2 ;;
    --fields) fields=--fields; shift ;;
    --java-dir) [ $# -ge 2 ] || usage "--java-dir needs a value"; java_dir=$2; shift 2 ;;
    --build-only) build_only=1; shift ;;
    -h|--help) awk 'NR > 1 && /^#/ { sub(/^# ?/, ""); print; next } NR > 1 { exit }' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) usage "unknown option $1" ;;
  esac
done
case "$url" in
  udpm://*\?*ttl=0*) ;;
  *) die 2 "--url $url: allowed only udpm:// URLs with ttl=0 (no packet may leave this machine)" ;;
esac
if [ "$mode" = replay ] || [ "$mode" = check ]; then
  [ -f "$log" ] || die 2 "$log: no such log file"
  log=$(cd "$(dirname "$log")" && pwd)/$(basename "$log")
fi
if [ "$mode" = run ]; then
  [ -f "$run_dir/fluid.pid" ] || die 2 "$run_dir/fluid.pid: no such file; give the OUTPUT folder of a running launch/run-coupled.sh"
fi
[[ "$speed" =~ ^[0-9]*\.?[0-9]+$ ]] || die 2 "--speed $speed: allowed a positive number"

# Prerequisites (exit 1: missing system packages, not bad input).
lcm_jar=/usr/share/java/lcm.jar
chart_jar=/usr/share/java/jchart2d.jar
command -v javac >/dev/null 2>&1 && command -v java >/dev/null 2>&1 ||
  die 1 "Java is not available (no javac/java): apt-get install default-jdk-headless liblcm-java libjchart2d-java (docs/logs.md)"
[ -f "$lcm_jar" ] || die 1 "$lcm_jar is missing: apt-get install liblcm-java (LCM's Java library, lcm-spy's classes)"

# Build the types (and the headless checker) when a source is newer than the jar.
mkdir -p "$java_dir"
jar=$java_dir/cosimlcm.jar
checker_src=$root/tools/log/java/CosimSpyCheck.java
stale=0
[ -f "$jar" ] && [ -f "$java_dir/check/CosimSpyCheck.class" ] || stale=1
for f in "$root"/protocol/lcm/*.lcm "$checker_src"; do [ "$f" -nt "$jar" ] && stale=1; done
if [ $stale -eq 1 ]; then
  rm -rf "$java_dir/src" "$java_dir/classes" "$java_dir/check"
  mkdir -p "$java_dir/src" "$java_dir/classes" "$java_dir/check"
  tmp=$java_dir/build.log
  if ! { lcm-gen --java --jpath "$java_dir/src" "$root"/protocol/lcm/*.lcm &&
         javac -nowarn -cp "$lcm_jar" -d "$java_dir/classes" "$java_dir"/src/cosimlcm/*.java &&
         jar cf "$jar.tmp" -C "$java_dir/classes" . && mv "$jar.tmp" "$jar" &&
         javac -nowarn -cp "$lcm_jar:$jar" -d "$java_dir/check" "$checker_src"; } >"$tmp" 2>&1; then
    die 1 "building the Java types failed: $(grep -v '^\s*$' "$tmp" | head -1) (all of it in $tmp)"
  fi
fi
[ $build_only -eq 1 ] && { echo "lcm-spy.sh: built $jar"; exit 0; }

cp=$lcm_jar:$jar
[ -f "$chart_jar" ] && cp=$cp:$chart_jar
# ClassDiscoverer (lcm-spy's type search) reports classes of lcm.jar it cannot load without
# jchart2d on stderr; those lines are noise for the headless modes.
quiet_discoverer() { grep -v -e '^ClassDiscoverer:' -e '^ *jar: ' -e '^ *class: ' -e '^Found [0-9]* LCM types' >&2 || true; }
case "$mode" in
  types|check)
    if [ "$mode" = types ]; then args=(--types); else args=("$log" $fields); fi
    set +e +o pipefail
    { java -cp "$cp:$java_dir/check" CosimSpyCheck "${args[@]}" 2>&1 >&3 | quiet_discoverer; } 3>&1
    exit "${PIPESTATUS[0]}" ;;
esac

[ -f "$chart_jar" ] || die 1 "$chart_jar is missing: apt-get install libjchart2d-java (lcm-spy's charts)"
[ -n "${DISPLAY:-}" ] ||
  die 1 "no display (DISPLAY is unset): lcm-spy is a Swing GUI; use --check LOG or --types without one"
spy=(java -Djava.net.preferIPv4Stack=true -Xmx512m -Xms64m -ea -cp "$cp" lcm.spy.Spy --lcm-url="$url")
case "$mode" in
  spy)
    echo "lcm-spy.sh: lcm-spy on $url" >&2
    exec "${spy[@]}" ;;
  run)
    [ "$(id -u)" -eq 0 ] || die 1 "--run needs root (nsenter into the run's network namespace)"
    pid=$(cat "$run_dir/fluid.pid")
    kill -0 "$pid" 2>/dev/null || die 1 "the fluid of $run_dir (pid $pid) is not running"
    echo "lcm-spy.sh: lcm-spy in the network namespace of pid $pid on $url" >&2
    exec nsenter -t "$pid" -n "${spy[@]}" ;;
  replay)
    [ "$(id -u)" -eq 0 ] || die 1 "--replay needs root (a private network namespace, unshare -n)"
    echo "lcm-spy.sh: replaying $log at speed $speed to lcm-spy on $url in a private network namespace" >&2
    # lo up with multicast and 224.0.0.0/4 routed to lo, as launch/coupled-inner.sh does.
    exec unshare -n bash -c '
      ip link set lo up && ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo || exit 1
      url=$1 log=$2 speed=$3; shift 3
      "$@" & spy=$!
      sleep 3   # lcm-spy subscribes once its window is up
      lcm-logplayer --lcm-url="$url" --speed="$speed" "$log"
      wait $spy' replay "$url" "$log" "$speed" "${spy[@]}" ;;
esac
