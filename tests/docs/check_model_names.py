#!/usr/bin/env python3
"""A deformation model is named only by its own folder, the registry and the tests.

Every command, the Python module and the static presses reach a model through the
registry (runtime/realtime/include/organsim/realtime/model_registry.h): its entry says
what the model needs, how a static press solves it, whether it is matched to the
reference, and which settings it takes. Fails, listing file:line, where the source
of the runtime, the pipeline or the tools writes a registered model's name as a
string literal outside those places, since a command that picks a model by its
name treats a new model as something it is not.

The names are read from ORGANSIM_REGISTERED_MODELS in model_registry.cpp. Comments
are not checked. The words that name something else in a few files are listed in
ELSEWHERE with what they name there.

Usage: check_model_names.py [REPOSITORY]   (default: this file's repository)
"""
import pathlib
import re
import sys

REGISTRY = "runtime/realtime/src/model_registry.cpp"
OWNERS = ("runtime/realtime/src/models/", REGISTRY, "tests/")
CHECKED = ("runtime/", "pipeline/", "tools/")
SUFFIXES = {".cpp", ".h", ".py"}
# file (or folder) -> what the words mean there, not the registered models.
ELSEWHERE = {
    "runtime/fem/": "the FEM library's material laws (a fem problem file's \"model\")",
    "tools/commands/simulation/fem_problem_file.h": "the material laws of a fem problem file",
    "tools/experiments/": "the paper reproductions, which compare the models their papers compare",
    "tools/scripts/fem_mesh_sizes.py": "the FEM models whose mesh sizes it measures",
    "tools/commands/simulation/info_command.cpp": "the \"beam\" key: one vertex's beam table",
    "tools/commands/simulation/export_command.cpp": "the \"beam\" output: one vertex's beam table",
    "tools/commands/simulation/springs_command.cpp": "the springs command (the mass-spring paper's experiment)",
}
# A line that names the springs command, not the model.
COMMAND_NAME = re.compile(r'add_command\(app, table, "springs"')


def model_names(repo):
    text = (repo / REGISTRY).read_text(encoding="utf-8")
    listed = re.search(r"#define ORGANSIM_REGISTERED_MODELS\(X\)(.*)", text)
    if not listed:
        raise SystemExit(f"{REGISTRY}: no ORGANSIM_REGISTERED_MODELS list")
    return re.findall(r"X\((\w+)\)", listed.group(1))


def code_of(line, suffix):
    """The line without its comment (a whole-line comment, or one after the code)."""
    marker = "#" if suffix == ".py" else "//"
    stripped = line.strip()
    if stripped.startswith(marker) or stripped.startswith("*") or stripped.startswith("/*"):
        return ""
    return line.split(" " + marker, 1)[0]


def findings(repo):
    names = model_names(repo)
    literal = re.compile(r"""["'](%s)["']""" % "|".join(map(re.escape, names)))
    for path in sorted(repo.rglob("*")):
        name = path.relative_to(repo).as_posix()
        if path.suffix not in SUFFIXES or not name.startswith(CHECKED) or name.startswith(OWNERS):
            continue
        if "build/" in name or any(name.startswith(place) for place in ELSEWHERE):
            continue
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
            if COMMAND_NAME.search(line):
                continue
            for match in literal.finditer(code_of(line, path.suffix)):
                yield f"{name}:{number}: '{match.group(1)}': {line.strip()[:160]}"


def main():
    repo = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parents[2]).resolve()
    found = list(findings(repo))
    for line in found:
        print(line)
    if found:
        print(f"{len(found)} model names outside their folders, the registry and the tests: reach the model "
              "through its registry entry (model_registry.h)", file=sys.stderr)
        return 1
    print(f"the models ({', '.join(model_names(repo))}) are named only where they are defined and registered")
    return 0


if __name__ == "__main__":
    sys.exit(main())
