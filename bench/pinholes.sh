#!/usr/bin/env bash
# Thin water side by side: for each particle file given, the genus (holes and tunnels through the
# surface), components, volume / (N d³), particles outside and frame time of meniscus with the
# defaults, with --close-handles, with --close-handles --fill-pinholes, and of OpenVDB's
# ParticlesToLevelSet + 4 mean-curvature passes + VolumeToMesh (meniscus_bench_compare) — one
# markdown row a file (bench/RESULTS.md), and the sums of the genus over the files last.
#
#   cmake --preset release -DMENISCUS_BUILD_BENCH=ON && cmake --build build/release
#   bash bench/pinholes.sh build/release tests/data/double_dam_break_frame_26_4732_particles.vtk \
#       sim/ParticleData_Fluid_00{05,10,15,20,25,30,35,40,45}.bgeo
set -euo pipefail
build=${1:?usage: bench/pinholes.sh BUILD_DIR FILE...}
shift
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
echo "| frame | genus / components: meniscus, --close-handles, + --fill-pinholes, OpenVDB + 4 | volume / (N d³): the same | particles outside | frame time [s]: the same |"
echo "| --- | --- | --- | --- | --- |"
for f in "$@"; do
  for v in plain close both; do
    extra=()
    [[ $v == close ]] && extra=(--close-handles)
    [[ $v == both ]] && extra=(--close-handles --fill-pinholes)
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
rows = [mine(v) for v in ("plain", "close", "both")]
genus = ", ".join(f"{r[0]} / {r[1]}" for r in rows) + f", {q['genus']} / {q['components']}"
volume = ", ".join(f"{r[2]:.3f}" for r in rows) + f", {q['volume_over_particle_volume']:.3f}"
outside = ", ".join(str(r[3]) for r in rows) + f", {q['particles_outside']}/{q['particles_sampled']}"
time = ", ".join(f"{r[4]:.2f}" for r in rows) + f", {vdb['total_seconds']:.2f}"
print(f"| {os.path.basename(f)} | {genus} | {volume} | {outside} | {time} |")
with open(f"{t}/sums.txt", "a") as sums:
    sums.write(" ".join(str(r[0]) for r in rows) + f" {q['genus']}\n")
PY
done
if [[ -f "$tmp/sums.txt" ]]; then
  awk '{ for (i = 1; i <= NF; ++i) s[i] += $i } END { printf "genus summed: meniscus %d, --close-handles %d, + --fill-pinholes %d, OpenVDB + 4 %d\n", s[1], s[2], s[3], s[4] }' \
    "$tmp/sums.txt"
fi
