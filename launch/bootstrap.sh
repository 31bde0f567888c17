#!/usr/bin/env bash
# Installs the Debian packages the project needs, and nothing else. Idempotent and quiet
# when everything is present. Run as root (or with sudo available).
#
#   bash launch/bootstrap.sh
set -euo pipefail
. "$(dirname "${BASH_SOURCE[0]}")/help.sh" && answer_help "${BASH_SOURCE[0]}" "$@"

packages=(
  build-essential cmake pkg-config
  liblcm-dev liblcm-bin libglib2.0-dev
  libeigen3-dev libhdf5-dev libtomlplusplus-dev libcli11-dev libssl-dev
  libgtest-dev libbenchmark-dev
  python3 python3-dev python3-h5py python3-matplotlib python3-numpy python3-scipy pybind11-dev
  python3-paraview
  iproute2 util-linux
  libopenmpi-dev openmpi-bin libhdf5-openmpi-dev
  time
)

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${db:Status-Status}' "$p" 2>/dev/null || true)
  [ "$status" = "installed" ] || missing+=("$p")
done
[ ${#missing[@]} -eq 0 ] && exit 0

if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then
    SUDO=sudo
  else
    echo "bootstrap: missing Debian packages: ${missing[*]}; run as root or install them" >&2
    exit 1
  fi
else
  SUDO=
fi

echo "bootstrap: installing ${missing[*]}" >&2
log=$(mktemp)
trap 'rm -f "$log"' EXIT
if ! { $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq &&
       $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends \
         "${missing[@]}"; } >"$log" 2>&1; then
  cat "$log" >&2
  echo "bootstrap: apt-get failed (output above)" >&2
  exit 1
fi
