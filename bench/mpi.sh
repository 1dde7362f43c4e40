#!/usr/bin/env bash
# One frame over MPI ranks against one process, on wide splashes (bench/wide_splash.py): the same
# file byte for byte (cmp), time, peak memory per rank, the halo's share.
#   bash bench/mpi.sh [BUILD_DIR] [COUNTS] [RANKS]     defaults: build/release 1000000,3000000 2,4
# Prints one table row per scene and rank count (markdown, for bench/RESULTS.md). Every rank reads
# its part of the frame and surfaces its slab; rank 0 also merges the ranks' pieces into one
# process's order and writes the .ply.
set -euo pipefail
root=$(cd "$(dirname "$0")/.." && pwd)
build=${1:-$root/build/release}
IFS=, read -r -a counts <<<"${2:-1000000,3000000}"
IFS=, read -r -a ranks <<<"${3:-2,4}"
meniscus=$build/meniscus
"$meniscus" info | grep -q "^mpi: yes" || { echo "$meniscus has no MPI (install libopenmpi-dev, rebuild)"; exit 1; }
work=$(mktemp -d /tmp/meniscus-bench-mpi.XXXXXX)
trap 'rm -rf "$work"' EXIT
mpi=(mpirun --oversubscribe -n)
[[ $(id -u) == 0 ]] && mpi=(mpirun --allow-run-as-root --oversubscribe -n)
export OMPI_MCA_btl=self,vader
echo "# $(nproc) cores, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), $(git -C "$root" rev-parse --short HEAD)"
echo "| scene | K | time (s) | peak per rank, MB (rank 0 / others) | max / 1 process | largest surfacing rank / 1 process | widest slab with halo / N | halo share of the particles surfaced | slowest rank's surfacing (s) | same file |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for n in "${counts[@]}"; do
  /usr/bin/python3 "$root/bench/wide_splash.py" "$n" "$work/splash.ply" >/dev/null
  "$meniscus" surface "$work/splash.ply" -o "$work/one.ply" --spacing 0.01 --stats "$work/one.json" -q --backend cpu
  read -r t1 p1 < <(/usr/bin/python3 -c "import json; j=json.load(open('$work/one.json')); print(j['total_seconds'], j['peak_memory_bytes'])")
  printf '| wide splash %s | 1 process | %.1f | %d | 1 | 1 | 1 | 0 | — | — |\n' "$n" "$t1" "$(( ${p1%.*} / 1000000 ))"
  for k in "${ranks[@]}"; do
    "${mpi[@]}" "$k" "$meniscus" surface "$work/splash.ply" -o "$work/k.ply" --spacing 0.01 --stats "$work/k.json" -q --backend cpu
    same=$(cmp -s "$work/one.ply" "$work/k.ply" && echo yes || echo NO)
    /usr/bin/python3 - "$work/k.json" "$p1" "$n" "$k" "$same" <<'PY'
import json, sys
j = json.load(open(sys.argv[1]))
p1, n, k, same = float(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]), sys.argv[5]
ranks = j["per_rank"]
peak = max(r["peak_memory_bytes"] for r in ranks)
others = max((r["peak_memory_bytes"] for r in ranks[1:]), default=0)
widest = max(r["particles_with_halo"] for r in ranks)
surfaced = sum(r["particles_with_halo"] for r in ranks)
slowest = max(r["surface_seconds"] for r in ranks)
rest = " ".join("%.0f" % (r["peak_memory_bytes"] / 1e6) for r in ranks[1:])
print(f"| wide splash {n} | {k} | {j['total_seconds']:.1f} | {ranks[0]['peak_memory_bytes'] / 1e6:.0f} / {rest} "
      f"| {peak / p1:.2f} | {others / p1:.2f} "
      f"| {widest / j['particles']:.2f} | {(surfaced - j['particles']) / surfaced:.2f} | {slowest:.1f} | {same} |")
PY
  done
done
