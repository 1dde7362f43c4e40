#!/usr/bin/python3
"""The CUDA backend's sources launch every kernel through MENISCUS_LAUNCH and copy through the
counted helpers, so that the emulated device runs every launch and --stats counts them all:
no raw `<<<` launch and no direct cudaMemcpy / cudaMemset outside src/cuda/cuda_check.hpp (and the
emulated runtime itself).

    check_sources.py REPO_ROOT
"""
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1])
allowed = {root / "src/cuda/cuda_check.hpp"}
bad = []
for path in sorted((root / "src").rglob("*")):
    if path.suffix not in (".cu", ".cpp", ".hpp", ".h") or path in allowed or "emulation" in path.parts:
        continue
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        code = line.split("//")[0]
        if "<<<" in code:
            bad.append(f"{path.relative_to(root)}:{n}: raw kernel launch (use MENISCUS_LAUNCH): {line.strip()}")
        if re.search(r"\bcudaMem(cpy|set)\s*\(", code):
            bad.append(f"{path.relative_to(root)}:{n}: uncounted copy (use counted_memcpy / counted_memset): {line.strip()}")
launches = sum(p.read_text(encoding="utf-8").count("MENISCUS_LAUNCH(") for p in (root / "src").rglob("*") if p.suffix in (".cu", ".hpp"))
print(f"{launches} launches through MENISCUS_LAUNCH")
print("\n".join(bad))
sys.exit(1 if bad or launches == 0 else 0)
