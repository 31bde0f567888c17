#!/usr/bin/env bash
# Runs a family of the paper's scenes (scenes/paper/, launch/paper-scenes.py), plots them
# together and prints a summary table.
#
#   bash launch/sweep.sh re|angle|pair [--full] [--no-build] [--law LAW]
#
#   re     single_theta90_re01, _re10, _re20, _re40      (Figs. 5, 6)
#   angle  single_theta00, 30, 45, 60, 90 at Re 40        (Figs. 7-9)
#   pair   pair_ds* at Re 40 (ds = 1.02 ... 11.5 um)      (Figs. 10, 12-14)
#
# The reduced presets (*_reduced.toml: half the resolution, a minute or more each) by default;
# --full runs the paper's size (much longer). --no-build skips launch/bootstrap.sh and
# launch/build.sh (done once for the whole sweep otherwise). --law LAW runs each scene under
# that reaction law (docs/reproduction.md, "The paper's readings"): a copy of the scene with
# `[reaction] law = "LAW"` added is written to OUT/<family>-LAW/scenes/ and run from there,
# the family's output going to OUT/<family>-LAW/ (momentum_exchange, omit_boundary_velocity,
# per_substep_over_time_ratio, eq18_literal; a scene that has its own [reaction] section is refused).
#
# Each scene goes through launch/run-coupled.sh into OUT/<family>/<scene>/ (the folder is
# emptied first; the launcher's own lines go to launcher.log there; on a terminal its one
# progress line shows "run i of n SCENE" and the run's progress, ETA included), then launch/plot.py over
# all of them into OUT/<family>/plots/ (emptied first), and the summary table is printed and
# written to OUT/<family>/summary.txt: per scene and sheet, the marked CGP's final and
# largest (signed, at max |x|) stream-wise displacement in um, the mean C_D and C_L (= C_z)
# over the last half of the free phase, the oscillation frequency of the marked CGP after
# the release with the number of zero crossings of x minus its mean that it comes from
# (launch/plot.py --stats) and the run's exit status (launch/run-coupled.sh: 0 done, 1 system, 2 bad input, 3 unhealthy, 4 peer lost).
# A failed run is still listed, and plotted if it left a readable solid.h5.
#
# Environment:
#   COSIM_SWEEP_SCENES  whitespace-separated scene files (relative to the repository root
#                       or absolute) that replace the family's list, e.g. for a quick test:
#                         COSIM_SWEEP_SCENES="scenes/coupled_small.toml" bash launch/sweep.sh re --no-build
#                       (the same file twice gets folders <scene> and <scene>_2)
#   COSIM_SWEEP_OUT     output root instead of out/sweep (OUT above)
#   COSIM_SWEEP_PLOTS   0: no plots, only the runs and the table (launch/paper-figures.sh
#                       plots the families itself)
#
# Exit status: 0 when every run and the plotting succeeded; otherwise the first failed
# run's status (or plot.py's); 2 for bad arguments.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
py=/usr/bin/python3

usage() { echo "usage: bash launch/sweep.sh re|angle|pair [--full] [--no-build] [--law LAW]" >&2; exit 2; }
[ $# -ge 1 ] || usage
family=$1; shift
full=0; build=1; law=""
while [ $# -gt 0 ]; do
  case "$1" in
    --full) full=1; shift ;;
    --no-build) build=0; shift ;;
    --law) [ $# -ge 2 ] || { echo "sweep: --law needs a value (momentum_exchange, omit_boundary_velocity, per_substep_over_time_ratio, eq18_literal)" >&2; exit 2; }
           law=$2; shift 2 ;;
    *) echo "sweep: unknown option $1" >&2; usage ;;
  esac
done
suffix=$([ $full -eq 1 ] && echo "" || echo "_reduced")
case "$family" in
  re) names=(single_theta90_re01 single_theta90_re10 single_theta90_re20 single_theta90_re40)
      label=re ;;
  angle) names=(single_theta00_re40 single_theta30_re40 single_theta45_re40 single_theta60_re40
                single_theta90_re40)
         label=angle ;;
  pair) names=()
        for f in "$root"/scenes/paper/pair_ds*_re40.toml; do
          if [ -e "$f" ]; then names+=("$(basename "$f" .toml)"); fi
        done
        label=ds ;;
  *) echo "sweep: unknown family '$family' (re, angle or pair)" >&2; usage ;;
esac

