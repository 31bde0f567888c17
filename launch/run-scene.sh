#!/usr/bin/env bash
# The main job: installs what is missing, builds, and runs a scene with the fluid server.
#   bash launch/run-scene.sh [SCENE.toml] [fluid options...]
# Default scene: the paper's channel (plate, Blasius inlet, outflow, no sheet) at reduced
# size. Output (monitor.h5, fields) goes to out/<scene name>/ unless --output is given.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
scene=${1:-$root/scenes/channel_reduced.toml}
[ $# -gt 0 ] && shift
bash "$root/launch/bootstrap.sh"
bash "$root/launch/build.sh" >/dev/null
name=$(basename "$scene" .toml)
has_output=0
for a in "$@"; do [ "$a" = "--output" ] && has_output=1; done
if [ $has_output -eq 0 ]; then
  set -- --output "$root/out/$name" "$@"
fi
exec "$root/build/fluid/fluid" "$scene" "$@"
