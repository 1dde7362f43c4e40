#!/usr/bin/env bash
# Builds the libFuzzer target of every particle reader with clang and runs each for a bounded
# time (FUZZ_SECONDS, default 30) on a corpus seeded with the real files in tests/data.
# Exits non-zero on any finding (crash, sanitizer report, leak, timeout).
set -euo pipefail
cd "$(dirname "$0")/.."
seconds=${FUZZ_SECONDS:-30}
build=build/fuzz
cmake -S . -B "$build" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DCMAKE_CXX_COMPILER=clang++ -DMENISCUS_FUZZ=ON >/dev/null
cmake --build "$build" -j "$(nproc)"

seeds_for() {  # the real files of a format, by extension
  case "$1" in
    ply) find tests/data -name '*.ply' ;;
    xyz) printf '' ;;
    *) find tests/data -name "*.$1" ;;
  esac
}
status=0
for target in "$build"/tests/fuzz/fuzz_*; do
  format=${target##*/fuzz_}
  corpus=$(mktemp -d)
  while read -r f; do [[ -n $f ]] && cp "$f" "$corpus/"; done < <(seeds_for "$format")
  # A tiny valid seed for formats without real files.
  [[ $format == xyz ]] && printf '\x00\x00\x80\x3f\x00\x00\x00\x40\x00\x00\x40\x40' > "$corpus/one.xyz"
  echo "== fuzzing $format for ${seconds}s ($(ls "$corpus" | wc -l) seeds)"
  if ! "$target" "$corpus" -max_total_time="$seconds" -max_len=1048576 -rss_limit_mb=2048 -timeout=10 \
       -print_final_stats=1 -artifact_prefix="$build/crash-$format-" 2>&1 | tail -n 12; then
    echo "FINDING in the $format reader: see $build/crash-$format-*"
    status=1
  fi
  rm -rf "$corpus"
done
exit $status
