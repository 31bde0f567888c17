#!/usr/bin/env bash
# Checks scene files without running them: every side that reads a scene validates it, in
# one call. A coupled scene (one with [coupling]) is checked by both servers (`fluid --check`
# and `solid --check`: each refuses a typo in its own sections, with a did-you-mean); a
# fluid-only scene by the fluid, a solid-only scene (with [solid] and no [coupling]) by the
# solid. Prints one line per scene and side, "ok" with the scene's size or the side's error.
#
#   bash launch/check.sh SCENE.toml [SCENE.toml...] [--verbose]
#
# --verbose prints each side's whole header (the lattice units, the sheets, the model).
# Uses build/fluid/fluid and build/solid/solid ($COSIM_BUILD_DIR for build/ where set,
# launch/folders.sh; bash launch/build.sh first; nothing is built or installed here).
# Exit status: 0 every scene passed; 2 a scene was refused (or bad arguments); 1 the
# executables are missing.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
. "$root/launch/folders.sh"
fluid=${COSIM_FLUID_EXE:-$bin/fluid/fluid}
solid=${COSIM_SOLID_EXE:-$bin/solid/solid}

scenes=(); verbose=0
for a in "$@"; do
  case "$a" in
    --verbose) verbose=1 ;;
    -*) echo "check: unknown option $a (allowed: --verbose, --help)" >&2; exit 2 ;;
    *) scenes+=("$a") ;;
  esac
done
[ ${#scenes[@]} -ge 1 ] || { echo "usage: bash launch/check.sh SCENE.toml [SCENE.toml...] [--verbose]" >&2; exit 2; }
for exe in "$fluid" "$solid"; do
  [ -x "$exe" ] || { echo "check: $exe is missing: build first (bash launch/build.sh)" >&2; exit 1; }
done

# Which sides read the scene: a section header line [coupling] / [solid] (TOML: at the
# start of a line, spaces allowed).
has_section() { grep -Eq "^[[:space:]]*\[$1\][[:space:]]*(#.*)?$" "$2"; }

status=0
for scene in "${scenes[@]}"; do
  if [ ! -f "$scene" ]; then
    echo "check: $scene: no such scene file" >&2; status=2; continue
  fi
  sides=()
  if has_section coupling "$scene"; then sides=(fluid solid)
  elif has_section solid "$scene"; then sides=(solid)
  else sides=(fluid); fi
  for side in "${sides[@]}"; do
    exe=$fluid; [ "$side" = solid ] && exe=$solid
    set +e
    out=$("$exe" "$scene" --check 2>&1)
    rc=$?
    set -e
    if [ $rc -eq 0 ]; then
      summary=$(grep -m1 -E '^  (grid|sheets) ' <<<"$out" | sed -E 's/^ +//; s/ +/ /g' || true)
      echo "check: $scene: $side: ok${summary:+ ($summary)}"
      [ $verbose -eq 1 ] && sed 's/^/  /' <<<"$out"
    else
      echo "check: $scene: $side: $(grep -v '^\s*$' <<<"$out" | tail -1)"
      if [ $rc -eq 2 ]; then status=2; elif [ $status -eq 0 ]; then status=$rc; fi
    fi
  done
done
exit $status
