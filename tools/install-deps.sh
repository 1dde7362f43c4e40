#!/usr/bin/env bash
# Installs the Debian packages meniscus needs to build and test (run as root).
#   bash tools/install-deps.sh                 the build, the tests and the Python module
#   bash tools/install-deps.sh --with-blender  also Blender (about 1 GB), for the add-on's test
set -euo pipefail
with_blender=0
for arg in "$@"; do
  case "$arg" in
    --with-blender) with_blender=1 ;;
    -h|--help) sed -n '2,4p' "$0"; exit 0 ;;
    *) echo "install-deps.sh: unknown option '$arg' (expected --with-blender)" >&2; exit 2 ;;
  esac
done
packages=(
  build-essential cmake ninja-build pkg-config zip
  libtbb-dev libembree-dev libfmt-dev nlohmann-json3-dev libcli11-dev zlib1g-dev libblosc-dev libstb-dev
  libopenvdb-dev libboost-dev libcgal-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  clang libclang-rt-14-dev
  python3 python3-numpy python3-meshio python3-vtk9 python3-dev python3-pytest pybind11-dev
  slurm-wlm munge openmpi-bin libopenmpi-dev
)
if [[ $with_blender == 1 ]]; then packages+=(blender); fi
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends "${packages[@]}" >/dev/null
