#!/usr/bin/env bash
# Bit-identity of coupled outputs across a change (the safety net of a refactor): builds
# commit REV in a git worktree beside this tree, runs the same coupled scenes with both
# builds, and compares every dataset of solid.h5 and monitor.h5 bit for bit.
#
#   bash launch/bit-identity.sh REV [--output DIR] [--no-build] [--quick]
#
# Scenes: scenes/coupled_small.toml with [coupling] scheme = "serial", "implicit" and
# "parallel" (the same files for both builds), and the reduced paper scene
# (scenes/paper/single_theta90_re40_reduced.toml; --quick leaves it out). Output: DIR
# (default out/bit-identity-REV-<time>, never an existing folder) with REV/ and HEAD/ runs
# and the table (launch/compare_outputs.py). Exit 0 when every file is bit-identical, 1 when
# one differs, 2 for bad input.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
usage() { echo "usage: bash launch/bit-identity.sh REV [--output DIR] [--no-build] [--quick]" >&2; exit 2; }
[ $# -ge 1 ] || usage
case "$1" in -h|--help) sed -n '2,13p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;; esac
rev=$1; shift
output=""; build=1; quick=0
while [ $# -gt 0 ]; do
  case "$1" in
    --output) [ $# -ge 2 ] || usage; output=$2; shift 2 ;;
    --no-build) build=0; shift ;;
    --quick) quick=1; shift ;;
    *) echo "bit-identity: unknown option $1 (allowed: --output DIR, --no-build, --quick)" >&2; exit 2 ;;
  esac
done
commit=$(git -C "$root" rev-parse --verify --quiet "$rev^{commit}") || {
  echo "bit-identity: REV = $rev is not a commit of $root" >&2; exit 2; }
short=${commit:0:10}
output=${output:-$root/out/bit-identity-$short-$(date +%Y%m%d-%H%M%S)}
if [ -e "$output" ]; then echo "bit-identity: --output $output exists; give a new folder" >&2; exit 2; fi
mkdir -p "$output/scenes"

if [ $build -eq 1 ]; then
  bash "$root/launch/bootstrap.sh"
  bash "$root/launch/build.sh" >/dev/null
fi
# The reference build: a worktree of REV with its own build/ (kept for the next call).
ref=$root/build/bit-identity/$short
if [ ! -x "$ref/build/fluid/fluid" ]; then
  git -C "$root" worktree add --force --detach "$ref" "$commit" >/dev/null
  bash "$ref/launch/build.sh" >/dev/null
fi

scenes=()
for scheme in serial implicit parallel; do
  sed "s/^rigid_steps = 50\$/rigid_steps = 50\nscheme = \"$scheme\"/" "$root/scenes/coupled_small.toml" \
    > "$output/scenes/small_$scheme.toml"
  scenes+=("$output/scenes/small_$scheme.toml")
done
[ $quick -eq 1 ] || { cp "$root/scenes/paper/single_theta90_re40_reduced.toml" "$output/scenes/paper_reduced.toml";
                      scenes+=("$output/scenes/paper_reduced.toml"); }
for tree in "$ref:$short" "$root:HEAD"; do
  dir=${tree%%:*}; label=${tree##*:}
  for scene in "${scenes[@]}"; do
    name=$(basename "$scene" .toml)
    status=0
    bash "$dir/launch/run-coupled.sh" "$scene" --output "$output/$label/$name" --no-build --quiet \
      > "$output/$label.$name.log" 2>&1 || status=$?
    echo "bit-identity: $label $name: exit $status"
  done
done
/usr/bin/python3 "$root/launch/compare_outputs.py" "$output/$short" "$output/HEAD"
