#!/usr/bin/python3
"""The Blender panel's parameters cannot drift from the program's table.

blender/meniscus_blender/parameter_table.py is made from `meniscus info --parameters` (the table
behind validation, config keys, the stats JSON, the CLI's options and the Python keywords): the
add-on builds its properties' defaults, ranges and help from it. This checks the file is exactly
what the table gives, or rewrites it.

    make_parameter_table.py MENISCUS PARAMETER_TABLE_PY            checks
    make_parameter_table.py MENISCUS PARAMETER_TABLE_PY --write    rewrites it
"""
import json
import subprocess
import sys

# What the table holds that depends on the machine it was made on (the thread count's range is
# the machine's cores): left out, so the file is the same wherever it is made.
MACHINE_DEPENDENT = {"threads"}
FIELDS = ("type", "default", "min", "min_open", "max", "choices", "unit", "control", "help", "zero")

HEADER = '''"""The parameters of `meniscus surface` as the program's table gives them (name, type, default,
range, unit, help): the panel's properties are made from these.

Made by blender/make_parameter_table.py from `meniscus info --parameters`; do not edit (a test
checks it against the program: run that script with --write after changing the table).
"""
'''


def contents(parameters):
    table = {p["key"]: {f: p[f] for f in FIELDS if f in p and p[f] is not None}
             for p in parameters if p["key"] not in MACHINE_DEPENDENT}
    lines = [f"    {key!r}: {entry!r}," for key, entry in table.items()]
    return HEADER + "\nPARAMETERS = {\n" + "\n".join(lines) + "\n}\n"


def main():
    meniscus, path = sys.argv[1], sys.argv[2]
    parameters = json.loads(subprocess.run([meniscus, "info", "--parameters"], check=True, capture_output=True,
                                           text=True).stdout)
    expected = contents(parameters)
    if "--write" in sys.argv[3:]:
        open(path, "w", encoding="utf-8").write(expected)
        print(f"{path}: written ({len(parameters) - len(MACHINE_DEPENDENT)} parameters)")
        return
    try:
        current = open(path, encoding="utf-8").read()
    except OSError as error:
        sys.exit(f"{path}: {error.strerror}")
    if current != expected:
        sys.exit(f"{path} differs from `meniscus info --parameters`; run\n  {sys.argv[0]} {meniscus} {path} --write")
    print(f"{path}: the same as the program's table")


if __name__ == "__main__":
    main()
