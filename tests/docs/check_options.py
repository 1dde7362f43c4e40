#!/usr/bin/python3
"""docs/cli.md's reference of `meniscus surface`'s options cannot drift from the program.

The parameters' table in docs/cli.md (between the `options:` markers) is made from the table
the program itself uses (`meniscus info --parameters`: names, defaults, ranges, help), so this
checks it is exactly what that table gives; and every option `meniscus surface --help` lists is in
one of the page's option tables.

    check_options.py MENISCUS DOCS_CLI_MD            checks
    check_options.py MENISCUS DOCS_CLI_MD --write    rewrites the generated table in place
"""
import json
import re
import subprocess
import sys

BEGIN = "<!-- options: made from `meniscus info --parameters` by tests/docs/check_options.py --write -->"
END = "<!-- end of options -->"


def default_text(p):
    text = plain_default(p)
    if p.get("presets"):  # what the presets set, where they differ from the default
        text += " (" + ", ".join(f"{name}: {value:g}" if isinstance(value, float) else f"{name}: {value}"
                                 for name, value in p["presets"].items()) + ")"
    return text


def plain_default(p):
    if p.get("control"):
        return "—"
    value = p.get("default")
    if p.get("zero") and value in (0, -1):
        return p["zero"]
    if p["type"] == "flag":
        return "on" if value else "off"
    if isinstance(value, list):
        return "none" if not value else ",".join(str(v) for v in value)
    if isinstance(value, float) and value == int(value):
        return str(int(value))
    return str(value)


def table(parameters):
    rows = ["| option | default | accepts | unit | meaning |", "| --- | --- | --- | --- | --- |"]
    for p in parameters:
        if not p["option"]:
            continue
        accepts = p["accepts"]
        if p.get("zero"):  # the default column says what 0 (−1) derives
            accepts = re.sub(r" \((0|or −1): [^)]*\)$", lambda m: f" ({m.group(1)}: the default)", accepts)
        rows.append(f"| `{p['option']}` | {default_text(p)} | {accepts} | {p.get('unit', '')} | {p['help']} |")
    return "\n".join(rows) + "\n"


def main():
    meniscus, page = sys.argv[1], sys.argv[2]
    write = "--write" in sys.argv[3:]
    parameters = json.loads(subprocess.run([meniscus, "info", "--parameters"], check=True, capture_output=True,
                                           text=True).stdout)
    text = open(page, encoding="utf-8").read()
    if BEGIN not in text or END not in text:
        sys.exit(f"{page}: no generated options table (markers {BEGIN!r} … {END!r})")
    head, rest = text.split(BEGIN, 1)
    current, tail = rest.split(END, 1)
    expected = "\n" + table(parameters)
    if write:
        open(page, "w", encoding="utf-8").write(head + BEGIN + expected + END + tail)
        print(f"{page}: options table written ({len(parameters)} parameters)")
        return
    failures = 0
    if current != expected:
        print(f"{page}: the options table differs from `meniscus info --parameters`; run\n"
              f"  {sys.argv[0]} {meniscus} {page} --write\nexpected:\n{expected}")
        failures += 1
    # Every option of `meniscus surface --help` is documented in one of the page's tables.
    help_text = subprocess.run([meniscus, "surface", "--help"], check=True, capture_output=True, text=True).stdout
    options = sorted(set(re.findall(r"^ +(?:-\w, )?(--[a-z][a-z-]+)", help_text, re.MULTILINE)) - {"--help"})
    documented = set(re.findall(r"^\| `(--[a-z][a-z-]+)", text, re.MULTILINE))
    missing = [o for o in options if o not in documented]
    if missing:
        print(f"{page}: options of `meniscus surface --help` not in its tables: {', '.join(missing)}")
        failures += 1
    print(f"{page}: {len(options)} options, {len(parameters)} parameters checked" if not failures else "")
    sys.exit(1 if failures else 0)


if __name__ == "__main__":
    main()
