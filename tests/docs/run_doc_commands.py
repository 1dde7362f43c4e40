#!/usr/bin/python3
"""Runs every command block of the README and docs/cli.md, so that none goes stale.

Each page's `sh` blocks run in order, with bash -e, in a fresh folder that looks like the
repository root: tests/, blender/, tools/ … are links to the real ones, `build/release` is the
build under test, `meniscus` is on the PATH, and sim/ and geo/ hold copies of bundled frames
as the examples' sequences (sim/fluid_0001.bgeo …, geo/fluid.0001.bgeo.sc …).

The README's first two blocks install packages and build: .ci/run runs them as they are
(tests/docs/doc_blocks.py extracts them), so they are skipped here.

    run_doc_commands.py REPO_ROOT BUILD_DIR
"""
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from doc_blocks import blocks  # noqa: E402

PAGES = {"README.md": 2, "docs/cli.md": 0}  # page → how many leading blocks .ci/run runs instead


def sandbox(repo, build, where):
    for name in ("tests", "blender", "tools", "python", "docs", "bench", "include", "src"):
        (where / name).symlink_to(repo / name)
    (where / "build").mkdir()
    (where / "build" / "release").symlink_to(build)
    for folder in ("sim", "geo", "out", "bin"):
        (where / folder).mkdir()
    frame = repo / "tests" / "data" / "dam_break_frame_9_6859_particles.bgeo"
    for i in (1, 2, 3):
        shutil.copy(frame, where / "sim" / f"fluid_{i:04d}.bgeo")
    cache = repo / "tests" / "data" / "houdini_pop_splatter_13883_points.bgeo.sc"
    for i in (1, 2):
        shutil.copy(cache, where / "geo" / f"fluid.{i:04d}.bgeo.sc")
    (where / "bin" / "meniscus").symlink_to(build / "meniscus")


def main():
    repo, build = pathlib.Path(sys.argv[1]).resolve(), pathlib.Path(sys.argv[2]).resolve()
    failures = 0
    for page, skipped in PAGES.items():
        found = blocks(repo / page)
        if len(found) <= skipped:
            print(f"{page}: expected more than {skipped} command blocks, found {len(found)}")
            failures += 1
            continue
        with tempfile.TemporaryDirectory() as tmp:
            where = pathlib.Path(tmp)
            sandbox(repo, build, where)
            env = dict(os.environ, PATH=f"{where / 'bin'}:{os.environ['PATH']}")
            for n, block in enumerate(found, 1):
                if n <= skipped:
                    print(f"{page} block {n}: run by .ci/run")
                    continue
                t0 = time.monotonic()
                run = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", block], cwd=where, env=env,
                                     stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=600)
                status = "ok" if run.returncode == 0 else f"FAILED (exit {run.returncode})"
                print(f"{page} block {n}: {status} in {time.monotonic() - t0:.1f} s")
                if run.returncode != 0:
                    failures += 1
                    print("---- block ----\n" + block + "---- output ----\n" + run.stdout[-4000:])
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
