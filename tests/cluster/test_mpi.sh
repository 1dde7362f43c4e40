#!/usr/bin/env bash
# `mpirun -n K meniscus surface` (OpenMPI) as README.md and docs/cluster.md show it — with
# --oversubscribe (more ranks than cores) and --allow-run-as-root (the docs' install runs as root) —
# writes the file one process writes, byte for byte (cmp), for K = 1, 2, 4: a .ply (streamed as the
# ranks' pieces merge) and other formats (gathered whole), on real frames (one with the anisotropic
# field and its velocity transferred, one read in parts with a density and a velocity) and a wide
# splash where the slabs are narrower than the frame; --stats records the ranks; --pieces and
# `meniscus merge` give the same surface in a canonical order; bad input and options fail every
# rank cleanly. Usage: test_mpi.sh MENISCUS_BINARY DATA_DIR; exits 77 (skipped) without MPI.
set -euo pipefail
# A sanitizer build: what OpenMPI keeps until exit is not ours to report.
export LSAN_OPTIONS="suppressions=$(cd "$(dirname "$0")" && pwd)/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
meniscus=$(realpath "$1") data=$(realpath "$2")
here=$(cd "$(dirname "$0")" && pwd)
command -v mpirun >/dev/null || { echo "SKIP: no mpirun (Debian: openmpi-bin)"; exit 77; }
"$meniscus" info | grep -q "^mpi: yes" || { echo "SKIP: this meniscus was built without MPI"; exit 77; }
work=$(mktemp -d /tmp/meniscus-mpi.XXXXXX)
trap 'rm -rf "$work"' EXIT
cd "$work"
fail() { echo "FAIL: $*"; exit 1; }
# The command as the docs show it. The ranks surface on the CPU whatever the machine (--backend auto
# runs the CPU under MPI), so the single process they are compared with runs there too.
mpi=(mpirun --oversubscribe --allow-run-as-root -n)
# A sanitizer build: OpenMPI's memory patcher rewrites libasan's entry points (open-mpi/ompi#13069;
# it only serves RDMA registration caches), and what OpenMPI keeps until MPI_Finalize's exit fills
# LeakSanitizer's report; the ranks run without both. (The same library code runs under LeakSanitizer
# in the Distributed.* unit tests.)
export OMPI_MCA_memory=^patcher
mpi=(env ASAN_OPTIONS="${ASAN_OPTIONS:-}${ASAN_OPTIONS:+:}detect_leaks=0" "${mpi[@]}")
same() { /usr/bin/python3 "$here/same_mesh.py" "$@"; }
start=$(date +%s%N)

# A wide splash: a pool 160 × 12 × 4 d with 100 lone droplets over it, a PLY point cloud.
/usr/bin/python3 - <<'PY'
import numpy as np
rng = np.random.default_rng(3)
d, depth = 0.01, 4
i, j, k = np.meshgrid(np.arange(160), np.arange(12), np.arange(depth), indexing="ij")
pool = np.stack([i, j, k], -1).reshape(-1, 3) * d + rng.uniform(-0.1 * d, 0.1 * d, (i.size, 3))
drops = rng.uniform([2 * d, 2 * d, (depth + 2) * d], [157 * d, 9 * d, 4 * depth * d], (100, 3))
points = np.concatenate([pool, drops]).astype("<f4")
with open("splash.ply", "wb") as f:
    f.write(f"ply\nformat binary_little_endian 1.0\nelement vertex {len(points)}\nproperty float x\nproperty float y\n"
            f"property float z\nend_header\n".encode())
    f.write(points.tobytes())
PY

