#!/usr/bin/env bash
# meniscus bench — two builds of the CLI side by side on the same frames, in one run: each frame
# surfaced REPEAT times by each build, alternating A and B so that the machine's drift hits both, and
# per frame the fastest wall time, the largest peak RSS (/usr/bin/time) and the ratio B / A.
# Frames: the bundled real ones and wide splashes of 300k and 1M particles (bench/wide_splash.py).
#   bench/ab.sh CLI_A CLI_B [REPEAT=5] [-- extra surface options]
# To compare with an earlier commit: git worktree add /tmp/old COMMIT, build its meniscus_cli there.
set -euo pipefail
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
a=$1 b=$2 repeat=${3:-5}
shift $(( $# >= 3 ? 3 : 2 ))
[[ ${1:-} == -- ]] && shift
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
/usr/bin/python3 "$root/bench/wide_splash.py" 300000 "$work/splash_300k.ply" >/dev/null
/usr/bin/python3 "$root/bench/wide_splash.py" 1000000 "$work/splash_1m.ply" >/dev/null
frames=("$root/tests/data/ply/dam_break_frame_23_24389_particles.ply"
        "$root/tests/data/ply/sphysics_dam_break_IPART_29814_particles.ply"
        "$work/splash_300k.ply" "$work/splash_1m.ply")

options=("$@")
measure() {  # measure CLI FRAME OUT: sets s (wall seconds) and kb (peak RSS); a failed run ends the bench
  if ! /usr/bin/time -f "%e %M" -o "$work/time" "$1" surface "$2" -q -o "$3" "${options[@]}" >/dev/null 2>"$work/err"; then
    echo "FAIL: $1 surface $2 ${options[*]}: $(cat "$work/err")" >&2
    exit 1
  fi
  read -r s kb < <(tail -n 1 "$work/time")
}
echo "# $(nproc) threads, $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ *//'), best of $repeat"
printf "%-44s %10s %10s %7s %10s %10s %7s %s\n" frame "A s" "B s" "B/A" "A MB" "B MB" "B/A" mesh
for frame in "${frames[@]}"; do
  best_a=1e9 best_b=1e9 peak_a=0 peak_b=0
  for ((i = 0; i < repeat; ++i)); do
    measure "$a" "$frame" "$work/a.ply"
    best_a=$(awk -v x="$s" -v y="$best_a" 'BEGIN { print (x < y ? x : y) }'); (( kb > peak_a )) && peak_a=$kb
    measure "$b" "$frame" "$work/b.ply"
    best_b=$(awk -v x="$s" -v y="$best_b" 'BEGIN { print (x < y ? x : y) }'); (( kb > peak_b )) && peak_b=$kb
  done
  same=$(cmp -s "$work/a.ply" "$work/b.ply" && echo "same bytes" || echo "DIFFERENT")
  awk -v f="$(basename "$frame")" -v ta="$best_a" -v tb="$best_b" -v ma="$peak_a" -v mb="$peak_b" -v same="$same" \
    'BEGIN { printf "%-44s %10.3f %10.3f %7.3f %10.0f %10.0f %7.3f %s\n", f, ta, tb, tb / ta, ma / 1024, mb / 1024, mb / ma, same }'
done
