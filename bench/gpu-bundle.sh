#!/usr/bin/env bash
# meniscus — bench/gpu.sh on a GPU machine that has the CUDA driver but not our Debian packages
# (TBB, fmt, OpenVDB, Embree …) and cannot install them: build here, run there.
#   bash bench/gpu-bundle.sh ARCH BUNDLE.tar.xz   here: builds build/gpu with CUDA for ARCH (90: H100/H200)
#                                                 and packs its test, CLI and benchmark programs, ctest's
#                                                 files and the shared libraries they load
#   there, in a checkout of the same commit at the same path (ctest's files name it):
#     tar -xJf BUNDLE.tar.xz && LD_LIBRARY_PATH=$PWD/build/gpu/lib MENISCUS_GPU_PREBUILT=1 bash bench/gpu.sh OUT_DIR
# glibc, libstdc++ and libgcc come from the GPU machine (they must be as new as this machine's).
set -euo pipefail
cd "$(dirname "$0")/.."
ARCH=${1:?usage: bash bench/gpu-bundle.sh CUDA_ARCH BUNDLE.tar.xz}
BUNDLE=$(realpath -m "${2:?usage: bash bench/gpu-bundle.sh CUDA_ARCH BUNDLE.tar.xz}")
BUILD=build/gpu
cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DMENISCUS_CUDA=ON -DCMAKE_CUDA_ARCHITECTURES="$ARCH" \
      -DMENISCUS_BUILD_BENCH=ON -DMENISCUS_PYTHON=OFF -DMENISCUS_MPI=OFF > /dev/null
cmake --build "$BUILD" --target meniscus_cli meniscus_cuda_tests meniscus_bench_gpu
programs=("$BUILD/meniscus" "$BUILD/tests/meniscus_cuda_tests" "$BUILD/meniscus_bench_gpu")
rm -rf "$BUILD/lib" && mkdir -p "$BUILD/lib"
ldd "${programs[@]}" | awk '/=> \//{print $3}' | sort -u |
  grep -Ev '/(libc|libm|libstdc\+\+|libgcc_s|libpthread|libdl|librt)\.so' | xargs -I{} cp -L {} "$BUILD/lib/"
# ctest's files: every CTestTestfile.cmake and the test lists gtest_discover_tests wrote.
mapfile -t ctest_files < <(find "$BUILD" -name CTestTestfile.cmake -o -name '*_tests*.cmake' | grep -v CMakeFiles)
tar -cJf "$BUNDLE" "${programs[@]}" "$BUILD/lib" "${ctest_files[@]}"
echo "$BUNDLE: $(du -h "$BUNDLE" | cut -f1)"
