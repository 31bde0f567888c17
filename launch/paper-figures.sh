#!/usr/bin/env bash
# Every figure of the paper's section 3 (Figs. 5-14) in one folder with an index page: the
# three families of the paper's scenes run through launch/sweep.sh (re: Figs. 5, 6; angle:
# Figs. 7-9; pair: Figs. 10-14), then launch/plot.py with the paper's plane positions and
# times (Fig. 9: y = L/2 at 13.4 us; Figs. 11, 12: ds = 8.2 um at 13.8, 15.6, 22.7 us after
# release, Fig. 12 on y = L/3), each figure as a 300 dpi PNG and a vector PDF.
#
#   bash launch/paper-figures.sh [--full] [--no-build] [--out DIR] [--reuse] [--tiny]
#
# Default: the reduced presets (about 14 runs of a few minutes each on 2 cores); --full the
# paper's size (hours). --reuse plots the runs already in OUT/runs/ without running them
# again. --tiny (the test PaperFiguresScriptProducesEveryFigure): one scene of each family
# (Re 40 at 90 deg, 30 deg, the ds = 8.2 um pair), each cut to 40 LB steps (20 rigid) with
# every snapshot kind, PNGs at 72 dpi: the whole chain in about a minute, figures of runs
# far too short for physics.
# Output: OUT (default out/paper-figures) with runs/FAMILY/SCENE/ (each run's outputs),
# figures/figNN_*.png and .pdf, and figures/index.html (every figure with its number, what
# it shows as in the paper's caption, its PDF and the commands that made it). Exit status:
# 0 every figure written; otherwise the first failure's (sweep.sh's or plot.py's); 2 bad
# arguments.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
py=/usr/bin/python3

usage() { echo "usage: bash launch/paper-figures.sh [--full] [--no-build] [--out DIR] [--reuse] [--tiny]" >&2; exit 2; }
full=""; build=1; out=""; reuse=0; tiny=0
while [ $# -gt 0 ]; do
  case "$1" in
    --full) full="--full"; shift ;;
    --no-build) build=0; shift ;;
    --out) [ $# -ge 2 ] || usage; out=$2; shift 2 ;;
    --reuse) reuse=1; shift ;;
    --tiny) tiny=1; shift ;;
    *) echo "paper-figures: unknown option $1" >&2; usage ;;
  esac
done
[ -z "$full" ] || [ $tiny -eq 0 ] || { echo "paper-figures: --full and --tiny exclude each other" >&2; exit 2; }
out=${out:-$root/out/paper-figures}
mkdir -p "$out"
out=$(cd "$out" && pwd)
if [ $build -eq 1 ]; then
  bash "$root/launch/bootstrap.sh"
  bash "$root/launch/build.sh" >/dev/null
fi

tag=_reduced; [ -n "$full" ] && tag=""
declare -A family_scenes=(
  [re]="single_theta90_re01 single_theta90_re10 single_theta90_re20 single_theta90_re40"
  [angle]="single_theta00_re40 single_theta30_re40 single_theta45_re40 single_theta60_re40 single_theta90_re40"
  [pair]="pair_ds01p02_re40 pair_ds02p05_re40 pair_ds04p10_re40 pair_ds08p20_re40 pair_ds11p50_re40"
)
if [ $tiny -eq 1 ]; then
  family_scenes=([re]="single_theta90_re40" [angle]="single_theta30_re40" [pair]="pair_ds08p20_re40")
fi
fig11_scene=pair_ds08p20_re40$tag

# A scene of the --tiny variant: the reduced preset, 40 LB steps with 20 rigid, snapshots of
# fields, the planes y = L/2 and L/3 and the sheets every 10 steps.
tiny_scene() {
  local src=$1 dst=$2
  sed -E -e 's/^steps = .*/steps = 40/' -e 's/^rigid_steps = .*/rigid_steps = 20/' \
         -e 's/^monitor_every = .*/monitor_every = 10/' -e '/^(fields_every|planes_every|planes_y|sheets_every) =/d' \
         -e 's/^\[output\]$/[output]\nfields_every = 20\nplanes_every = 10\nplanes_y = [0.5, 0.3333]\nsheets_every = 10/' \
         "$src" >"$dst"
}

status=0
for family in re angle pair; do
  scenes=()
  for name in ${family_scenes[$family]}; do
    if [ $tiny -eq 1 ]; then
      mkdir -p "$out/scenes"
      tiny_scene "$root/scenes/paper/$name$tag.toml" "$out/scenes/$name$tag.toml"
      scenes+=("$out/scenes/$name$tag.toml")
    else
      scenes+=("$root/scenes/paper/$name$tag.toml")
    fi
  done
  if [ $reuse -eq 1 ] && [ -d "$out/runs/$family" ]; then
    echo "paper-figures: $family: reusing $out/runs/$family"
    continue
  fi
  echo "paper-figures: family $family (${#scenes[@]} runs)"
  set +e
  COSIM_SWEEP_SCENES="${scenes[*]}" COSIM_SWEEP_OUT="$out/runs" COSIM_SWEEP_PLOTS=0 bash "$root/launch/sweep.sh" "$family" --no-build $full
  s=$?
  set -e
  [ $s -eq 0 ] || [ $status -ne 0 ] || status=$s
done

