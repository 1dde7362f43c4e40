#!/usr/bin/python3
"""Checks that every relative link and picture in the README and the docs resolves: the file
exists, and an anchor (#section) names a heading of that file (GitHub's heading slugs).

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


def main():
    repo = pathlib.Path(sys.argv[1]).resolve()
    bad, checked = [], 0
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
    print(f"{checked} relative links checked")
    for b in bad:
        print(b)
    sys.exit(1 if bad else 0)


if __name__ == "__main__":
    main()
