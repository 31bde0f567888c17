# Sourced by the launch scripts that build, run or write, after `root` is set: where things go.
#
# The build folder: sets `bin` to it and exports it as COSIM_BUILD_DIR, so that the scripts
# they start use the same one. It is $COSIM_BUILD_DIR (absolute, or relative to the current
# folder) where that is set and not empty, else ROOT/build: e.g.
#
#   COSIM_BUILD_DIR=build-v3 bash launch/build.sh -DCOSIM_NATIVE=OFF -DCOSIM_ARCH=x86-64-v3
#   COSIM_BUILD_DIR=build-v3 bash launch/run-coupled.sh SCENE.toml --no-build
#
# builds a second, AVX2 binary beside build/ and runs a scene with it (launch/run-tests.sh
# does so for its x86-64-v3 pass).
#
# An installed launcher (PREFIX/bin/cosim-run sets COSIM_PREFIX_BIN to its folder): the
# servers and tools are that folder's, nothing is built, and `installed` is 1.
# The executables: fluid_exe, solid_exe, record_exe (cosim-record).
if [ -n "${COSIM_PREFIX_BIN:-}" ]; then
  installed=1
  bin=$COSIM_PREFIX_BIN
  fluid_exe=$bin/fluid solid_exe=$bin/solid record_exe=$bin/cosim-record
else
  installed=0
  bin=${COSIM_BUILD_DIR:-$root/build}
  case $bin in /*) ;; *) bin=$PWD/$bin ;; esac
  export COSIM_BUILD_DIR=$bin
  fluid_exe=$bin/fluid/fluid solid_exe=$bin/solid/solid record_exe=$bin/tools/record/cosim-record
fi

# new_folder PARENT: creates and prints PARENT/<UTC date-time>, or PARENT/<UTC date-time>-K
# where that exists already: a folder no other call got, created by this one (mkdir without
# -p fails where the name exists, so concurrent calls in the same second each get their own;
# nothing a user ran before is overwritten).
new_folder() {
  local base d k=2
  mkdir -p "$1" || return 1
  base=$1/$(date -u +%Y%m%d-%H%M%S)
  d=$base
  until mkdir "$d" 2>/dev/null; do
    [ -e "$d" ] || return 1  # not a name taken: the parent refuses (permissions, full disk)
    d=$base-$k; k=$((k + 1))
  done
  echo "$d"
}

# scene_value SCENE KEY: the value of KEY as the fluid reads SCENE (`fluid SCENE --print KEY`:
# the servers' own TOML parser and defaults; the launcher never parses TOML itself); empty
# where the fluid refuses the scene (the servers then say why when they start).
scene_value() {
  "$fluid_exe" "$1" --print "$2" 2>/dev/null | sed -n "s/^$2=//p"
}
