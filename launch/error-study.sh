#!/usr/bin/env bash
# Error against run time (DESIGN 6): one row per accuracy knob (grid resolution of a fluid
# validation case and of a coupled case, A_T, RCGP truncation range, coupling scheme,
# floating-point precision), each with its error against a reference, wall time and peak
# memory, and the settings on the best error-for-time front.
#
#   bash launch/error-study.sh [--short] [--out DIR] [--docs] [--no-build] [--repeats N]
#                              [--threads N] [--only KNOB,KNOB]
#
# Full (about 20-30 min on 2 cores): writes docs/error-vs-runtime.md and
# docs/figures/error-vs-runtime/*.png. --short (about 2 min, 1 repeat, fewer and cheaper
# settings): writes only into DIR (default out/error-study) unless --docs. Both write
# DIR/error-vs-runtime.md, DIR/results.tsv, DIR/results.json, DIR/figures/*.png and the runs
# (scenes, logs, HDF5) under DIR/runs/. Installs what is missing and builds first unless
# --no-build. The study itself is launch/error_study.py (run with Debian's /usr/bin/python3,
# which has h5py, numpy and matplotlib).
#
# Exit status: 0 done; 1 a run failed (one line naming it and its log); 2 bad arguments.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
exec bash "$(dirname "${BASH_SOURCE[0]}")/python-study.sh" error_study.py "$@"
