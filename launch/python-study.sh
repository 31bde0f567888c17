#!/usr/bin/env bash
# The shared start of the study scripts (error-study.sh, stability-matrix.sh,
# added-mass-study.sh): installs what is missing and builds, unless --no-build is among the
# arguments, then runs launch/SCRIPT.py with Debian's /usr/bin/python3 (h5py, numpy,
# matplotlib) and the other arguments.
#
#   bash launch/python-study.sh SCRIPT.py [--no-build] [ARGS...]
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
script=$1
shift
build=1
args=()
for a in "$@"; do
  if [ "$a" = "--no-build" ]; then build=0; else args+=("$a"); fi
done
if [ $build -eq 1 ]; then
  bash "$root/launch/bootstrap.sh"
  bash "$root/launch/build.sh" >/dev/null
fi
exec /usr/bin/python3 "$root/launch/$script" "${args[@]+"${args[@]}"}"