# The figures: plot.py per family into work/, then copied under the paper's numbers.
work=$out/work
rm -rf "$work" "$out/figures"
mkdir -p "$work" "$out/figures"
runs_of() { local d; for name in ${family_scenes[$1]}; do d=$out/runs/$1/$name$tag; [ -f "$d/solid.h5" ] && echo "$d"; done; }
plot() {  # plot OUTDIR RUN... [-- plot.py options]
  local dest=$1; shift
  local args=()
  while [ $# -gt 0 ] && [ "$1" != "--" ]; do args+=("$1"); shift; done
  [ $# -gt 0 ] && shift
  if [ ${#args[@]} -eq 0 ]; then echo "paper-figures: no run to plot into $dest" >&2; [ $status -ne 0 ] || status=1; return; fi
  echo "  $py launch/plot.py ${args[*]##*/runs/} --out $dest --dpi $dpi $*" >>"$out/figures/commands.txt"
  "$py" "$root/launch/plot.py" "${args[@]}" --out "$dest" --dpi "$dpi" "$@" >"$dest.list" || { s=$?; [ $status -ne 0 ] || status=$s; }
}
mapfile -t re_runs < <(runs_of re)
mapfile -t angle_runs < <(runs_of angle)
mapfile -t pair_runs < <(runs_of pair)
dpi=300; [ $tiny -eq 1 ] && dpi=72   # --tiny: the chain, not print quality
plot "$work/re" "${re_runs[@]}" -- --label re --figures displacement,coefficients
plot "$work/angle" "${angle_runs[@]}" -- --label angle --plane 0.5 --vorticity-times 13.4 \
     --figures displacement,forces,vorticity
plot "$work/pair" "${pair_runs[@]}" -- --label ds --figures sheets,forces,strain
plot "$work/fig11" "$out/runs/pair/$fig11_scene" -- --times 13.8,15.6,22.7 --plane 0.3333 \
     --vorticity-times 13.8,15.6,22.7 --figures strain_sheets,vorticity

# figNN_name.{png,pdf} <- work file (without extension); the index rows.
rows=()
copy() {  # copy FIG NAME SOURCE CAPTION
  local fig=$1 name=$2 src=$3 caption=$4 ext
  for ext in png pdf; do
    if [ -f "$src.$ext" ]; then cp "$src.$ext" "$out/figures/fig${fig}_$name.$ext"
    else echo "paper-figures: Fig. $fig: $src.$ext missing" >&2; [ $status -ne 0 ] || status=1; fi
  done
  rows+=("$fig|fig${fig}_$name|$caption")
}
copy 05 displacement_re "$work/re/displacement" "Displacement of the marked CGP against time, Re = 1, 10, 20, 40 (single graphene, 90 deg)"
copy 06 coefficients_re "$work/re/coefficients" "Drag and lift coefficients against time, Re = 1, 10, 20, 40"
copy 07 displacement_angle "$work/angle/displacement" "Displacement of the marked CGP against time for the angles of attack, Re = 40"
copy 08 forces_angle "$work/angle/forces" "Drag and lift forces against time for the angles of attack, Re = 40"
for d in "${angle_runs[@]}"; do
  t=$(basename "$d")
  src=$work/angle/vorticity_y_$t; [ ${#angle_runs[@]} -eq 1 ] && src=$work/angle/vorticity_y  # plot.py: one run, no tag
  copy 09 "vorticity_${t%$tag}" "$src" "y vorticity on the plane y = L/2 at t - t0 = 13.4 us, ${t%$tag}"
done
copy 10 displacement_pair "$work/pair/displacement_sheets" "Displacement of the marked CGPs of both sheets against time, ds = 1.02 ... 11.5 um, Re = 40"
for t in 13.8 15.6 22.7; do
  copy 12 "vorticity_t$t" "$work/fig11/vorticity_y_t$t" "y vorticity on the plane y = L/3 at t - t0 = $t us, ds = 8.2 um"
done
copy 11 strain_sheets "$work/fig11/strain_sheets" "Area strain on the sheets at t - t0 = 13.8, 15.6, 22.7 us, ds = 8.2 um"
copy 13 forces_pair "$work/pair/forces" "Fluid force on each sheet against time, the pairs"
copy 14 strain_pair "$work/pair/strain" "Strain at the bottom, middle and top of the leading edges, the pairs"

# The index page.
{
  echo "<!DOCTYPE html><html><head><meta charset=\"utf-8\"><title>Inoue et al. 2010, section 3: Figs. 5-14</title>"
  echo "<style>body{font-family:sans-serif;max-width:60em;margin:auto}img{max-width:100%;border:1px solid #ccc}</style></head><body>"
  echo "<h1>The paper's section 3, Figs. 5-14</h1>"
  echo "<p>Made by <code>bash launch/paper-figures.sh $full$([ $tiny -eq 1 ] && echo ' --tiny')</code>"
  echo "($( [ $tiny -eq 1 ] && echo 'tiny test variant: 40 LB steps, no physics to read' || ([ -n "$full" ] && echo "the paper's size" || echo 'reduced presets'))),"
  echo "$(date -u +%Y-%m-%dT%H:%M:%SZ), $(git -C "$root" describe --always --dirty 2>/dev/null || echo 'no git'). Runs: <code>runs/</code>; each has its scene and provenance.</p>"
  for row in "${rows[@]}"; do
    IFS='|' read -r fig file caption <<<"$row"
    echo "<h2>Fig. $((10#$fig)): $caption</h2>"
    echo "<p><a href=\"$file.pdf\">PDF</a></p><img src=\"$file.png\" alt=\"Fig. $((10#$fig))\">"
  done
  echo "<h2>Commands</h2><pre>"
  sed 's/&/\&amp;/g; s/</\&lt;/g' "$out/figures/commands.txt"
  echo "</pre></body></html>"
} >"$out/figures/index.html"
echo "paper-figures: $(ls "$out/figures" | grep -c '\.png$') figures in $out/figures (index.html)"
exit $status
