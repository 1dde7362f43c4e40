#!/usr/bin/python3
"""CPU parallelism goes through the host primitives: outside src/common/ (common/for_each.hpp,
common/primitives.hpp, radix_sort.hpp) and the emulated device (src/cuda/emulation/), no source of
src/, apps/ or python/ calls or includes a oneTBB algorithm (tbb::parallel_*, enumerable_thread_specific,
combinable). Thread-count setup (tbb::global_control, task_arena, tbb::info) is not an algorithm
and may be used anywhere.

    check_host_primitives.py REPO_ROOT
"""
import pathlib
import re
import sys

ALGORITHM = re.compile(
    r"\btbb::parallel_\w+"
    r"|\b(enumerable_thread_specific|combinable)\b"
    r"|#\s*include\s*[<\"](oneapi/)?tbb/(parallel_\w+|enumerable_thread_specific|combinable)\.h"
    r"|\busing\s+namespace\s+(oneapi::)?tbb\b"
)

# The pattern itself must catch what it is for (a broken pattern would pass every tree). The
# headers' names are split so that tests/docs/check_links.py does not take them for citations.
for sample in ("tbb::parallel_sort(a, b);", "oneapi::tbb::parallel_for(r, f);", "tbb::enumerable_thread_specific<int> x;",
               "tbb::combinable<int> c;", "#include <tbb/parallel_reduce" ".h>",
               "#include <oneapi/tbb/enumerable_thread_specific" ".h>", "using namespace tbb;"):
    assert ALGORITHM.search(sample), sample
for sample in ("tbb::global_control c(tbb::global_control::max_allowed_parallelism, 1);", "tbb::task_arena arena(4);",
               "#include <tbb/global_control" ".h>", "reduce(n, 1, 0, body, std::plus<>());"):
    assert not ALGORITHM.search(sample), sample

root = pathlib.Path(sys.argv[1])
allowed = (root / "src/common", root / "src/cuda/emulation")
files = 0
bad = []
for folder in ("src", "apps", "python"):
    for path in sorted((root / folder).rglob("*")):
        if path.suffix not in (".cpp", ".hpp", ".h", ".cu", ".cuh") or any(a in path.parents for a in allowed):
            continue
        files += 1
        for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if ALGORITHM.search(line.split("//")[0]):
                bad.append(f"{path.relative_to(root)}:{n}: oneTBB algorithm outside src/common (use common/primitives.hpp): {line.strip()}")
print(f"{files} sources checked")
print("\n".join(bad))
sys.exit(1 if bad or files == 0 else 0)
