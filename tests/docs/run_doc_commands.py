#!/usr/bin/python3
"""Runs every command block of the README, docs/cli.md and docs/cluster.md, so that none goes stale.

The build under test is installed (`cmake --install`) into a fresh prefix, as a user's would be,
and each page's `sh` blocks run in order, with bash -e, in a fresh folder that holds only links
to the repository's data (tests/, tools/, docs/ …), with the prefix's `meniscus` first on the PATH
and its Python module on the PYTHONPATH: nothing of the build folder is used.

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

PAGES = {"README.md": 2, "docs/cli.md": 0, "docs/cluster.md": 0}  # page → how many leading blocks .ci/run runs instead


def sandbox(repo, where):
    for name in ("tests", "blender", "tools", "python", "docs", "bench", "include", "src"):
        (where / name).symlink_to(repo / name)
    (where / "out").mkdir()


def install(build, prefix):
    """`cmake --install` of the build into prefix; the environment that uses it alone."""
    subprocess.run(["cmake", "--install", str(build), "--prefix", str(prefix)], check=True,
                   stdout=subprocess.DEVNULL)
    env = dict(os.environ, PATH=f"{prefix / 'bin'}:/usr/local/bin:/usr/bin:/bin")
    packages = sorted(prefix.glob("lib/python3*/dist-packages"))
    if packages:
        env["PYTHONPATH"] = str(packages[0])
    return env


def main():
    repo, build = pathlib.Path(sys.argv[1]).resolve(), pathlib.Path(sys.argv[2]).resolve()
    prefix = pathlib.Path(tempfile.mkdtemp(prefix="meniscus-prefix-"))
    env = install(build, prefix)
    found_meniscus = shutil.which("meniscus", path=env["PATH"])
    print(f"meniscus on the PATH: {found_meniscus}")
    if found_meniscus != str(prefix / "bin" / "meniscus"):
        sys.exit(f"expected the installed meniscus first on the PATH, found {found_meniscus}")
    failures = 0
    for page, skipped in PAGES.items():
        found = blocks(repo / page)
        if len(found) <= skipped:
            print(f"{page}: expected more than {skipped} command blocks, found {len(found)}")
            failures += 1
            continue
        with tempfile.TemporaryDirectory() as tmp:
            where = pathlib.Path(tmp)
            sandbox(repo, where)
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
    shutil.rmtree(prefix, ignore_errors=True)
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
