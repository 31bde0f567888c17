#!/usr/bin/env bash
# The stability matrix of DESIGN 6 (docs/stability.md): every case of scenes/stability/ run
# and classified (stable, or stopped with a diagnosis before any NaN is written), the report
# and its figures written.
#
#   bash launch/stability-matrix.sh [--short] [--output DIR] [--doc PATH] [--cases a,b]
#                                   [--report-only] [--no-build]
#
# --short runs the few-second version of each case (the test StabilityMatrixShort) and writes
# its report to OUTPUT/stability.md unless --doc says otherwise; without it the report is
# docs/stability.md. --report-only writes the report and figures again from
# OUTPUT/summary.json of the last run. Exit status: 0 every case ended stable or stopped with
# a diagnosis; 1 a case violated that (a crash, a hang, a stop without a diagnosis, a NaN in a
# file); 2 bad arguments or nothing built.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
exec bash "$(dirname "${BASH_SOURCE[0]}")/python-study.sh" stability_matrix.py "$@"
