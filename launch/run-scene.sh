#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs a scene with the fluid server.
#   bash launch/run-scene.sh [SCENE.toml] [--ranks N] [fluid options...]
# Default scene: the paper's channel (plate, Blasius inlet, outflow, no sheet) at reduced
# size. Output (monitor.h5, fields) goes to out/<scene name>/ unless --output is given.
# --ranks N runs the fluid's grid in N blocks over MPI ranks on this machine
# (launch/mpirun-local.sh: loopback only; slabs along z, [run] blocks in the scene), with
# the same outputs, bit for bit, as one process (fluid-only scenes; DESIGN 8).
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
. "$root/launch/folders.sh"
scene=${1:-$root/scenes/channel_reduced.toml}
[ $# -gt 0 ] && shift
bash "$root/launch/bootstrap.sh"
bash "$root/launch/build.sh" >/dev/null
name=$(basename "$scene" .toml)
has_output=0 ranks=0 args=()
while [ $# -gt 0 ]; do
  case $1 in
    --ranks)
      [ $# -ge 2 ] || { echo "run-scene: --ranks needs a number of MPI ranks" >&2; exit 2; }
      ranks=$2
      shift 2
      continue ;;
    --ranks=*) ranks=${1#--ranks=} ;;
    --output) has_output=1; args+=("$1") ;;
    *) args+=("$1") ;;
  esac
  shift
done
if [ $has_output -eq 0 ]; then
  args=(--output "$root/out/$name" "${args[@]}")
fi
if [ "$ranks" != 0 ]; then
  [[ $ranks =~ ^[1-9][0-9]{0,3}$ ]] || { echo "run-scene: --ranks $ranks: the number of MPI ranks must be an integer from 1 to 9999" >&2; exit 2; }
  grep -q "COSIM_HAVE_MPI:INTERNAL=\(ON\|TRUE\|1\)" "$bin/CMakeCache.txt" 2>/dev/null ||
    { echo "run-scene: --ranks $ranks: this build has no MPI (install libopenmpi-dev and openmpi-bin, then rebuild)" >&2; exit 2; }
  exec bash "$root/launch/mpirun-local.sh" "$ranks" "$bin/fluid/fluid" "$scene" "${args[@]}"
fi
exec "$bin/fluid/fluid" "$scene" "${args[@]}"
