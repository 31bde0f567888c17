#!/usr/bin/env bash
# Installs what is missing, builds with warnings as errors, and runs every test (CTest
# labels: short, long). Extra arguments go to ctest, e.g. -L short.
#
#   bash launch/run-tests.sh [CTEST_OPTIONS...]
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$root/launch/bootstrap.sh"
bash "$root/launch/build.sh" -DCOSIM_WERROR=ON
cd "$root/build"
ctest --output-on-failure --timeout 900 "$@"
