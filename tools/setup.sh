#!/usr/bin/env bash
# setup.sh — install the Debian packages kerf needs (only the missing ones)
# and build it (Release, warnings on). Idempotent: fast when all is in place.
#   usage: tools/setup.sh [build-dir]   (default: build)
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-"$here/build"}

packages=(build-essential cmake pkg-config file
          libopenvdb-dev libboost-iostreams-dev libtbb-dev libembree-dev libassimp-dev
          libosmesa6-dev libegl-dev libegl-mesa0 libfyaml-dev libpng-dev libmujoco-dev libqhull-dev
          libmicrohttpd-dev     # kerf view's web server
          libopenexr-dev libimath-dev  # EXR frames with AOVs (OpenEXRCore, the C library)
          libopenmpi-dev openmpi-bin  # one simulation over several ranks (mpirun -np N kerf run)
          libmpich-dev mpich  # MPICH beside it, for a second tree (cmake -DMPI_C_COMPILER=mpicc.mpich); Open MPI stays the default
          chromium chromium-driver  # the tests of kerf view drive a headless browser
          clang-format  # tools/format.sh
          gnuplot-nox   # gnuplot: the figures of tools/evidence/run.sh
          slurm-wlm munge openmpi-bin)  # kerf farm and its tests (tools/slurm_local.sh); MPI ranks
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing ${missing[*]}" >&2
  sudo_cmd=""
  [ "$(id -u)" -ne 0 ] && sudo_cmd="sudo"
  $sudo_cmd apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $sudo_cmd apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
fi

# extra configure options from the caller (tools/test.sh: -DKERF_WERROR=ON)
cmake -S "$here" -B "$build" -DCMAKE_BUILD_TYPE=Release ${KERF_CMAKE_OPTIONS:-} >/dev/null
cmake --build "$build" -j "$(nproc)" >&2
