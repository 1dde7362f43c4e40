#!/usr/bin/env bash
# Builds the libFuzzer target of every particle reader with clang and runs each for a bounded
# time (FUZZ_SECONDS, default 30; one target per core at a time) on a corpus seeded with the real
# files in tests/data.
# Exits non-zero on any finding (crash, sanitizer report, leak, timeout, an input that makes a
# reader hold more memory than the 256 MB the target gives it: -rss_limit_mb and -malloc_limit_mb
# sit just above that, where a decompression bomb or a lying count would land far beyond).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${FUZZ_SECONDS:-30}
build=build/fuzz
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ -DMENISCUS_FUZZ=ON -DMENISCUS_CUDA=OFF -DMENISCUS_PYTHON=OFF \
  -DMENISCUS_OPENVDB=OFF -DMENISCUS_CGAL=OFF >/dev/null  # the readers need none of these
cmake --build "$build" -j "$(nproc)" --target fuzzers  # the readers and the fuzz targets, not the whole library

seed() {  # the real files of a format as seeds, or a tiny valid file where there is none
  local format=$1 corpus=$2
  case "$format" in
    ply|bgeo|vtk|vtu) find tests/data -name "*.$format" -size -400k -exec cp {} "$corpus/" \; ;;
    sc) cp tests/data/*.bgeo.sc "$corpus/" ;;
    csv) { gzip -dc tests/data/sphysics_dam_break_IPART_29814_particles.txt.gz | head -n 50 > "$corpus/ipart.txt"; } || true
         printf 'x,y,z,vx,vy,vz\n0,0,0,1,2,3\n1,1,1,0,0,0\n' > "$corpus/header.csv" ;;
    xyz) printf '\x00\x00\x80\x3f\x00\x00\x00\x40\x00\x00\x40\x40' > "$corpus/one.xyz" ;;
    npy) /usr/bin/python3 -c "import numpy; numpy.save('$corpus/a.npy', numpy.arange(12, dtype='<f4').reshape(4, 3))" ;;
    bgeojson) printf '\x7fNSJb[' > "$corpus/stub.bgeo" ;;
  esac
}
fuzz() {  # one target: its report in $build/fuzz-FORMAT.log, its fuzzer's exit status in .status
  set +e  # (a background job of its own) a finding is a status to report, not the end of the script
  local target=$1 format=${1##*/fuzz_} corpus found
  corpus=$(mktemp -d)
  seed "$format" "$corpus"
  {
    echo "== fuzzing $format for ${seconds}s ($(ls "$corpus" | wc -l) seeds)"
    "$target" "$corpus" -max_total_time="$seconds" -max_len=1048576 -rss_limit_mb=512 -malloc_limit_mb=400 -timeout=10 \
      -print_final_stats=1 -artifact_prefix="$build/crash-$format-" 2>&1 | tail -n 12
    found=${PIPESTATUS[0]}
  } > "$build/fuzz-$format.log"
  echo "$found" > "$build/fuzz-$format.status"
  rm -rf "$corpus"
}
# One target per core at a time (each fuzzer is one process).
formats=()
for target in "$build"/tests/fuzz/fuzz_*; do
  formats+=("${target##*/fuzz_}")
  rm -f "$build/fuzz-${formats[-1]}.status"
  fuzz "$target" &
  while (( $(jobs -rp | wc -l) >= $(nproc) )); do wait -n || true; done
done
wait
status=0
for format in "${formats[@]}"; do
  cat "$build/fuzz-$format.log"
  if [[ $(cat "$build/fuzz-$format.status" 2>/dev/null) != 0 ]]; then
    echo "FINDING in the $format reader: see $build/crash-$format-*"
    status=1
  fi
done
exit $status
