#!/usr/bin/env bash
# tools/cluster/surface-array.sbatch on a real one-node Slurm cluster (tests/cluster/cluster.sh):
# four real frames as a job array of two tasks of two frames, against a local run of the same frames.
#   - a corrupt frame fails its task: `sbatch --wait` exits non-zero, the task's log names the
#     frame, no partial or temporary file is left;
#   - a resubmission with the frame repaired redoes only that frame (--skip-existing);
#   - the four meshes are then byte-identical to the local run;
#   - the flicker measured afterwards (`meniscus inspect --flicker`) is the local run's;
#   - a job granted less memory than its frame needs (sbatch --mem) is refused with a message, and
#     one granted enough (3x the frame's peak, at least 400 MB) runs on the CPUs it was given;
#   - an MPI job (sbatch -n 2, srun --mpi=pmix) surfaces one frame over its two ranks and writes
#     the local run's file, byte for byte (when this meniscus has MPI).
# Usage: test_slurm.sh MENISCUS_BINARY DATA_DIR; exits 77 (skipped) without Slurm.
set -euo pipefail
# A sanitizer build: what OpenMPI keeps until exit is not ours to report.
export LSAN_OPTIONS="suppressions=$(cd "$(dirname "$0")" && pwd)/lsan.supp${LSAN_OPTIONS:+:$LSAN_OPTIONS}"
meniscus=$(realpath "$1") data=$(realpath "$2")
here=$(cd "$(dirname "$0")" && pwd) root=$(cd "$(dirname "$0")/../.." && pwd)
source "$here/cluster.sh"
cluster_prerequisites || exit 77
work=$(mktemp -d /tmp/meniscus-slurm.XXXXXX)
fail() { echo "FAIL: $*"; cluster_logs; exit 1; }
start=$(date +%s%N)
elapsed() { echo "$(( ($(date +%s%N) - start) / 1000000 )) ms"; }
cluster_start "$work/slurm"
trap 'cluster_stop; rm -rf "$work"' EXIT
echo "cluster up after $(elapsed)"

# Four real frames of SPlisHSPlasH scenes, as one sequence (each frame is surfaced on its own,
# with the spacing estimated on frame 1 for all, as one run over the sequence does).
mkdir -p "$work/sim"
i=1
for f in dam_break_frame_9_6859_particles cube_2366_particles double_dam_break_frame_26_4732_particles \
         bunny_frame_14_7705_particles; do
  cp "$data/ply/$f.ply" "$work/sim/fluid_000$i.ply"
  i=$((i + 1))
done
cd "$work"
"$meniscus" surface 'sim/fluid_####.ply' -o 'local/mesh_####.ply' --stats 'local/stats_####.json' -q --threads 1

# Frame 3 corrupt: its task fails, the other task and frame 4 of the failing task succeed.
cp sim/fluid_0003.ply fluid_0003.good
head -c 3000 fluid_0003.good > sim/fluid_0003.ply
export MENISCUS=$meniscus
array=(--cpus-per-task=1 --output='log/task_%a.log' "$root/tools/cluster/surface-array.sbatch"
       'sim/fluid_####.ply' 'cluster/mesh_####.ply' --frames 1-4 --chunk 2)
mkdir -p log
[[ $(bash "$root/tools/cluster/surface-array.sbatch" 'sim/fluid_####.ply' 'cluster/mesh_####.ply' --frames 1-4 --chunk 2) \
   == *"--array=0-1 "* ]] || fail "the template does not say --array=0-1 for 4 frames in chunks of 2"
if sbatch --wait --array=0-1 "${array[@]}" > submit1.out 2>&1; then fail "sbatch --wait succeeded with a corrupt frame"; fi
grep -q "frame 3: error" log/task_1.log || { cat log/task_1.log; fail "task 1's log does not name frame 3"; }
grep -q "fluid_0003.ply" log/task_1.log || fail "task 1's log does not name the file"
for f in 1 2 4; do [[ -s cluster/mesh_000$f.ply ]] || fail "frame $f was not written"; done
[[ ! -e cluster/mesh_0003.ply ]] || fail "a partial mesh of frame 3 was left"
[[ $(ls cluster | wc -l) == 3 ]] || { ls -la cluster; fail "files besides the three meshes in cluster/"; }
stamp_before=$(stat -c %Y.%y cluster/mesh_0001.ply cluster/mesh_0002.ply cluster/mesh_0004.ply)

