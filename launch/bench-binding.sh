#!/usr/bin/env bash
# The Python binding's overhead per LB step against the same solid in C++ (docs/solid-library.md):
# examples/spring_sheet/bench_step (C++) and examples/python_sheet/bench_step.py (Python,
# through the module `cosim`) time step() without a fluid, A_T = 150, for a 4 x 6 and a 20 x 20
# sheet, each the best of 5 repetitions, and the table is printed in Markdown.
#   bash launch/bench-binding.sh [--no-build]
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
. "$root/launch/folders.sh"
[ "${1:-}" = "--no-build" ] || bash "$root/launch/build.sh" >/dev/null
cpp=$("$bin/examples/spring_sheet/bench_step")
py=$(PYTHONPATH="$bin/sdk/python:$root/examples/python_sheet" /usr/bin/python3 "$root/examples/python_sheet/bench_step.py")
echo "| markers | no-op C++ (us) | no-op Python (us) | binding overhead (us) | spring sheet C++ (ms) | spring sheet Python (ms) | Python / C++ |"
echo "|---|---|---|---|---|---|---|"
paste <(echo "$cpp") <(echo "$py") | while IFS=$'\t' read -r c p; do
  n=$(awk '{print $2}' <<<"$c")
  cn=$(awk '{print $5}' <<<"$c"); cs=$(awk '{print $9}' <<<"$c")
  pn=$(awk '{print $5}' <<<"$p"); ps=$(awk '{print $9}' <<<"$p")
  awk -v n="$n" -v cn="$cn" -v pn="$pn" -v cs="$cs" -v ps="$ps" \
    'BEGIN { printf "| %d | %.2f | %.2f | %.2f | %.3f | %.3f | %.1f |\n", n, 1e3 * cn, 1e3 * pn, 1e3 * (pn - cn), cs, ps, ps / cs }'
done
