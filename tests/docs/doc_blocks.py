#!/usr/bin/python3
"""The command blocks of a Markdown page: the fenced blocks marked `sh`.

    doc_blocks.py PAGE.md N      prints the N-th block (1-based), e.g. for `eval` in .ci/run
    doc_blocks.py PAGE.md        prints how many there are
"""
import re
import sys

FENCE = re.compile(r"^```sh[ \t]*\n(.*?)^```[ \t]*$", re.MULTILINE | re.DOTALL)


def blocks(path):
    """The `sh` blocks of the page at path, in order, each as its text."""
    with open(path, encoding="utf-8") as f:
        return [m.group(1) for m in FENCE.finditer(f.read())]


if __name__ == "__main__":
    found = blocks(sys.argv[1])
    if len(sys.argv) == 2:
        print(len(found))
    else:
        n = int(sys.argv[2])
        if not 1 <= n <= len(found):
            sys.exit(f"{sys.argv[1]}: no command block {n} (it has {len(found)})")
        sys.stdout.write(found[n - 1])
