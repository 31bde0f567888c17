#!/usr/bin/env bash
# The per-level kernel objects (cosim_isa_objects in fluid/CMakeLists.txt) may define code
# only in their own level's namespace (cosim::fluid::isa_<level>): an inline function or
# template instance outside it would be a weak symbol the linker may pick for the whole
# program, so that AVX-512 code could run on a CPU without it. Lists the offending symbols.
#
#   bash tests/fluid/check_isa_symbols.sh OBJECT...
set -euo pipefail
bad=0
for o in "$@"; do
  # Defined code symbols: T/t (text), W (weak), i (indirect function); local ones (t) are
  # private to the object and harmless.
  leaks=$(nm -C --defined-only "$o" | awk '$2 ~ /^[TWi]$/' | grep -v 'cosim::fluid::isa_' || true)
  if [ -n "$leaks" ]; then
    echo "$o defines code outside its level's namespace:"
    echo "$leaks"
    bad=1
  fi
done
[ "$bad" = 0 ] && echo "$# per-level objects define code only in their level's namespace"
exit "$bad"
