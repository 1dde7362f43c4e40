#!/usr/bin/python3
"""Checks that every relative link and picture in the README and the docs resolves: the file
exists, and an anchor (#section) names a heading of that file (GitHub's heading slugs); and that
the code's comments cite only files the repository has: a path like docs/method.md, src/x/y.hpp
or smooth/schedule.hpp (relative to the root, src/, include/ or the citing file), README or a
docs page with a "Section" in quotes (a heading of that page), and no DESIGN (not shipped).

    check_links.py REPO_ROOT
"""
import pathlib
import re
import sys

LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
HEADING = re.compile(r"^#{1,6}\s+(.*?)\s*$", re.MULTILINE)
CODE = re.compile(r"^```.*?^```", re.MULTILINE | re.DOTALL)


def slug(heading):
    """GitHub's anchor of a heading: lower case, markup and punctuation dropped, spaces → '-'."""
    text = re.sub(r"[`*_]|\[([^\]]*)\]\([^)]*\)", lambda m: m.group(1) or "", heading).lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path):
    text = CODE.sub("", path.read_text(encoding="utf-8"))
    return {slug(h) for h in HEADING.findall(text)}


def pages(repo):
    yield repo / "README.md"
    yield from sorted((repo / "docs").glob("*.md"))
    yield repo / "bench" / "RESULTS.md"
    yield repo / "tests" / "data" / "README.md"


SOURCES = ("*.cpp", "*.hpp", "*.cu", "*.h", "*.py", "*.sh", "*.sbatch", "CMakeLists.txt", "*.cmake", "*.in")
SOURCE_DIRS = ("src", "include", "apps", "python", "tests", "bench", "tools", "blender", "cmake", ".ci")
CITED_PATH = re.compile(r"(?<![\w/.-])((?:\.\./)*(?:[\w-]+/)+[\w.-]+\.(?:md|hpp|cpp|cu|h|py|sh|sbatch|txt|json))(?:#([\w-]+))?")
CITED_SECTION = re.compile(r"(README|(?:docs/)?[\w-]+\.md) \"([^\"]+)\"")


def headings(path):
    text = CODE.sub("", path.read_text(encoding="utf-8"))
    return {re.sub(r"[`*_]", "", h).strip().lower() for h in HEADING.findall(text)}


def source_files(repo):
    for folder in SOURCE_DIRS:
        for pattern in SOURCES:
            for f in sorted((repo / folder).rglob(pattern)):
                if "data" not in f.relative_to(repo).parts[:2]:
                    yield f
    yield repo / ".ci" / "run"
    yield repo / "CMakeLists.txt"


def check_sources(repo):
    bad, checked = [], 0
    for f in source_files(repo):
        if not f.is_file():
            continue
        rel = f.relative_to(repo)
        marker = "//" if f.suffix in (".cpp", ".hpp", ".cu", ".h") else "#"
        for n, full in enumerate(f.read_text(encoding="utf-8", errors="replace").splitlines(), 1):
            at = full.find(marker)
            if at < 0 or full.lstrip().startswith(("#include", "#!")):
                continue
            line = full[at:]  # the comment
            if re.search(r"\bDESIGN\b", line):
                bad.append(f"{rel}:{n}: cites DESIGN, a file the repository does not have")
            for path, anchor in CITED_PATH.findall(line):
                if "*" in path or "<" in path or path.startswith(("http", "build/", "out/", "tmp/")):
                    continue
                checked += 1
                bases = [repo, repo / "src", repo / "include", f.parent]
                found = next((b / path for b in bases if (b / path).exists()), None)
                if found is None:
                    bad.append(f"{rel}:{n}: cites {path}, which the repository does not have")
                elif anchor and found.suffix == ".md" and anchor not in anchors(found):
                    bad.append(f"{rel}:{n}: no heading '#{anchor}' in {path}")
            for page, section in CITED_SECTION.findall(line):
                checked += 1
                target = repo / ("README.md" if page == "README" else page if page.startswith("docs/") else "docs/" + page)
                if not target.exists():
                    bad.append(f"{rel}:{n}: cites {page}, which the repository does not have")
                elif not any(h.startswith(section.lower()) for h in headings(target)):
                    bad.append(f"{rel}:{n}: {page} has no section \"{section}\"")
    return bad, checked


def main():
    repo = pathlib.Path(sys.argv[1]).resolve()
    bad, checked = check_sources(repo)
    for page in pages(repo):
        text = CODE.sub("", page.read_text(encoding="utf-8"))
        for target in LINK.findall(text):
            if re.match(r"[a-z]+:", target):  # https:, mailto: …
                continue
            checked += 1
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve() if path else page
            where = f"{page.relative_to(repo)}: ({target})"
            if not dest.exists():
                bad.append(f"{where}: no such file {dest.relative_to(repo) if repo in dest.parents else dest}")
            elif repo not in dest.parents and dest != repo:
                bad.append(f"{where}: points outside the repository")
            elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                bad.append(f"{where}: no heading '#{anchor}' in {dest.relative_to(repo)}")
    print(f"{checked} relative links and citations in comments checked")
    for b in bad:
        print(b)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
