#!/usr/bin/env bash
# `cmake --install` of a build into a fresh prefix, then everything a user takes from it: the
# command on PATH, the Python module from the prefix, the Blender add-on zip, and a program outside
# the tree built with find_package(meniscus) that surfaces a block.
#   test_install.sh BUILD_DIR SOURCE_DIR PYTHON [COMPILER_FLAGS]   (the flags a sanitized library needs)
set -euo pipefail
build=$1 source=$2 python=$3 flags=${4:-}
prefix=$(mktemp -d) work=$(mktemp -d)
trap 'rm -rf "$prefix" "$work"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

cmake --install "$build" --prefix "$prefix" > "$work/install.log"
for f in bin/meniscus lib/libmeniscus.a include/meniscus/reconstruct.hpp lib/cmake/meniscus/meniscusConfig.cmake \
         share/meniscus/meniscus_blender.zip; do
  [[ -e $prefix/$f ]] || fail "$f not installed"
done

# The command, from the prefix alone.
PATH="$prefix/bin:/usr/bin:/bin" meniscus info | grep -q "^meniscus " || fail "meniscus info"
PATH="$prefix/bin:/usr/bin:/bin" meniscus surface "$source/tests/data/ply/fluid_250_particles.ply" -o "$work/cli.ply" -q
echo "cli: $(PATH="$prefix/bin:/usr/bin:/bin" command -v meniscus) surfaced a frame"

# The Python module, from the prefix's dist-packages (not the build's).
if [[ -d $(echo "$prefix"/lib/python3*/dist-packages/meniscus) ]]; then
  PYTHONPATH=$(echo "$prefix"/lib/python3*/dist-packages) "$python" -c "
import meniscus, sys
assert meniscus.__file__.startswith('$prefix'), meniscus.__file__
mesh = meniscus.reconstruct(meniscus.read_particles('$source/tests/data/ply/fluid_250_particles.ply'))
print('python:', meniscus.__file__, len(mesh.triangles), 'triangles')
"
else
  echo "python: not built here (no pybind11), not installed"
fi

# The add-on zip: the folder Blender installs, at its root.
"$python" - "$prefix/share/meniscus/meniscus_blender.zip" <<'PY'
import sys, zipfile
names = zipfile.ZipFile(sys.argv[1]).namelist()
assert "meniscus_blender/__init__.py" in names, names
print("blender: the add-on zip holds", ", ".join(names))
PY

# A program outside the tree, against the installed package.
cmake -S "$source/tests/install/consumer" -B "$work/consumer" -G Ninja -DCMAKE_PREFIX_PATH="$prefix" \
  -DCMAKE_BUILD_TYPE=Release -DCMAKE_CXX_FLAGS="$flags" -DCMAKE_EXE_LINKER_FLAGS="$flags" > "$work/consumer.log" 2>&1 || { cat "$work/consumer.log"; fail "find_package(meniscus)"; }
cmake --build "$work/consumer" >> "$work/consumer.log" 2>&1 || { cat "$work/consumer.log"; fail "the consumer did not build"; }
"$work/consumer/surface_block" "$work/block.ply"
PATH="$prefix/bin:/usr/bin:/bin" meniscus inspect "$work/block.ply" | grep -q "^topology: watertight" || fail "the consumer's mesh"
echo "install: ok"
