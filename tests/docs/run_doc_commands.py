#!/usr/bin/python3
"""Runs every command block of the README and of every docs/*.md page, so that none goes stale.

The README starts from the state its two commands leave on a Debian machine: the build
(`build/release`) complete and `cmake --install build/release --component cli` done. A page of docs/
starts where the README ends: everything installed (`cmake --install build/release`, as the README's
Python block does). Each page gets its own such machine, emulated in a fresh folder ROOT that stands
for `/`, so nothing outside it is written:

- `cmake --install` runs with DESTDIR=ROOT, so the build's prefix `/usr/local` becomes ROOT/usr/local;
- Debian's /usr/bin/python3 runs with PYTHONHOME=ROOT/usr, whose lib/python3.X and lib/python3 are
  links to the real ones: its site module then adds ROOT/usr/local/lib/python3.X/dist-packages to
  the path exactly where it adds /usr/local/lib/python3.X/dist-packages on the real machine. No
  PYTHONPATH is passed on and the user's site-packages are left out, so in the README `import
  meniscus` works only once one of its blocks installed the module (the runner checks that it cannot
  be imported before them, and that a docs page imports it from ROOT);
- PATH starts with ROOT/usr/local/bin.

The blocks run in a folder that links the repository's top-level entries (tests/, tools/, docs/ …)
and build/release (the build under test), with an empty out/. Every `sh` block runs with bash -e,
every `python` block with /usr/bin/python3, in page order; a block marked
`<!-- doc_commands: skip: WHY -->` is reported with its reason instead. Every fence must name its
language (`text` for listings), and shell commands are `sh`, so no command hides from the runner.
Outputs must go under out/: anything else a block leaves in the folder fails the page.

The README's first two blocks install packages and build: .ci/run runs them as they are
(tests/docs/doc_blocks.py extracts them), so they are skipped here.

    run_doc_commands.py REPO_ROOT BUILD_DIR [PAGE.md ...]     (default: the README and docs/*.md)
"""
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from doc_blocks import fenced  # noqa: E402

RUN_BY_CI = {"README.md": 2}  # page → how many leading `sh` blocks .ci/run runs instead
# Pages left out, with the reason (printed on every run).
EXCLUDED = {}
LANGUAGES = {"sh", "python", "text", "json", "cmake", "cpp", "vex", "ini"}  # what a fence may say
SHELLS = {"bash", "shell", "console", "zsh", "shell-session"}  # refused: command blocks are `sh`
PREFIX = "/usr/local"  # the README's install prefix (CMake's default)


def pages(repo, wanted):
    if wanted:
        return wanted
    return ["README.md"] + [str(p.relative_to(repo)) for p in sorted((repo / "docs").glob("*.md"))]


def install_prefix(build):
    cache = (build / "CMakeCache.txt").read_text(encoding="utf-8", errors="replace")
    for line in cache.splitlines():
        if line.startswith("CMAKE_INSTALL_PREFIX:"):
            return line.split("=", 1)[1]
    return None


def machine(build, root, component):
    """ROOT as `/` after `cmake --install` of the component (None: all); the environment that sees
    it as `/`."""
    version = f"python{sys.version_info.major}.{sys.version_info.minor}"
    (root / "usr" / "lib").mkdir(parents=True)
    for name in (version, "python3"):
        (root / "usr" / "lib" / name).symlink_to(pathlib.Path("/usr/lib") / name)
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
    env.update(DESTDIR=str(root), PYTHONHOME=str(root / "usr"), PYTHONNOUSERSITE="1",
               PATH=f"{root}{PREFIX}/bin:/usr/local/bin:/usr/bin:/bin")
    only = ["--component", component] if component else []
    subprocess.run(["cmake", "--install", str(build)] + only, env=env, check=True, stdout=subprocess.DEVNULL)
    return env


def sandbox(repo, build, where):
    for entry in sorted(repo.iterdir()):
        if entry.name not in (".git", "build", "out"):
            (where / entry.name).symlink_to(entry)
    (where / "build").mkdir()
    (where / "build" / "release").symlink_to(build)
    (where / "out").mkdir()
    return {p.name for p in where.iterdir()}


