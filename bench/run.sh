#!/usr/bin/env bash
# meniscus bench — builds build/bench and runs meniscus_bench_compare on the synthetic scenes
# (100k, 300k; --large adds 1M and 3M) and the bundled real frames, printing the tables.
# Usage: bench/run.sh [--large | --counts N1,N2,...] [--no-files] [--json] [--micro] [--repeat N] [--decimate E]
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="$root/build/bench"
counts=(100000 300000)
extra=()
micro=0
files=1
while [[ $# -gt 0 ]]; do
  case "$1" in
    --large) counts+=(1000000 3000000) ;;
    --counts) IFS=, read -r -a counts <<<"$2"; shift ;;
    --no-files) files=0 ;;
    --json) extra+=(--json) ;;
    --micro) micro=1 ;;
    --repeat) extra+=(--repeat "$2"); shift ;;
    --decimate) extra+=(--decimate "$2"); shift ;;
    *) echo "unknown option $1" >&2; exit 2 ;;
  esac
  shift
done

cmake -S "$root" -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=Release -DMENISCUS_BUILD_BENCH=ON \
  -DMENISCUS_BUILD_TESTS=OFF >/dev/null
ninja -C "$build" meniscus_bench_compare meniscus_bench_micro >/dev/null

echo "# $(nproc) threads, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//')"
for scene in block sphere splash; do
  for n in "${counts[@]}"; do
    "$build/meniscus_bench_compare" --scene "$scene" --count "$n" "${extra[@]}"
  done
done
if [[ $files == 1 ]]; then
  for f in dam_break_frame_23_24389_particles.ply sphysics_dam_break_IPART_29814_particles.ply; do
    "$build/meniscus_bench_compare" --file "$root/tests/data/ply/$f" "${extra[@]}"
  done
fi
if [[ $micro == 1 ]]; then
  "$build/meniscus_bench_micro"
fi