scenes=()
if [ -n "${COSIM_SWEEP_SCENES:-}" ]; then
  for s in $COSIM_SWEEP_SCENES; do
    case "$s" in /*) scenes+=("$s") ;; *) scenes+=("$root/$s") ;; esac
  done
  label=""   # plot.py picks the parameter that differs between the runs
else
  for n in "${names[@]}"; do scenes+=("$root/scenes/paper/$n$suffix.toml"); done
fi
[ ${#scenes[@]} -gt 0 ] || { echo "sweep: no scenes for family $family" >&2; exit 2; }
for s in "${scenes[@]}"; do
  [ -f "$s" ] || { echo "sweep: $s: no such scene file (python3 launch/paper-scenes.py writes scenes/paper/)" >&2; exit 2; }
done
[ -x "$py" ] || { echo "sweep: $py not found (launch/bootstrap.sh installs it)" >&2; exit 1; }

case "$law" in
  ""|momentum_exchange|omit_boundary_velocity|per_substep_over_time_ratio|eq18_literal) ;;
  *) echo "sweep: --law '$law' is not a reaction law (momentum_exchange, omit_boundary_velocity, per_substep_over_time_ratio, eq18_literal)" >&2; exit 2 ;;
esac
for s in "${scenes[@]}"; do
  if [ -n "$law" ] && grep -q '^[[:space:]]*\[reaction\]' "$s"; then
    echo "sweep: $s has its own [reaction] section; --law $law would give it a second one" >&2; exit 2
  fi
done

base=${COSIM_SWEEP_OUT:-$root/out/sweep}/$family${law:+-$law}
mkdir -p "$base"
base=$(cd "$base" && pwd)

# Under --law, each scene runs from a copy with the law's [reaction] section appended.
if [ -n "$law" ]; then
  mkdir -p "$base/scenes"
  for i in "${!scenes[@]}"; do
    copy=$base/scenes/$(basename "${scenes[$i]}")
    { cat "${scenes[$i]}"; printf '\n# Added by launch/sweep.sh --law %s\n[reaction]\nlaw = "%s"\n' "$law" "$law"; } >"$copy"
    scenes[$i]=$copy
  done
fi

if [ $build -eq 1 ]; then
  bash "$root/launch/bootstrap.sh"
  bash "$root/launch/build.sh" >/dev/null
fi

# Folder names: the scene file's name, made unique.
dirs=(); declare -A used=()
for s in "${scenes[@]}"; do
  n=$(basename "$s" .toml); d=$n; k=2
  while [ -n "${used[$d]:-}" ]; do d=${n}_$k; k=$((k + 1)); done
  used[$d]=1; dirs+=("$d")
done

echo "sweep: family $family, ${#scenes[@]} scene(s)$([ $full -eq 1 ] && echo ', full size' || echo ', reduced presets')${law:+, reaction law $law}, output $base"
statuses=(); first_failure=0
for i in "${!scenes[@]}"; do
  scene=${scenes[$i]}; out=$base/${dirs[$i]}
  rm -rf "$out"; mkdir -p "$out"
  echo "sweep: run $((i + 1)) of ${#scenes[@]}: ${dirs[$i]}"
  start=$SECONDS
  set +e
  # The launcher's lines go to launcher.log; its one progress line, labelled with the run's
  # number, to this terminal when there is one (launch/progress.py, COSIM_PROGRESS_TTY).
  COSIM_RUN_LABEL="run $((i + 1)) of ${#scenes[@]} ${dirs[$i]}" COSIM_PROGRESS_TTY=1 \
    bash "$root/launch/run-coupled.sh" "$scene" --output "$out" --no-build >"$out/launcher.log" 2>&1
  status=$?
  set -e
  statuses+=("$status")
  echo "sweep: run $((i + 1)) of ${#scenes[@]}: ${dirs[$i]}: exit $status in $((SECONDS - start)) s"
  if [ $status -ne 0 ]; then
    [ $first_failure -ne 0 ] || first_failure=$status
    for log in launcher.log fluid.log solid.log; do
      if [ -s "$out/$log" ]; then tail -n 3 "$out/$log" | sed "s|^|  $log: |"; fi
    done
  fi
done

# Plots of every run that left a solid.h5.
plot_dirs=()
for d in "${dirs[@]}"; do
  if [ -f "$base/$d/solid.h5" ]; then plot_dirs+=("$base/$d"); fi
done
rm -rf "$base/plots"
plot_status=0
if [ "${COSIM_SWEEP_PLOTS:-1}" = 0 ]; then
  echo "sweep: no plots (COSIM_SWEEP_PLOTS=0)"
elif [ ${#plot_dirs[@]} -gt 0 ]; then
  echo "sweep: plots of ${#plot_dirs[@]} run(s) into $base/plots"
  set +e
  "$py" "$root/launch/plot.py" "${plot_dirs[@]}" --out "$base/plots" ${label:+--label "$label"}
  plot_status=$?
  set -e
else
  echo "sweep: no run left a solid.h5: nothing to plot"
  plot_status=1
fi

# Summary table, one row per scene and sheet.
{
  printf '%-34s %-5s %4s %11s %11s %9s %10s %8s %5s\n' scene sheet exit "x_end(um)" "x_max(um)" \
    "<C_D>" "<C_L>" "f(MHz)" cross
  for i in "${!dirs[@]}"; do
    d=${dirs[$i]}; status=${statuses[$i]}; rows=""
    if [ -f "$base/$d/solid.h5" ]; then
      rows=$("$py" "$root/launch/plot.py" --stats "$base/$d" 2>&1) || rows="!$rows"
    else
      rows="!no solid.h5"
    fi
    if [ "${rows:0:1}" = "!" ]; then
      printf '%-34s %-5s %4s %s\n' "$d" - "$status" "(${rows:1})"
    else
      while IFS=$'\t' read -r _scene sheet xend xmax cd cl f cross; do
        printf '%-34s %-5s %4s %11s %11s %9s %10s %8s %5s\n' "$d" "$sheet" "$status" "$xend" "$xmax" \
          "$cd" "$cl" "$f" "$cross"
      done <<<"$rows"
    fi
  done
  echo "x: stream-wise displacement of the marked CGP (x_max: at the largest |x|); <C_D>, <C_L> = <C_z>: means over the"
  echo "last half of the free phase; f: from the 'cross' zero crossings of x - mean after release (nan: no oscillation)"
} | tee "$base/summary.txt"

[ $first_failure -eq 0 ] || exit $first_failure
exit $plot_status
