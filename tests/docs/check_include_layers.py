#!/usr/bin/env python3
"""The layering docs/architecture.md states, checked on the sources.

Usage: check_include_layers.py REPOSITORY

Reads every C++ source and header under runtime/, pipeline/ and tools/ and fails,
naming what it found, when:
  - an include prefix (organsim/<prefix>/) is written by more than one library
    folder: a prefix names one library;
  - the libraries include each other in a cycle (A includes B's headers and B,
    through any chain, includes A's): each library is a floor, and includes go
    down only;
  - two source units include each other (a.cpp includes b.h and b.cpp includes
    a.h; a unit is a header and its source of the same name in one folder).

A library folder is runtime/<name>/, pipeline/<name>/, tools/<name>/ or
tools/commands/<name>/. An include is resolved as the compiler does for these
targets: beside the including file, then under each library's include/ (the
organsim/ prefixes), then under tools/ and the command folders (their headers
are included as "<folder>/<file>.h" or, within a folder, by name).
"""
import pathlib
import re
import sys

SOURCE_SUFFIXES = {".h", ".cpp"}
INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.MULTILINE)


def library_of(path):
    """The library folder of a path relative to the repository, or None."""
    parts = path.parts
    if parts[0] in ("runtime", "pipeline") and len(parts) > 2:
        return "/".join(parts[:2])
    if parts[0] == "tools" and len(parts) > 2:
        if parts[1] == "commands" and len(parts) > 3:
            return "/".join(parts[:3])
        return "/".join(parts[:2])
    return None


def sources(repo):
    for top in ("runtime", "pipeline", "tools"):
        for path in sorted((repo / top).rglob("*")):
            if path.suffix in SOURCE_SUFFIXES and path.is_file():
                yield path.relative_to(repo)


def find_cycle(graph):
    """One cycle of `graph` (node -> set of nodes) as a list of nodes, or None."""
    state = {}
    stack = []

    def visit(node):
        state[node] = "open"
        stack.append(node)
        for successor in sorted(graph.get(node, ())):
            if state.get(successor) == "open":
                return stack[stack.index(successor):] + [successor]
            if successor not in state:
                cycle = visit(successor)
                if cycle:
                    return cycle
        stack.pop()
        state[node] = "done"
        return None

    for node in sorted(graph):
        if node not in state:
            cycle = visit(node)
            if cycle:
                return cycle
    return None


def main():
    repo = pathlib.Path(sys.argv[1]).resolve()
    files = list(sources(repo))
    problems = []

    # Which library folders provide each include prefix.
    prefixes = {}
    for path in files:
        parts = path.parts
        if "include" in parts:
            index = parts.index("include")
            if len(parts) > index + 2 and parts[index + 1] == "organsim":
                prefixes.setdefault(parts[index + 2], set()).add(library_of(path))
    for prefix, libraries in sorted(prefixes.items()):
        if len(libraries) > 1:
            problems.append(f"include prefix organsim/{prefix}/ is written by {len(libraries)} libraries "
                            f"({', '.join(sorted(libraries))}): give each library a prefix of its own")

    roots = sorted({path.parents[len(path.parts) - path.parts.index("include") - 2]
                    for path in files if "include" in path.parts})
    roots += [pathlib.Path("tools"), pathlib.Path("tools/commands/simulation"), pathlib.Path("tools/commands/baking")]
    existing = set(files)

    def resolve(including, name):
        for candidate in [including.parent / name] + [root / name for root in roots]:
            candidate = pathlib.Path(*candidate.parts)
            if candidate in existing:
                return candidate
        return None

    library_graph = {}
    unit_graph = {}
    for path in files:
        text = (repo / path).read_text(encoding="utf-8", errors="replace")
        library = library_of(path)
        unit = path.with_suffix("")
        for name in INCLUDE.findall(text):
            target = resolve(path, name)
            if target is None:
                continue
            target_library = library_of(target)
            if library and target_library and target_library != library:
                library_graph.setdefault(library, set()).add(target_library)
            target_unit = target.with_suffix("")
            if target_unit != unit:
                unit_graph.setdefault(unit, set()).add(target_unit)

    cycle = find_cycle(library_graph)
    if cycle:
        problems.append("libraries include each other in a cycle: " + " -> ".join(cycle))
    for unit, targets in sorted(unit_graph.items()):
        for target in sorted(targets):
            if unit < target and unit in unit_graph.get(target, ()):
                problems.append(f"{unit} and {target} include each other: move what both need into one of them "
                                "or into a third")

    for problem in problems:
        print(problem)
    if problems:
        return 1
    print(f"{len(files)} files in {len(library_graph)} libraries that include others, {len(prefixes)} include "
          "prefixes: one library per prefix, includes go down only, no two units include each other")
    return 0


if __name__ == "__main__":
    sys.exit(main())
