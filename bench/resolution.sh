#!/usr/bin/env bash
# How much the smoothed surface depends on the tiles' resolution: a frame surfaced at the production
# defaults (the reference), then finer (--detail 2) and coarser (--detail 0.5, with the default
# sweeps and with fewer, scaled as a Laplacian's reach goes with the square of the edge length); the
# distance of each from the reference (bench/distance_by_turn.py: random points on the reference,
# VTK's exact distances, in d), binned by how flat the reference is there. This is the bound any
# simplification before or during the sweeps, or an adaptive extraction, would have to beat.
#   bash bench/resolution.sh [BUILD_DIR] [FRAME ...]   defaults: build/release, the dam break 23 and
#                                                      the SPHysics dam break
# Prints a markdown table (the lean meshes part of bench/RESULTS.md).
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build/release}
shift || true
frames=("$@")
if [[ ${#frames[@]} == 0 ]]; then
  frames=("$root/tests/data/ply/dam_break_frame_23_24389_particles.ply"
          "$root/tests/data/ply/sphysics_dam_break_IPART_29814_particles.ply")
fi
work=$(mktemp -d /tmp/meniscus-bench-resolution.XXXXXX)
trap 'rm -rf "$work"' EXIT
echo "# $(git -C "$root" rev-parse --short HEAD): distance from the production surface / d, by the reference's normal turn"
echo "| frame: surfaced at | turn | area share | median | 90 % | 99 % |"
echo "|---|---|---|---|---|---|"
for frame in "${frames[@]}"; do
  name=$(basename "$frame" .ply)
  "$build/meniscus" surface "$frame" -o "$work/reference.ply" --stats "$work/reference.json" -q --backend cpu
  d=$(/usr/bin/python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["parameters"]["spacing"])' "$work/reference.json")
  while IFS="|" read -r label options; do
    # shellcheck disable=SC2086  # the options are words
    "$build/meniscus" surface "$frame" -o "$work/other.ply" -q --backend cpu $options
    PYTHONPATH="$root/bench" /usr/bin/python3 "$root/bench/distance_by_turn.py" "$work/reference.ply" "$work/other.ply" "$d" 40000 "$name: $label"
  done <<'RUNS'
detail 2|--detail 2
detail 0.5|--detail 0.5
detail 0.5, A 10, B 5|--detail 0.5 --steps-a 10 --steps-b 5
detail 0.5, A 5, B 3|--detail 0.5 --steps-a 5 --steps-b 3
RUNS
done
