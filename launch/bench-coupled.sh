#!/usr/bin/env bash
# Time per LB step of the coupled run, split per side into compute, waiting and (fluid)
# publishing (DESIGN 7), for the small coupled scene and the paper's grid. Prints a table.
#   bash launch/bench-coupled.sh [--no-build]
set -euo pipefail
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
build=1
[ "${1:-}" = "--no-build" ] && build=0
if [ $build -eq 1 ]; then
  bash "$root/launch/bootstrap.sh"
  bash "$root/launch/build.sh" >/dev/null
fi
field() {  # field FILE REGEX: the number captured by the first (..) of the regex
  sed -n "s/$2/\1/p" "$1" | head -1
}
printf '%-20s %13s %5s %6s | %13s %10s %10s | %13s %10s | %9s\n' scene grid CGPs steps \
  "fluid compute" "wait" "publish" "solid compute" "wait" "wall/step"
for scene in coupled_small coupled_paper_grid; do
  out="$root/out/bench/$scene"
  rm -rf "$out"
  bash "$root/launch/run-coupled.sh" "$root/scenes/$scene.toml" --no-build --quiet --output "$out" >/dev/null
  f="$out/fluid.log"; s="$out/solid.log"
  grid=$(field "$f" '.*grid *\([0-9]* x [0-9]* x [0-9]*\).*' | tr -d ' ')
  cgps=$(field "$f" '.*handshake accepted: solid model [a-z]*, \([0-9]*\) CGPs.*')
  steps=$(field "$f" '.*coupled run done, \([0-9]*\) LB steps.*')
  wall=$(field "$f" '.*LB steps in \([0-9.e+-]*\) s.*')
  fc=$(field "$f" '.*per LB step: compute \([0-9.e+-]*\) ms.*')
  fw=$(field "$f" '.*waiting \([0-9.e+-]*\) ms (for solid_state_t).*')
  fp=$(field "$f" '.*publishing \([0-9.e+-]*\) ms.*')
  sc=$(field "$s" '.*per LB step: compute \([0-9.e+-]*\) ms.*')
  sw=$(field "$s" '.*waiting \([0-9.e+-]*\) ms (for fluid_state_t).*')
  ws=$(awk -v w="$wall" -v n="$steps" 'BEGIN { printf "%.3g", 1e3 * w / n }')
  printf '%-20s %13s %5s %6s | %10s ms %7s ms %7s ms | %10s ms %7s ms | %6s ms\n' "$scene" "$grid" \
    "$cgps" "$steps" "$fc" "$fw" "$fp" "$sc" "$sw" "$ws"
done
echo "(serial scheme: each side waits while the other computes; rigid spin-up steps take no substeps)"
