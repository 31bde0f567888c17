#!/usr/bin/env bash
# Runs a bench or study command and keeps what it prints as a result file: docs/results/
# NAME-YYYYMMDD-HHMM.md (or --dir DIR), headed by what makes the numbers a claim: the command
# line, the commit (and whether the tree differed from it), the CPU model, its core count, the
# load average before and after, and the start time in UTC. The command's output is shown as
# it runs and kept verbatim below the header; the exit status is the command's. An existing
# file is never overwritten (a second run in the same minute gets -2, -3, ...). The guide's
# pages (docs/performance.md, docs/scale.md, ...) link the result files they quote.
#
#   bash launch/record-result.sh NAME [--dir DIR] -- COMMAND [ARGS...]
#   e.g. bash launch/record-result.sh bench-precision -- bash launch/bench-precision.sh --repeat 5
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
usage() { awk 'NR == 1 { next } /^#/ { sub(/^# ?/, ""); print; next } { exit }' "${BASH_SOURCE[0]}"; }
name="" dir="$root/docs/results"
while [ $# -gt 0 ] && [ "$1" != "--" ]; do
  case "$1" in
    -h|--help) usage; exit 0 ;;
    --dir) [ $# -ge 2 ] || { echo "record-result: --dir needs a folder" >&2; exit 2; }; dir=$2; shift ;;
    -*) echo "record-result: unknown option $1 (--dir DIR, then -- COMMAND)" >&2; exit 2 ;;
    *) [ -z "$name" ] || { echo "record-result: two names, '$name' and '$1' (one NAME, then -- COMMAND)" >&2; exit 2; }
       name=$1 ;;
  esac
  shift
done
[ -n "$name" ] || { echo "record-result: no NAME (bash launch/record-result.sh NAME -- COMMAND)" >&2; exit 2; }
[[ $name =~ ^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$ ]] ||
  { echo "record-result: NAME '$name': allowed: letters, digits, '_', '.', '-' (at most 64, not starting with a symbol)" >&2; exit 2; }
[ "${1-}" = "--" ] && [ $# -ge 2 ] || { echo "record-result: no COMMAND after '--'" >&2; exit 2; }
shift
mkdir -p "$dir" || { echo "record-result: --dir $dir: cannot create it" >&2; exit 2; }
stamp=$(date -u '+%Y%m%d-%H%M')
file="$dir/$name-$stamp.md"
k=2
while ! (set -o noclobber; : >"$file") 2>/dev/null; do
  file="$dir/$name-$stamp-$k.md"
  k=$((k + 1))
done
commit=$(git -C "$root" rev-parse --short HEAD 2>/dev/null || echo unknown)
dirty=""
git -C "$root" diff --quiet HEAD -- 2>/dev/null || dirty=" (with uncommitted changes)"
cpu=$(sed -n 's/^model name[[:space:]]*: //p' /proc/cpuinfo | head -1)
{
  echo "# $name, $(date -u '+%Y-%m-%d %H:%M UTC')"
  echo
  echo "- command: \`$(printf '%q ' "$@" | sed 's/ $//')\`"
  echo "- commit: $commit$dirty"
  echo "- CPU: ${cpu:-unknown}, $(getconf _NPROCESSORS_ONLN) cores; load average before: $(cut -d' ' -f1-3 /proc/loadavg)"
  echo
  echo '```'
} >"$file"
status=0
"$@" 2>&1 | tee -a "$file" || status=${PIPESTATUS[0]}
{
  echo '```'
  echo
  echo "Exit status $status; load average after: $(cut -d' ' -f1-3 /proc/loadavg)."
} >>"$file"
echo "record-result: kept in $file" >&2
exit "$status"
