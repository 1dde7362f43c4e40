#!/usr/bin/env bash
# A meniscus built without its optional libraries (CGAL, OpenVDB): `info` says so, a frame still
# surfaces watertight (and decimates, which needs no optional library), and --clip-cap and
# --save-field are refused with a message naming the missing library, before any work, leaving no
# output behind.
#   check-minimal-build.sh MENISCUS
set -euo pipefail
cd "$(dirname "$0")/.."
meniscus=$1
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
frame=tests/data/ply/dam_break_frame_9_6859_particles.ply

info=$("$meniscus" info)
for line in "openvdb: no" "cgal: no"; do
  grep -q "^$line" <<<"$info" || fail "meniscus info does not say '$line'"
done
"$meniscus" surface "$frame" -q -o "$work/m.ply"
"$meniscus" inspect "$work/m.ply" | grep -q "^topology: watertight" || fail "the mesh of a minimal build"
refused() {  # refused OPTIONS… -- WORDS: exit 2, the message names WORDS, no mesh written
  local options=() words
  while [[ $1 != -- ]]; do options+=("$1"); shift; done
  shift; words=$*
  local out status=0
  out=$("$meniscus" surface "$frame" -q -o "$work/refused.ply" "${options[@]}" 2>&1) || status=$?
  [[ $status == 2 ]] || fail "${options[*]}: exit $status, expected 2 (an invalid parameter): $out"
  grep -q "$words" <<<"$out" || fail "${options[*]}: the message does not name '$words': $out"
  [[ ! -e $work/refused.ply ]] || fail "${options[*]}: a mesh was written"
}
refused --clip-box -1,-1,0.05,1,1,1 --clip-cap -- "built without CGAL"
refused --save-field "$work/f.vdb" -- "built without OpenVDB"
"$meniscus" surface "$frame" -q -o "$work/clipped.ply" --clip-box -1,-1,0.05,1,1,1  # a clip without a cap needs none
"$meniscus" surface "$frame" -q -o "$work/lean.ply" --decimate 0.02
"$meniscus" inspect "$work/lean.ply" | grep -q "^topology: watertight" || fail "the decimated mesh of a minimal build"
echo "minimal build: surfaces and decimates; --clip-cap and --save-field refused by name"
