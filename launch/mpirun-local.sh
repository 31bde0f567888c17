#!/usr/bin/env bash
# Runs a command on N MPI ranks of this machine with OpenMPI's mpirun, loopback only
# (DESIGN 8; the fluid's blocks over ranks, fluid/mpi/):
#
#   bash launch/mpirun-local.sh N COMMAND [ARGS...]
#
# The ranks talk through shared memory (--mca btl self,vader: no network transport); as
# root, mpirun runs in a private network namespace (unshare -n, lo up), so that its own
# start-up traffic stays on this machine too, and with OpenMPI's consent to run as root.
# More ranks than cores are allowed (--oversubscribe). Each rank gets OMP_NUM_THREADS =
# the cores divided among the ranks (at least 1) unless OMP_NUM_THREADS is set. Binding: where
# ranks x threads fit the cores, each rank is bound to its own set of `threads` cores
# (--map-by slot:PE=threads --bind-to core), so no two threads of a rank share a core; where
# they do not fit, no binding (--bind-to none: the kernel spreads them). OpenMPI's own default
# would bind a rank to one core, all its threads on it. COSIM_MPI_BIND=none|cores asks for one
# of the two whatever the counts (cores: one core per rank, OpenMPI's default). The exit
# status is mpirun's: 0 when every rank ended with 0, else a rank's non-zero status (one
# rank killed: mpirun ends the others and says which rank died and how). Every COSIM_*
# variable set here goes to the ranks (the run's token, id, faults, kernel level).
# COSIM_NETNS_PRIVATE=1: the caller already runs in a private network namespace
# (launch/coupled-inner.sh, where the solid listens): no second one.
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"
die() { echo "mpirun-local: $*" >&2; exit 2; }
[ $# -ge 2 ] || die "usage: bash launch/mpirun-local.sh N COMMAND [ARGS...]"
ranks=$1
shift
[[ $ranks =~ ^[1-9][0-9]{0,3}$ ]] || die "N = $ranks: the number of ranks must be an integer from 1 to 9999"
command -v mpirun >/dev/null 2>&1 || die "mpirun not found: install OpenMPI (bash launch/bootstrap.sh: openmpi-bin)"
threads=${OMP_NUM_THREADS:-$(( $(nproc) / ranks ))}
[ "$threads" -ge 1 ] 2>/dev/null || threads=1
cmd=(mpirun -np "$ranks" --oversubscribe --mca btl self,vader -x "OMP_NUM_THREADS=$threads")
cores=$(nproc)
case "${COSIM_MPI_BIND:-}" in
  none) cmd+=(--bind-to none) ;;
  cores) cmd+=(--map-by core --bind-to core) ;;
  "") if [ $((ranks * threads)) -le "$cores" ]; then cmd+=(--map-by "slot:PE=$threads" --bind-to core)
      else cmd+=(--bind-to none); fi ;;
  *) die "COSIM_MPI_BIND = ${COSIM_MPI_BIND}: must be none or cores (or unset: bound per rank to its threads' cores where they fit)" ;;
esac
for v in OMP_WAIT_POLICY $(compgen -e | grep '^COSIM_' || true); do
  [ -n "${!v:-}" ] && cmd+=(-x "$v")
done
cmd+=("$@")
if [ "$(id -u)" -eq 0 ]; then
  export OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1
  if [ "${COSIM_NETNS_PRIVATE:-0}" != 1 ] && command -v unshare >/dev/null 2>&1 && unshare -n true 2>/dev/null; then
    exec unshare -n bash -c 'ip link set lo up && exec "$@"' mpirun-local "${cmd[@]}"
  fi
fi
exec "${cmd[@]}"
