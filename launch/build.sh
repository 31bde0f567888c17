#!/usr/bin/env bash
# Configures and builds the project into build/ (Release). Extra arguments go to CMake's
# configure step, e.g. -DCOSIM_WERROR=ON.
#
#   bash launch/build.sh [CMAKE_OPTIONS...]
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
cmake -S "$root" -B "$root/build" -DCMAKE_BUILD_TYPE=Release "$@" >/dev/null
cmake --build "$root/build" -j "$(nproc)"
