#!/usr/bin/env bash
# meniscus — build with CUDA (+ benchmarks), run the CUDA tests (device stages and CPU/GPU
# parity) and the GPU benchmark at 100k, 1M and 10M particles. Needs nvcc and a CUDA device.
#   bash bench/gpu.sh [BUILD_DIR]        (default build/gpu)
set -euo pipefail
cd "$(dirname "$0")/.."
BUILD=${1:-build/gpu}
JOBS=${JOBS:-$(nproc)}

cmake -S . -B "$BUILD" -G Ninja -DCMAKE_BUILD_TYPE=Release -DMENISCUS_CUDA=ON -DMENISCUS_BUILD_BENCH=ON
cmake --build "$BUILD" -j "$JOBS"

"$BUILD/meniscus" info

echo "== CUDA tests (backend dispatch, shared code, device stages, parity) =="
"$BUILD/tests/meniscus_tests" --gtest_filter='SumTree*:MarchingTables*:Backend*:Cuda*:KernelField*' --gtest_color=no

# Out-of-bounds and uninitialised device reads, on the small device tests, where the toolkit has
# compute-sanitizer (most of the device code had never run when it was written).
SANITIZER=$(command -v compute-sanitizer || ls /usr/local/cuda/bin/compute-sanitizer 2>/dev/null || true)
if [ -n "$SANITIZER" ]; then
  echo "== compute-sanitizer memcheck / initcheck on the device stage tests =="
  "$SANITIZER" --tool memcheck --error-exitcode 1 "$BUILD/tests/meniscus_tests" --gtest_filter='CudaStages*:CudaParity.Extraction*:CudaParity.FieldMethods*' --gtest_color=no
  "$SANITIZER" --tool initcheck --error-exitcode 1 "$BUILD/tests/meniscus_tests" --gtest_filter='CudaStages*' --gtest_color=no
else
  echo "(compute-sanitizer not found: device memory checks skipped)"
fi

echo "== GPU benchmark: jittered blocks, per-stage device times (CUDA events) =="
"$BUILD/meniscus_bench_gpu" --backend cuda --counts "${COUNTS:-100000,1000000,10000000}"

echo "== the field methods of issue #7 on the GPU (1M particles; anisotropic: centres, ellipsoids, ellipsoid constraints) =="
for f in metaball sph zhu-bridson anisotropic; do
  "$BUILD/meniscus_bench_gpu" --backend cuda --field "$f" --counts "${FIELD_COUNTS:-1000000}"
done

echo "== the same scenes on the CPU backend, for comparison (100k, 1M) =="
"$BUILD/meniscus_bench_gpu" --backend cpu --counts "${CPU_COUNTS:-100000,1000000}"
