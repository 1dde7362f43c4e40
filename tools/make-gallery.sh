#!/usr/bin/env bash
# Regenerates the README's gallery (docs/images/gallery/*.png): every real frame in tests/data
# surfaced with the defaults and drawn by `meniscus render`, coloured by speed where the frame
# has a velocity. Run from anywhere after building the CLI (cmake --build --preset release).
#   bash tools/make-gallery.sh [path/to/meniscus]
set -euo pipefail
cd "$(dirname "$0")/.."
cli=${1:-build/release/meniscus}
out=docs/images/gallery
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$out"

# name | particle file | up axis | yaw | surface options | render options
frames=(
  "dam_break_23|tests/data/dam_break_frame_23_24389_particles.bgeo|y|35||"
  "dam_break_9|tests/data/dam_break_frame_9_6859_particles.bgeo|y|35|--transfer velocity|--color-by velocity"
  "double_dam_break|tests/data/double_dam_break_frame_26_4732_particles.vtk|y|35|--transfer velocity|--color-by velocity"
  "bunny|tests/data/bunny_frame_14_7705_particles.vtk|y|35|--transfer velocity|--color-by velocity"
  "sphysics_dam_break|tests/data/sphysics_dam_break_IPART_29814_particles.txt.gz|z|35|--columns x,y,z,vx,vy,vz,rho,p,mass --transfer velocity|--color-by velocity"
  "houdini_splatter|tests/data/houdini_pop_splatter_13883_points.bgeo.sc|y|35||"
)
for entry in "${frames[@]}"; do
  IFS='|' read -r name file up yaw surface_opts render_opts <<< "$entry"
  # shellcheck disable=SC2086  # the option strings are word lists
  "$cli" surface "$file" -o "$work/$name.ply" -q $surface_opts
  # shellcheck disable=SC2086
  "$cli" render "$work/$name.ply" -o "$out/$name.png" --size 480x360 --up "$up" --yaw "$yaw" -q $render_opts
  echo "wrote $out/$name.png"
done