# Under the sanitizers (MENISCUS_SANITIZED=1, set by the sanitize build) the same checks over fewer
# rank counts and without the largest frame: the code they run is the same, the Release run has all.
ranks=(1 2 4) format_ranks=(2 4) large=yes
if [[ ${MENISCUS_SANITIZED:-0} == 1 ]]; then ranks=(1 4) format_ranks=(4) large=no; fi
check() {  # name, input, options...
  local name=$1 input=$2
  shift 2
  "$meniscus" surface "$input" -o "$name.single.ply" -q --backend cpu "$@"
  for k in "${ranks[@]}"; do
    "${mpi[@]}" $k "$meniscus" surface "$input" -o "$name.k$k.ply" --stats "$name.k$k.json" -q "$@" ||
      fail "$name: mpirun -n $k failed"
    cmp "$name.single.ply" "$name.k$k.ply" || fail "$name: the file of K=$k is not one process's"
    /usr/bin/python3 -c "
import json, sys
j = json.load(open('$name.k$k.json'))
assert j['ranks'] == $k and len(j['per_rank']) == $k, (j['ranks'], len(j['per_rank']))
assert sum(r['owned_triangles'] for r in j['per_rank']) == j['triangles'], 'a triangle owned twice or never'
assert all(r['peak_memory_bytes'] > 0 and r['surface_seconds'] > 0 for r in j['per_rank'] if r['particles_with_halo'] > 0)
assert j['removed_voids'] is None and all(r['removed_voids'] >= 0 and r['removed_blobs'] >= 0 for r in j['per_rank'])
" || fail "$name: the stats of K=$k"
  done
  same "$name.single.ply" "$name.k4.ply" > "$name.same" || { cat "$name.same"; fail "$name: not closed and manifold"; }
  echo "$name: K=${ranks[*]} byte-identical to one process ($(cat "$name.same"))"
}
[[ $large == no ]] || check dam_break_23 "$data/ply/dam_break_frame_23_24389_particles.ply"
check dam_break_9_anisotropic_velocity "$data/dam_break_frame_9_6859_particles.bgeo" --field anisotropic --transfer velocity
check splash splash.ply --spacing 0.01
# A binary PLY with a density and a velocity: read in parts, the spacing, the rest density and the
# reference speed reduced over the parts.
check dam_break_9_parts_sph_velocity "$data/ply/dam_break_frame_9_6859_particles.ply" --field sph --velocity-weighted
/usr/bin/python3 -c "
import json, os
for name, read, spread in [('dam_break_23', 'read_parts', 'exchange'), ('dam_break_9_parts_sph_velocity', 'read_parts', 'exchange'),
                           ('dam_break_9_anisotropic_velocity', 'read', 'scatter')]:
    if not os.path.exists(name + '.k4.json'): continue  # (the largest frame, not run under the sanitizers)
    stages = json.load(open(name + '.k4.json'))['stages']
    assert read in stages and spread in stages and 'gather_write' in stages, (name, list(stages))
print('fixed-record PLY read in parts by every rank; bgeo read by rank 0')
" || fail "the read stages"
# --particle-box: every rank drops the particles outside from its part as it reads.
"$meniscus" surface "$data/ply/dam_break_frame_23_24389_particles.ply" -o box.single.ply --particle-box=-10,-10,-10,0.3,10,10 -q --backend cpu
"${mpi[@]}" 2 "$meniscus" surface "$data/ply/dam_break_frame_23_24389_particles.ply" -o box.k2.ply --particle-box=-10,-10,-10,0.3,10,10 -q ||
  fail "mpirun -n 2 with --particle-box failed"
cmp box.single.ply box.k2.ply || fail "--particle-box: the file of K=2 is not one process's"
echo "particle box: K=2 byte-identical to one process"
# A frame far from the origin: every rank computes its slab about the whole frame's local origin,
# so the ranks' file is still one process's.
/usr/bin/python3 - "$data/ply/dam_break_frame_9_6859_particles.ply" <<'PY'
import sys
source = open(sys.argv[1], "rb").read()
end = source.index(b"end_header\n") + len(b"end_header\n")
header = source[:end].decode()
assert "property float x\nproperty float y\nproperty float z\n" in header, header
import numpy as np
names = [l.split()[2] for l in header.splitlines() if l.startswith("property")]
types = [l.split()[1] for l in header.splitlines() if l.startswith("property")]
dt = np.dtype([(n, {"float": "<f4", "int": "<i4", "uint": "<u4"}[t]) for n, t in zip(names, types)])
v = np.frombuffer(source[end:], dt).copy()
for axis in "xyz":
    v[axis] = (v[axis].astype(np.float64) + 1e4).astype("<f4")
open("far.ply", "wb").write(source[:end] + v.tobytes())
PY
"$meniscus" surface far.ply -o far.single.ply -q --backend cpu --spacing 0.05
"${mpi[@]}" 2 "$meniscus" surface far.ply -o far.k2.ply -q --spacing 0.05 || fail "mpirun -n 2 on a far frame failed"
cmp far.single.ply far.k2.ply || fail "a frame 1e4 from the origin: the file of K=2 is not one process's"
echo "a frame 1e4 from the origin: K=2 byte-identical to one process"
# README.md's example, and formats gathered whole on rank 0 (the velocity as each format holds it).
frame=$data/ply/dam_break_frame_9_6859_particles.ply
for ext in ply obj bgeo vtp; do
  "$meniscus" surface "$frame" -o "frame.single.$ext" --transfer velocity -q --backend cpu
  for k in "${format_ranks[@]}"; do
    "${mpi[@]}" $k "$meniscus" surface "$frame" -o "frame.k$k.$ext" --transfer velocity --stats "frame.k$k.$ext.json" -q ||
      fail "mpirun -n $k to .$ext failed"
    cmp "frame.single.$ext" "frame.k$k.$ext" || fail ".$ext from $k ranks is not one process's file"
  done
