#!/usr/bin/python3
"""The fenced blocks of a Markdown page, and its command blocks: the blocks marked `sh`.

A fence may be indented (a block inside a list item); its lines lose that indentation. The first
word after the opening fence is the block's language. A line `<!-- doc_commands: skip: WHY -->`
right before a fence (blank lines between allowed) marks a block the documentation tests do not
run, and says why; GitHub does not show it.

    doc_blocks.py PAGE.md N      prints the N-th `sh` block (1-based), e.g. for `eval` in .ci/run
    doc_blocks.py PAGE.md        prints how many `sh` blocks there are
"""
import collections
import re
import sys

Block = collections.namedtuple("Block", "language text line skip")  # line: the opening fence's, 1-based

OPEN = re.compile(r"^( *)(`{3,}|~{3,})\s*([^\s`]*)")
SKIP = re.compile(r"^\s*<!--\s*doc_commands:\s*skip:\s*(.*?)\s*-->\s*$")


def fenced(path):
    """Every fenced block of the page at path, in order. Raises ValueError for a fence left open."""
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    found, n, note = [], 0, None
    while n < len(lines):
        opening = OPEN.match(lines[n])
        if not opening:
            if lines[n].strip():
                marker = SKIP.match(lines[n])
                note = marker.group(1) if marker else None
            n += 1
            continue
        indent, fence, language = len(opening.group(1)), opening.group(2), opening.group(3)
        closing = re.compile(r"^ *" + re.escape(fence[0]) + "{" + str(len(fence)) + r",}\s*$")
        end = next((k for k in range(n + 1, len(lines)) if closing.match(lines[k])), None)
        if end is None:
            raise ValueError(f"{path}:{n + 1}: the fence opened here is never closed")
        body = [re.sub(r"^ {0,%d}" % indent, "", line) for line in lines[n + 1:end]]
        found.append(Block(language, "".join(line + "\n" for line in body), n + 1, note))
        note, n = None, end + 1
    return found


def blocks(path):
    """The `sh` blocks of the page at path, in order, each as its text."""
    return [b.text for b in fenced(path) if b.language == "sh"]


if __name__ == "__main__":
    found = blocks(sys.argv[1])
    if len(sys.argv) == 2:
        print(len(found))
    else:
        n = int(sys.argv[2])
        if not 1 <= n <= len(found):
            sys.exit(f"{sys.argv[1]}: no command block {n} (it has {len(found)})")
        sys.stdout.write(found[n - 1])
