#!/usr/bin/env bash
# --decimate on every bundled real frame and a wide splash (bench/wide_splash.py): triangles kept,
# the stage's time, the largest distance between the simplified and the full surface measured
# independently (bench/surface_distance.py: VTK's locator, every vertex and 100,000 random points
# on each mesh, both ways) against the bound E·d.
#   bash bench/decimate.sh [BUILD_DIR] [E] [SPLASH_PARTICLES]    defaults: build/release 0.02 200000
# Prints a markdown table (docs/cli.md "Clipping and decimation").
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build/release}
e=${2:-0.02}
splash=${3:-200000}
meniscus=$build/meniscus
work=$(mktemp -d /tmp/meniscus-bench-decimate.XXXXXX)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 "$root/bench/wide_splash.py" "$splash" "$work/wide_splash_$splash.ply" >/dev/null
echo "# $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(git -C "$root" rev-parse --short HEAD), E = $e"
echo "| frame | triangles | kept at E = $e | kept share | decimate (s) | surfacing (s) | rounds | largest distance / d (measured) | bound / d |"
echo "|---|---|---|---|---|---|---|---|---|"
for frame in "$root"/tests/data/ply/*.ply "$work/wide_splash_$splash.ply"; do
  name=$(basename "$frame" .ply)
  "$meniscus" surface "$frame" -o "$work/full.ply" --stats "$work/full.json" -q --backend cpu
  "$meniscus" surface "$frame" -o "$work/simple.ply" --decimate "$e" --stats "$work/simple.json" -q --backend cpu
  measured=$(/usr/bin/python3 "$root/bench/surface_distance.py" "$work/full.ply" "$work/simple.ply" 100000)
  /usr/bin/python3 - "$work/full.json" "$work/simple.json" "$measured" "$name" "$e" <<'PY'
import json, sys
full, simple = (json.load(open(p)) for p in sys.argv[1:3])
measured, name, e = json.loads(sys.argv[3]), sys.argv[4], float(sys.argv[5])
d = simple["parameters"]["spacing"]
print(f"| {name} | {full['triangles']:,} | {simple['triangles']:,} | {100 * simple['triangles'] / full['triangles']:.0f} % "
      f"| {simple['stages']['decimate']:.2f} | {full['total_seconds']:.2f} | {simple['decimate_rounds']} "
      f"| {measured['hausdorff'] / d:.4f} | {e} |")
PY
done