def check_machine(env, root, where, module_installed):
    """Refuses to run when the emulated machine is not the one the page starts from."""
    found = shutil.which("meniscus", path=env["PATH"])
    if found != f"{root}{PREFIX}/bin/meniscus":
        return f"expected the installed meniscus first on the PATH, found {found}"
    probe = subprocess.run(["/usr/bin/python3", "-c", "import meniscus; print(meniscus.__file__)"],
                           cwd=where, env=env, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    expected = f"{root}{PREFIX}/lib/" if module_installed else None
    if probe.returncode == 0 and not (expected and probe.stdout.startswith(expected)):
        return f"meniscus is importable from {probe.stdout.strip()}, not installed there by this run"
    if probe.returncode != 0 and module_installed:
        return "the installed meniscus module cannot be imported"
    return None


def run_page(repo, build, page):
    """Runs the page's blocks; returns how many failed."""
    try:
        found = fenced(repo / page)
    except ValueError as e:
        print(e)
        return 1
    failures, shell_blocks = 0, 0
    for b in found:
        if not b.language:
            print(f"{page}:{b.line}: a fence without a language: `sh` for commands to run, `text` for a listing")
            failures += 1
        elif b.language in SHELLS:
            print(f"{page}:{b.line}: a ```{b.language} block: commands are ```sh (and run here)")
            failures += 1
        elif b.language not in LANGUAGES:
            print(f"{page}:{b.line}: a ```{b.language} block: not one of {', '.join(sorted(LANGUAGES))}")
            failures += 1
    if failures:
        return failures
    with tempfile.TemporaryDirectory(prefix="meniscus-docs-") as tmp:
        where, root = pathlib.Path(tmp) / "checkout", pathlib.Path(tmp) / "root"
        where.mkdir()
        links = sandbox(repo, build, where)
        readme = page == "README.md"
        env = machine(build, root, "cli" if readme else None)
        problem = check_machine(env, root, where, module_installed=not readme)
        if problem:
            print(f"{page}: {problem}")
            return 1
        for b in found:
            if b.language not in ("sh", "python"):
                continue
            if b.language == "sh":
                shell_blocks += 1
            name = f"{page}:{b.line} ({b.language})"
            if b.language == "sh" and shell_blocks <= RUN_BY_CI.get(page, 0):
                print(f"{name}: run by .ci/run")
                continue
            if b.skip is not None:
                print(f"{name}: skipped: {b.skip}")
                continue
            if b.language == "sh":
                command, given = ["bash", "-e", "-o", "pipefail", "-c", b.text], None
            else:
                command, given = ["/usr/bin/python3", "-"], b.text
            t0 = time.monotonic()
            try:
                run = subprocess.run(command, cwd=where, env=env, input=given, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, timeout=600)
                code, output = run.returncode, run.stdout
            except subprocess.TimeoutExpired as e:
                code, output = "timeout after 600 s", e.stdout or ""
                if isinstance(output, bytes):
                    output = output.decode(errors="replace")
            print(f"{name}: {'ok' if code == 0 else f'FAILED (exit {code})'} in {time.monotonic() - t0:.1f} s")
            if code != 0:
                failures += 1
                print("---- block ----\n" + b.text + "---- output ----\n" + output[-4000:])
        stray = sorted({p.name for p in where.iterdir()} - links)
        if stray:
            print(f"{page}: its blocks wrote {', '.join(stray)} outside out/")
            failures += 1
    return failures


def main():
    repo, build = pathlib.Path(sys.argv[1]).resolve(), pathlib.Path(sys.argv[2]).resolve()
    prefix = install_prefix(build)
    if prefix != PREFIX:
        sys.exit(f"{build}: installs into {prefix}; the documentation's commands assume {PREFIX}")
    failures = 0
    for page in pages(repo, sys.argv[3:]):
        if page in EXCLUDED:
            print(f"{page}: not run: {EXCLUDED[page]}")
            continue
        ci = RUN_BY_CI.get(page, 0)
        if ci and len([b for b in fenced(repo / page) if b.language == "sh"]) <= ci:
            print(f"{page}: expected more than {ci} command blocks")
            failures += 1
            continue
        failures += run_page(repo, build, page)
    print(f"{failures} failed" if failures else "all ran")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
