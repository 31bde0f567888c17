#!/usr/bin/env bash
# The added-mass limit of the coupling schemes (issue 7 item 4): the light_sheet scene with
# lighter and lighter CGPs at one A_T, serial against implicit, each against the serial
# scheme at 8 x the A_T. Writes out/added-mass/added-mass.md, and docs/added-mass.md with
# --docs. About 10 minutes on 2 cores (two blocks, A_T = 4000 and 40000).
#
#   bash launch/added-mass-study.sh [--docs] [--no-build] [--out DIR] [--block A_T:ATOMS,...]...
#                                   [--reference-factor F]
#
# Installs what is missing and builds first unless --no-build. Exit status: 0 done; 1 a run
# could not be read; 2 bad arguments.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
exec bash "$(dirname "${BASH_SOURCE[0]}")/python-study.sh" added_mass_study.py "$@"
