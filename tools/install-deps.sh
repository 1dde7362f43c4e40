#!/usr/bin/env bash
# Installs the Debian packages meniscus needs to build and test (run as root).
set -euo pipefail
export DEBIAN_FRONTEND=noninteractive
apt-get update -qq
apt-get install -y -qq --no-install-recommends \
  build-essential cmake ninja-build pkg-config \
  libtbb-dev libembree-dev libfmt-dev nlohmann-json3-dev libcli11-dev zlib1g-dev libblosc-dev libstb-dev libopenvdb-dev libboost-dev \
  libgtest-dev libgmock-dev libbenchmark-dev \
  clang libclang-rt-14-dev \
  python3 python3-numpy python3-meshio python3-vtk9 \
  python3-dev python3-pytest pybind11-dev blender >/dev/null
