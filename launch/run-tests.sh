#!/usr/bin/env bash
# Installs what is missing, builds with warnings as errors, and runs every test (CTest
# labels: short, long). Extra arguments go to ctest, e.g. -L short. Then, where the CPU runs
# a higher level than x86-64-v3 (AVX2), the kernel, precision and reproducibility tests again
# on a second build for an AVX2 CPU: everything compiled with -march=x86-64-v3 into
# build-x86-64-v3/ (launch/folders.sh; only those tests and the servers they run) and the
# fluid kernel forced to that level (COSIM_KERNEL_LEVEL, fluid/collision/kernel_dispatch.hpp): the
# code an AVX2-only CPU runs, every bit-identity test on it.
# Two tests run at a time (COSIM_TEST_JOBS, default 2): on CI's 2 cores both are shared, the
# busy machine every test is sized for (each well inside its timeout there), and the suite
# takes about half the time of one test at a time. A later -j in the arguments wins.
#
#   bash launch/run-tests.sh [CTEST_OPTIONS...]
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
. "$root/launch/folders.sh"
bash "$root/launch/bootstrap.sh"
bash "$root/launch/build.sh" -DCOSIM_WERROR=ON
cd "$bin"
status=0
jobs=${COSIM_TEST_JOBS:-2}
if ! [[ $jobs =~ ^[1-9][0-9]{0,2}$ ]]; then
  echo "run-tests.sh: COSIM_TEST_JOBS = '$jobs': the number of tests at a time must be an integer from 1 to 999" >&2
  exit 2
fi
ctest --output-on-failure --timeout 900 -j "$jobs" "$@" || status=$?
# The level the bench picks by itself (its first line: "CPU: ...; kernel level L (...)").
best=$(COSIM_KERNEL_LEVEL= ./fluid/bench --grids box --box 8 --threads 1 --steps 1 --repeat 1 --no-ib \
       2>/dev/null | sed -n 's/^CPU: .*; kernel level \([^ ]*\) .*/\1/p')
if [ "$best" = "x86-64-v4" ]; then
  v3=$root/build-x86-64-v3
  echo "== again on an x86-64-v3 build ($v3), kernel level x86-64-v3 (this CPU's own level: $best)"
  COSIM_BUILD_DIR=$v3 bash "$root/launch/build.sh" -DCOSIM_WERROR=ON -DCOSIM_NATIVE=OFF -DCOSIM_ARCH=x86-64-v3 \
    -- --target test_kernel_dispatch test_lbm_invariants test_precision test_reproducibility
  cd "$v3"
  COSIM_KERNEL_LEVEL=x86-64-v3 ctest --output-on-failure --timeout 900 -j "$jobs" \
    -R '^(Kernel|Lattice|Precision|Reproducibility)\.' "$@" || status=$?
else
  echo "== the kernel level of this CPU is ${best:-unknown}: no second pass with x86-64-v3"
fi
exit "$status"
