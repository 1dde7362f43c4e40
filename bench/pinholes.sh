#!/usr/bin/env bash
# Thin water side by side: for each particle file given, the genus (holes and tunnels through the
# surface), components, volume / (N d³), particles outside and frame time of meniscus with the
# defaults, with --fill-pinholes, and of OpenVDB's ParticlesToLevelSet + 4 mean-curvature passes +
# VolumeToMesh (meniscus_bench_compare) — one markdown row a file (bench/RESULTS.md).
#
#   cmake --preset release -DMENISCUS_BUILD_BENCH=ON && cmake --build build/release
#   bash bench/pinholes.sh build/release tests/data/double_dam_break_frame_26_4732_particles.vtk \
#       sim/ParticleData_Fluid_00{05,10,15,20,25,30,35,40,45}.bgeo
set -euo pipefail
build=${1:?usage: bench/pinholes.sh BUILD_DIR FILE...}
shift
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "| frame | meniscus genus / components | --fill-pinholes genus / components | OpenVDB + 4 passes genus / components | volume / (N d³): meniscus, --fill-pinholes, OpenVDB | particles outside | frame time [s]: meniscus, --fill-pinholes, OpenVDB |"
echo "| --- | --- | --- | --- | --- | --- | --- |"
for f in "$@"; do
  for v in plain fill; do
    extra=()
    [[ $v == fill ]] && extra=(--fill-pinholes)
    "$build/meniscus" surface "$f" -o "$tmp/$v.ply" --quiet --threads 2 --stats "$tmp/$v.json" "${extra[@]}"
    "$build/meniscus" inspect "$tmp/$v.ply" --particles "$f" --json > "$tmp/$v.q.json"
  done
  "$build/meniscus_bench_compare" --file "$f" --json --no-warmup > "$tmp/vdb.json"
  /usr/bin/python3 - "$tmp" "$f" <<'PY'
import json, os, sys
t, f = sys.argv[1], sys.argv[2]
def mine(v):
    s, q = json.load(open(f"{t}/{v}.json")), json.load(open(f"{t}/{v}.q.json"))
    return s["genus"], s["components"], q["particles"]["volume_over_particle_volume"], q["particles"]["outside_surface"], s["total_seconds"]
vdb = json.load(open(f"{t}/vdb.json"))["runs"]["vdb-filter4"]
q = vdb["quality"]
p, b = mine("plain"), mine("fill")
print(f"| {os.path.basename(f)} | {p[0]} / {p[1]} | {b[0]} / {b[1]} | {q['genus']} / {q['components']} | "
      f"{p[2]:.3f}, {b[2]:.3f}, {q['volume_over_particle_volume']:.3f} | {p[3]}, {b[3]}, {q['particles_outside']}/{q['particles_sampled']} | "
      f"{p[4]:.2f}, {b[4]:.2f}, {vdb['total_seconds']:.2f} |")
PY
done
