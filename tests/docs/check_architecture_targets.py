#!/usr/bin/env python3
"""docs/architecture.md's targets table against the targets CMake defines.

Usage: check_architecture_targets.py TARGETS_FILE ARCHITECTURE_MD

TARGETS_FILE is build/organsim_targets.txt (one "name TYPE" line per library or
executable target defined outside tests/, written at configure time). The table
is the one under "## Targets": its first column names each target in backticks;
"(optional)" after the name allows it to be absent from a build, and a name with
<placeholder> stands for any name of that shape (organsim_kernels_<level>).
Fails, naming them, when a defined target is missing from the table or a
non-optional row names no defined target.
"""
import re
import sys


def table_rows(markdown):
    """(pattern, optional, name) for each row of the table under "## Targets"."""
    section = markdown.split("\n## Targets\n", 1)
    if len(section) != 2:
        sys.exit("architecture.md has no '## Targets' section")
    rows = []
    for line in section[1].split("\n## ", 1)[0].splitlines():
        match = re.match(r"\|\s*`([^`]+)`([^|]*)\|", line)
        if not match:
            continue
        name = match.group(1)
        pattern = "^" + re.sub(r"<[^>]+>", "[A-Za-z0-9_]+", re.escape(name).replace(r"\<", "<").replace(r"\>", ">")) + "$"
        rows.append((re.compile(pattern), "optional" in match.group(2), name))
    if not rows:
        sys.exit("the '## Targets' section of architecture.md has no table rows naming targets")
    return rows


def main():
    targets_file, markdown_file = sys.argv[1:3]
    defined = [line.split()[0] for line in open(targets_file) if line.strip()]
    rows = table_rows(open(markdown_file, encoding="utf-8").read())
    undocumented = [t for t in defined if not any(pattern.match(t) for pattern, _, _ in rows)]
    missing = [name for pattern, optional, name in rows
               if not optional and not any(pattern.match(t) for t in defined)]
    for t in undocumented:
        print(f"target {t} is defined in CMake but not in docs/architecture.md's targets table: add a row")
    for name in missing:
        print(f"docs/architecture.md's targets table names {name}, which CMake does not define: "
              "remove the row, fix the name, or mark it (optional)")
    if undocumented or missing:
        return 1
    print(f"{len(defined)} targets, {len(rows)} rows: every target documented, every row a target")
    return 0


if __name__ == "__main__":
    sys.exit(main())
