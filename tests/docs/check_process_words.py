#!/usr/bin/env python3
"""The repository speaks of the product, not of how it was built.

Fails, listing file:line, where a tracked text file (docs, code, comments, tests, scripts)
says when something was done instead of what the software does: a numbered stop or issue,
or a session, round or stop named by "this", "a later", "an earlier", "the previous" and
the like (PROCESS_WORDS below). History belongs in CHANGELOG.md, which is not checked.

A citation of another project's tracker is not development history and passes: an issue
number after a project's name, or a link to its tracker (CITATION below).

Usage: check_process_words.py [REPOSITORY]   (default: this file's repository)
"""
import pathlib
import re
import subprocess
import sys

PROCESS_WORDS = re.compile(
    r"\b(?:stops? #?\d+"
    r"|issues? #?\d+"
    r"|this (?:session|round|stop)"
    r"|(?:a|an|the) (?:later|earlier|previous|next|last) (?:session|round|stop)s?"
    r"|(?:earlier|later|previous) (?:rounds?|stops?|sessions?))\b",
    re.IGNORECASE)
# "<Project> issue #N" or a tracker link: a citation, not history.
CITATION = re.compile(r"(?:\b[A-Z][A-Za-z0-9+.-]*(?:'s)? issues? #?\d+|/issues/\d+)")
NOT_CHECKED = {"CHANGELOG.md", "tests/docs/check_process_words.py"}  # history; the patterns
TEXT_SUFFIXES = {".md", ".txt", ".cpp", ".h", ".hpp", ".cc", ".c", ".py", ".sh", ".cmake", ".in",
                 ".json", ".yaml", ".yml", ".toml", ".smk", ".session", ".html", ".css", ".cfg"}
TEXT_NAMES = {"CMakeLists.txt", "Snakefile", "run", "README", "NOTICE", "LICENSE"}


def repository_files(repo):
    """git's tracked and untracked-but-not-ignored files; every file but the usual outputs outside git."""
    try:
        listed = subprocess.run(["git", "-C", str(repo), "ls-files", "-z", "--cached", "--others",
                                 "--exclude-standard"], capture_output=True, check=True).stdout
        return sorted(filter(None, listed.decode().split("\0")))
    except (OSError, subprocess.CalledProcessError):
        skip = {".git", "build", "demo_output", ".snakemake", "__pycache__"}
        return sorted(str(p.relative_to(repo)) for p in repo.rglob("*")
                      if p.is_file() and not skip & set(p.relative_to(repo).parts))


def tracked_text_files(repo):
    for name in repository_files(repo):
        path = repo / name
        if name in NOT_CHECKED or not path.is_file():
            continue
        if path.suffix in TEXT_SUFFIXES or path.name in TEXT_NAMES:
            yield name, path


def findings(repo):
    for name, path in tracked_text_files(repo):
        try:
            lines = path.read_text(encoding="utf-8").splitlines()
        except UnicodeDecodeError:
            continue
        for number, line in enumerate(lines, 1):
            cited = {m.span() for m in CITATION.finditer(line)}
            for match in PROCESS_WORDS.finditer(line):
                if any(start <= match.start() < end for start, end in cited):
                    continue
                yield f"{name}:{number}: '{match.group(0)}': {line.strip()[:160]}"


def main():
    repo = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parents[2])
    found = list(findings(repo.resolve()))
    for line in found:
        print(line)
    if found:
        print(f"{len(found)} development-process words: write what the software does and why; "
              "history goes to CHANGELOG.md", file=sys.stderr)
        return 1
    print("no development-process words")
    return 0


if __name__ == "__main__":
    sys.exit(main())
