#!/usr/bin/env bash
# Configures and builds the project into build/ (Release; $COSIM_BUILD_DIR instead where set,
# launch/folders.sh). Arguments go to CMake's configure step, e.g. -DCOSIM_WERROR=ON; those
# after `--` to its build step, e.g. `-- --target fluid solid` to build only those.
#
#   bash launch/build.sh [CMAKE_OPTIONS...] [-- BUILD_OPTIONS...]
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
. "$root/launch/folders.sh"
configure=() build=()
while [ $# -gt 0 ]; do
  if [ "$1" = "--" ]; then shift; build=("$@"); break; fi
  configure+=("$1"); shift
done
cmake -S "$root" -B "$bin" -DCMAKE_BUILD_TYPE=Release "${configure[@]}" >/dev/null
cmake --build "$bin" -j "$(nproc)" "${build[@]}"