done
/usr/bin/python3 -c "
import json
stages = json.load(open('frame.k4.obj.json'))['stages']
assert 'gather' in stages and 'write' in stages, list(stages)
" || fail "the gather's stages for .obj"
echo "formats: .ply .obj .bgeo .vtp over ${format_ranks[*]} ranks byte-identical to one process"
/usr/bin/python3 -c "
import json
j = json.load(open('splash.k4.json'))
widest = max(r['particles_with_halo'] for r in j['per_rank'])
assert widest < 0.8 * j['particles'], (widest, j['particles'])
print(f'splash K=4: the widest slab holds {widest:.0f} of {j[\"particles\"]} particles with its halo')
"

# --pieces: one .vtp per rank and ParaView's .pvtp index (read by VTK itself), welded by merge
# into the single process's surface.
"${mpi[@]}" 4 "$meniscus" surface splash.ply -o pieces/splash.pvtp --pieces --spacing 0.01 -q --backend cpu ||
  fail "mpirun --pieces failed"
[[ $(ls pieces | wc -l) == 5 ]] || { ls pieces; fail "expected 4 pieces and the index"; }
/usr/bin/python3 - <<'PY' || fail "VTK does not read the pieces through the .pvtp index as the frame's triangles"
import subprocess, vtk
r = vtk.vtkXMLPPolyDataReader(); r.SetFileName("pieces/splash.pvtp"); r.Update()
cells = r.GetOutput().GetNumberOfCells()
single = vtk.vtkPLYReader(); single.SetFileName("splash.single.ply"); single.Update()
assert cells == single.GetOutput().GetNumberOfCells(), (cells, single.GetOutput().GetNumberOfCells())
assert r.GetOutput().GetPointData().GetNormals() is not None
print(f"pieces: VTK reads {cells} triangles through the .pvtp index")
PY
"$meniscus" merge pieces/splash.pvtp -o merged.ply -q
same splash.single.ply merged.ply > merged.same || { cat merged.same; fail "the merged pieces differ from one process"; }
echo "merge: $(cat merged.same)"

# Bad input: every rank stops, the message names the file, no mesh is written.
head -c 2000 "$data/ply/dam_break_frame_23_24389_particles.ply" > broken.ply
if "${mpi[@]}" 2 "$meniscus" surface broken.ply -o broken_mesh.ply > broken.out 2>&1; then fail "a truncated file surfaced"; fi
grep -q "broken.ply" broken.out || { cat broken.out; fail "no message naming the file"; }
[[ ! -e broken_mesh.ply ]] || fail "a mesh was written for a truncated file"
if "${mpi[@]}" 2 "$meniscus" surface 'sim_####.ply' -o 'out_####.ply' > seq.out 2>&1; then fail "a sequence ran under mpirun"; fi
grep -q "job array" seq.out || { cat seq.out; fail "no message for a sequence under mpirun"; }
# What the gather cannot give in one process's order is refused up front (exit 2), not run.
refused() {  # what, expected message, options...
  local what=$1 message=$2 code=0
  shift 2
  "${mpi[@]}" 2 "$meniscus" surface "$data/ply/dam_break_frame_9_6859_particles.ply" -o refused.ply "$@" > refused.out 2>&1 || code=$?
  [[ $code == 2 ]] || { cat refused.out; fail "$what under mpirun: exit $code, expected 2"; }
  grep -q "$message" refused.out || { cat refused.out; fail "no message for $what under mpirun"; }
  [[ ! -e refused.ply ]] || fail "a mesh was written for a refused $what"
}
refused --decimate "not available over MPI ranks" --decimate 0.02
refused "--backend cuda" "backend cuda is not available over MPI ranks" --backend cuda
refused "no sweep" "no smoothing sweep" --steps-a 0 --steps-b 0 --steps-free 0
refused --erode "erode is not available over MPI ranks" --erode 0.002
echo "total $(( ($(date +%s%N) - start) / 1000000 )) ms"
