#!/usr/bin/env bash
# Calm water that shimmers: the jitter (docs/cli.md "Sequences": the flicker without the motion)
# of a particle sequence surfaced by meniscus and by OpenVDB r = d, voxel d/2 + 4 mean-curvature
# passes, each frame side by side, one d for every frame of both (meniscus' estimate on frame 1).
#
#   cmake --preset release -DMENISCUS_BUILD_BENCH=ON && cmake --build build/release
#   bash bench/jitter.sh build/release DIR [PATTERN] [-- extra surface options]
# DIR holds the frames (PATTERN, default ParticleData_Fluid_####.bgeo: the SPlisHSPlasH sequence of
# ../shared/data/sph_dambreak_sequence). Prints a markdown row a frame and the summary.
set -euo pipefail
build=${1:?usage: bench/jitter.sh BUILD_DIR DIR [PATTERN] [-- surface options]}
dir=${2:?usage: bench/jitter.sh BUILD_DIR DIR [PATTERN] [-- surface options]}
pattern=${3:-ParticleData_Fluid_####.bgeo}
shift $(( $# >= 3 ? 3 : 2 ))
[[ ${1:-} == -- ]] && shift
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$build/meniscus" surface "$dir/$pattern" -o "$tmp/m_####.ply" --stats "$tmp/s_####.json" -q "$@"
first=$(ls "$tmp"/s_*.json | head -n 1)
d=$(/usr/bin/python3 -c "import json, sys; print(json.load(open(sys.argv[1]))['parameters']['spacing'])" "$first")
for s in "$tmp"/s_*.json; do
  n=${s##*/s_}; n=${n%.json}
  "$build/meniscus_bench_compare" --file "$dir/${pattern/\#\#\#\#/$n}" --spacing "$d" --write-vdb-mesh "$tmp/v_$n.ply" >/dev/null
done
"$build/meniscus" inspect "$tmp/m_####.ply" --flicker --spacing "$d" --json > "$tmp/m.json"
"$build/meniscus" inspect "$tmp/v_####.ply" --flicker --spacing "$d" --json > "$tmp/v.json"
/usr/bin/python3 - "$tmp/m.json" "$tmp/v.json" "$d" <<'PY'
import json, statistics, sys
m, v, d = json.load(open(sys.argv[1])), json.load(open(sys.argv[2])), float(sys.argv[3])
print(f"d = {d:g}")
print("| frame | jitter median [d]: meniscus, OpenVDB + 4 | ratio | 90th percentile [d]: meniscus, OpenVDB + 4 |")
print("| --- | --- | --- | --- |")
ratios = []
for a, b in zip(m["frames"], v["frames"]):
    if "jitter" not in a or "jitter" not in b:
        continue
    ja, jb = a["jitter"], b["jitter"]
    r = ja["median"] / jb["median"] if jb["median"] > 0 else float("inf")
    ratios.append((a["frame"], r))
    print(f"| {a['frame']} | {ja['median']:.4f}, {jb['median']:.4f} | {r:.2f} | {ja['p90']:.4f}, {jb['p90']:.4f} |")
sm, sv = m["summary"]["jitter"], v["summary"]["jitter"]
worse = sum(1 for _, r in ratios if r > 1)
print(f"median over {sm['frames']} frames: meniscus {sm['median']:.4f} d, OpenVDB + 4 {sv['median']:.4f} d; "
      f"meniscus / OpenVDB per frame {min(r for _, r in ratios):.2f}-{max(r for _, r in ratios):.2f}, "
      f"meniscus higher in {worse} of {len(ratios)}")
PY