# Repaired and resubmitted: only frame 3 is surfaced.
cp fluid_0003.good sim/fluid_0003.ply
rm -f log/*
sbatch --wait --array=0-1 "${array[@]}" > submit2.out 2>&1 || { cat submit2.out log/*; fail "the resubmission failed"; }
grep -q "every frame's mesh exists: nothing to do" log/task_0.log || { cat log/task_0.log; fail "task 0 did work again"; }
grep -q "skipping 1 frame(s) whose mesh exists (--skip-existing): 4" log/task_1.log || { cat log/task_1.log; fail "task 1 did not skip frame 4"; }
grep -q "1 of 1 frames surfaced" log/task_1.log || fail "task 1 did not surface frame 3 alone"
[[ $(stat -c %Y.%y cluster/mesh_0001.ply cluster/mesh_0002.ply cluster/mesh_0004.ply) == "$stamp_before" ]] ||
  fail "the resubmission rewrote finished frames"
for f in 1 2 3 4; do
  cmp -s local/mesh_000$f.ply cluster/mesh_000$f.ply || fail "frame $f differs from the local run"
done
echo "array: 4 frames byte-identical to the local run; the failed frame redone alone"

# The flicker over the finished sequence, afterwards, is the local run's.
"$meniscus" inspect 'cluster/mesh_####.ply' --flicker --particles 'sim/fluid_####.ply' --json > flicker.json
/usr/bin/python3 - <<'PY' || fail "the post-pass flicker differs from the run's"
import json
post = {f["frame"]: f["flicker"] for f in json.load(open("flicker.json"))["frames"] if "flicker" in f}
assert sorted(post) == [2, 3, 4], post
for frame, f in post.items():
    run = json.load(open(f"local/stats_{frame:04d}.json"))["flicker"]
    for key in ("mean", "max", "beyond_cap"):
        assert abs(f[key] - run[key]) <= 1e-9 * (1 + abs(run[key])), (frame, key, f[key], run[key])
print("flicker afterwards = flicker in the run:", {k: round(v["mean"], 6) for k, v in post.items()})
PY

# A task granted less memory than its frame needs is refused, not killed; its threads are Slurm's.
# (A batch job's environment carries its grant, SLURM_MEM_PER_NODE; srun's tasks alone do not.)
job=("$meniscus" surface sim/fluid_0001.ply)
if sbatch --wait --mem=40 --cpus-per-task=1 --output=starved.out --wrap "${job[*]} -o starved/mesh.ply" >/dev/null 2>&1; then
  cat starved.out; fail "a 40 MB task surfaced a frame that needs more"
fi
grep -q "more than the .* allowed (90 % of Slurm's grant" starved.out || { cat starved.out; fail "no message naming the grant"; }
[[ ! -e starved/mesh.ply ]] || fail "a refused task left a mesh"
# Enough: 400 MB, or three times what the local run of the frame peaked at (a sanitizer build needs more).
fed=$(/usr/bin/python3 -c "import json; print(max(400, 3 * json.load(open('local/stats_0001.json'))['peak_memory_bytes'] // 2**20))")
sbatch --wait --mem="$fed" --cpus-per-task=1 --output=fed.out --wrap "${job[*]} -o fed/mesh.ply" >/dev/null 2>&1 ||
  { cat fed.out; fail "a $fed MB task failed"; }
grep -q "on 1 thread (SLURM_CPUS_PER_TASK)" fed.out || { cat fed.out; fail "--cpus-per-task=1 was not honoured"; }
cmp -s fed/mesh.ply local/mesh_0001.ply || fail "the batch job's mesh differs from the local run's"
echo "memory: a 40 MB task refused with a message, a $fed MB one ran on 1 thread"

# One frame over the two ranks of an MPI job under Slurm (PMIx).
if "$meniscus" info | grep -q "^mpi: yes"; then
  # (OpenMPI under a sanitizer build: no memory patcher, no leak report; see test_mpi.sh.)
  OMPI_MCA_memory=^patcher ASAN_OPTIONS="${ASAN_OPTIONS:-}${ASAN_OPTIONS:+:}detect_leaks=0" \
    sbatch --wait -n 2 --output=mpi.out --wrap "srun --mpi=pmix ${job[*]} -o mpi/mesh.ply --stats mpi/stats.json" >/dev/null 2>&1 ||
    { cat mpi.out; fail "the MPI job failed"; }
  grep -q '"ranks": 2' mpi/stats.json || fail "the MPI job did not run on 2 ranks"
  cmp local/mesh_0001.ply mpi/mesh.ply || fail "the MPI job's file is not the local run's"
  echo "mpi: srun --mpi=pmix over 2 ranks writes the local run's file, byte for byte"
else
  echo "mpi: this meniscus has no MPI; the MPI job is not run"
fi
echo "total $(elapsed)"
