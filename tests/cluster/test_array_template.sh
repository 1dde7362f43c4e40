#!/usr/bin/env bash
# tools/cluster/surface-array.sbatch where no Slurm runs, as docs/cluster.md uses it: the dry run
# prints the submission and warns on stderr when the input's frames do not exist where it runs (none
# of them, or some), for each kind of frame placeholder; a task run by hand (SLURM_ARRAY_TASK_ID)
# surfaces its chunk, byte-identical to one run over the sequence, and a task past the end does
# nothing. Usage: test_array_template.sh MENISCUS_BINARY DATA_DIR
set -euo pipefail
meniscus=$(realpath "$1") data=$(realpath "$2")
template=$(cd "$(dirname "$0")/../.." && pwd)/tools/cluster/surface-array.sbatch
work=$(mktemp -d /tmp/meniscus-array.XXXXXX)
trap 'rm -rf "$work"' EXIT
cd "$work"
fail() { echo "FAIL: $*"; exit 1; }
export MENISCUS=$meniscus
mkdir sim
cp "$data"/sequence/fluid_000[1-6].bgeo.sc sim/
dry() {  # name, template arguments...: stdout in NAME.out, stderr in NAME.err; must exit 0
  local name=$1
  shift
  bash "$template" "$@" > "$name.out" 2> "$name.err" || { cat "$name.out" "$name.err"; fail "$name: the dry run failed"; }
  grep -q "^sbatch --array=" "$name.out" || { cat "$name.out"; fail "$name: no submission printed"; }
  if grep -q warning "$name.out"; then fail "$name: a warning on stdout"; fi
}

# Every frame there: the submission, no warning.
dry all 'sim/fluid_####.bgeo.sc' 'mesh/fluid_####.ply' --frames 1-6 --chunk 4
grep -q -- "--array=0-1 " all.out || { cat all.out; fail "not --array=0-1 for 6 frames in chunks of 4"; }
[[ ! -s all.err ]] || { cat all.err; fail "a warning although every frame exists"; }
dry printf_style 'sim/fluid_%04d.bgeo.sc' 'mesh/fluid_####.ply' --frames 2-5
[[ ! -s printf_style.err ]] || { cat printf_style.err; fail "a warning for %04d frames that exist"; }

# A pattern that matches nothing here: a warning naming it and the first frame's file.
dry none 'sim_elsewhere/fluid_####.bgeo.sc' 'mesh/fluid_####.ply' --frames 1-240 --chunk 4
grep -q -- "--array=0-59 " none.out || { cat none.out; fail "not --array=0-59 for 240 frames in chunks of 4"; }
grep -q "warning: 'sim_elsewhere/fluid_####.bgeo.sc' matches no file here for frames 1-240 (frame 1 is sim_elsewhere/fluid_0001.bgeo.sc)" none.err ||
  { cat none.err; fail "no warning for a pattern that matches nothing"; }
# {} numbers frames without padding: fluid_2.bgeo.sc does not exist.
dry braces 'sim/fluid_{}.bgeo.sc' 'mesh/fluid_####.ply' --frames 2-3
grep -q "matches no file here for frames 2-3 (frame 2 is sim/fluid_2.bgeo.sc)" braces.err || { cat braces.err; fail "no warning for {}"; }
# Some frames missing: how many, and the first.
dry some 'sim/fluid_####.bgeo.sc' 'mesh/fluid_####.ply' --frames 1-7:3
grep -q "warning: 1 of the 3 frames of 'sim/fluid_####.bgeo.sc' do not exist here (the first: sim/fluid_0007.bgeo.sc)" some.err ||
  { cat some.err; fail "no warning for a missing frame"; }
# No placeholder: every task would surface the one file.
dry one_file 'sim/fluid_0001.bgeo.sc' 'mesh/fluid_####.ply' --frames 1-2
grep -q "has no frame placeholder" one_file.err || { cat one_file.err; fail "no warning without a placeholder"; }
echo "dry run: the submission printed; warnings on stderr for none, some, {} and no placeholder"

# A task by hand: task 1 of chunks of 4 surfaces frames 5 and 6, as one run over the sequence does.
SLURM_ARRAY_TASK_ID=1 bash "$template" 'sim/fluid_####.bgeo.sc' 'mesh/fluid_####.ply' --frames 1-6 --chunk 4 -q > task.out 2>&1 ||
  { cat task.out; fail "task 1 failed"; }
grep -q "task 1 of 2 .*frames 5-6:1 of 1-6 with $meniscus" task.out || { cat task.out; fail "the task does not say what it runs"; }
[[ $(ls mesh) == $'fluid_0005.ply\nfluid_0006.ply' ]] || { ls mesh; fail "task 1 did not write frames 5 and 6 alone"; }
"$meniscus" surface 'sim/fluid_####.bgeo.sc' -o 'one/fluid_####.ply' --frames 1-6 -q
for f in 5 6; do cmp "mesh/fluid_000$f.ply" "one/fluid_000$f.ply" || fail "frame $f of task 1 is not the single run's"; done
SLURM_ARRAY_TASK_ID=2 bash "$template" 'sim/fluid_####.bgeo.sc' 'mesh/fluid_####.ply' --frames 1-6 --chunk 4 > past.out 2>&1 ||
  { cat past.out; fail "a task past the end failed"; }
grep -q "only 2 chunks" past.out || { cat past.out; fail "a task past the end does not say so"; }
echo "task by hand: frames 5-6 byte-identical to one run over the sequence; a task past the end does nothing"
