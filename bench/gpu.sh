#!/usr/bin/env bash
# meniscus — what a machine with a CUDA device can tell us, in one command and one report file:
#   1. the build with CUDA for this machine's GPU (and the benchmarks), on all cores;
#   2. the cuda-labelled tests on the device (stages bit for bit against the CPU, parity on blocks
#      and every real frame, field methods, fallback, the CLI with --backend cuda);
#   3. the GPU benchmark: per-stage device times and launch / round-trip counts at 100k, 1M and
#      10M particles (warm: the second of two runs), the field methods at 1M;
#   4. the same scenes on this machine's CPU backend;
#   5. compute-sanitizer memcheck, racecheck, initcheck and synccheck on the device stage tests.
# Every section runs even when one fails; the report ends with a verdict per section, and the
# script exits non-zero if any failed. About 8 minutes on an H100 with 16 cores.
#   bash bench/gpu.sh OUT_DIR            writes the report gpu_report.txt into OUT_DIR (the build goes to build/gpu)
#   MENISCUS_GPU_PREBUILT=1 bash bench/gpu.sh OUT_DIR   uses the build in build/gpu as it is (made on
#                                        another machine and unpacked here: bench/gpu-bundle.sh)
set -uo pipefail
cd "$(dirname "$0")/.."
OUT=${1:?usage: bash bench/gpu.sh OUT_DIR}
mkdir -p "$OUT"
REPORT="$OUT/gpu_report.txt"
BUILD=${BUILD:-build/gpu}
JOBS=${JOBS:-$(nproc)}
: > "$REPORT"
declare -a verdicts=()

section() {  # section NAME TIMEOUT_S COMMAND...: runs it, appends its output, records the verdict
  local name=$1 limit=$2
  shift 2
  local start=$SECONDS
  { echo; echo "=== $name"; echo "\$ $*"; } >> "$REPORT"
  timeout "$limit" "$@" >> "$REPORT" 2>&1
  local rc=$?
  local line="$name: $([[ $rc == 0 ]] && echo ok || echo "FAILED (exit $rc)") in $((SECONDS - start)) s"
  echo "$line" | tee -a "$REPORT"
  verdicts+=("$line")
}

{
  echo "meniscus GPU report — $(date -u +%Y-%m-%dT%H:%M:%SZ), commit $(git rev-parse --short HEAD 2>/dev/null || echo unknown)"
  nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv,noheader 2>&1 || true
  echo "host: $(nproc) cores, $(lscpu 2>/dev/null | sed -n 's/^Model name: *//p')"
  nvcc --version 2>&1 | tail -n 2 || true
} >> "$REPORT"

SANITIZER=$(command -v compute-sanitizer || ls /usr/local/cuda/bin/compute-sanitizer 2>/dev/null || true)
TESTS="$BUILD/tests/meniscus_cuda_tests"
STAGE_TESTS='CudaStages*:CudaParity.ExtractionOnly*:CudaParity.TransferredAttributes*'

if [[ ${MENISCUS_GPU_PREBUILT:-0} == 1 ]]; then
  # A build made elsewhere for this GPU (bench/gpu-bundle.sh), on a machine without the Debian packages.
  section "build (prebuilt: $BUILD)" 10 test -x "$BUILD/meniscus" -a -x "$TESTS" -a -x "$BUILD/meniscus_bench_gpu"
else
  section "build (CUDA for this GPU, benchmarks, $JOBS jobs)" 420 bash -c "
    cmake -S . -B '$BUILD' -G Ninja -DCMAKE_BUILD_TYPE=Release -DMENISCUS_CUDA=ON -DCMAKE_CUDA_ARCHITECTURES=native \
          -DMENISCUS_BUILD_BENCH=ON -DMENISCUS_PYTHON=OFF > /dev/null && cmake --build '$BUILD' -j $JOBS"
fi
section "meniscus info" 30 "$BUILD/meniscus" info
section "cuda tests on the device (ctest -L cuda)" 300 ctest --test-dir "$BUILD" -L cuda --output-on-failure
section "GPU benchmark: blocks, 100k / 1M / 10M particles" 300 \
  "$BUILD/meniscus_bench_gpu" --backend cuda --counts "${COUNTS:-100000,1000000,10000000}"
for f in metaball sph zhu-bridson anisotropic; do
  section "GPU benchmark: --field $f, 1M particles" 120 \
    "$BUILD/meniscus_bench_gpu" --backend cuda --field "$f" --counts "${FIELD_COUNTS:-1000000}"
done
section "CPU backend on this machine: the same blocks" 300 \
  "$BUILD/meniscus_bench_gpu" --backend cpu --counts "${CPU_COUNTS:-100000,1000000,10000000}"

# Last: the slowest section, and the one a short lease can best do without.
if [[ -n $SANITIZER ]]; then
  for tool in memcheck racecheck initcheck synccheck; do
    section "compute-sanitizer $tool (device stage tests)" 240 \
      "$SANITIZER" --tool "$tool" --error-exitcode 1 "$TESTS" --gtest_filter="$STAGE_TESTS" --gtest_color=no
  done
else
  section "compute-sanitizer" 5 bash -c 'echo "compute-sanitizer not found"; exit 1'
fi

{ echo; echo "=== verdicts"; printf '%s\n' "${verdicts[@]}"; } >> "$REPORT"
echo "report: $REPORT"
for v in "${verdicts[@]}"; do [[ $v == *FAILED* ]] && exit 1; done
exit 0
