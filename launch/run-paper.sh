#!/usr/bin/env bash
# The paper's single graphene at an angle of attack of 90 deg and Re 40 (section 3.1,
# Figs. 5 and 6): fluid and solid coupled over LCM, then the plots.
#
#   bash launch/run-paper.sh [--full] [--output DIR] [--no-build]
#
# Default: the reduced preset (half the resolution, same physics and times; a few minutes
# on 2 cores); --full: the paper's 120 x 60 x 90 grid, 15000 rigid + 15000 free LB steps.
# Ends by listing the PNGs (launch/plot.py) and the run's HDF5/XDMF outputs.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
scene=single_theta90_re40_reduced
output=""
build=1
while [ $# -gt 0 ]; do
  case "$1" in
    --full) scene=single_theta90_re40; shift ;;
    --output) [ $# -ge 2 ] || { echo "run-paper: --output needs a folder" >&2; exit 2; }; output=$2; shift 2 ;;
    --no-build) build=0; shift ;;
    *) echo "run-paper: unknown option $1 (allowed: --full, --output DIR, --no-build)" >&2; exit 2 ;;
  esac
done
output=${output:-$root/out/$scene/$(date -u +%Y%m%d-%H%M%S)}  # a new folder for every run
args=("$root/scenes/paper/$scene.toml" --output "$output")
[ $build -eq 0 ] && args+=(--no-build)
bash "$root/launch/run-coupled.sh" "${args[@]}"
/usr/bin/python3 "$root/launch/plot.py" "$output" --out "$output/plots"
