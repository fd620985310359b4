#!/usr/bin/env python3
"""Fails when a relative link in README.md or docs/*.md points nowhere.

Checks every Markdown link and image whose target is not a web address: the file
must exist in the repository, and a `#fragment` must name a heading of that file
(GitHub's anchor rule: lower case, punctuation dropped, spaces to hyphens, repeats
numbered -1, -2, …) or an explicit `<a id="…">`.

    python3 tests/docs/check_links.py [REPO]
"""
import pathlib
import re
import sys
import urllib.parse

LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")
EXPLICIT_ANCHOR = re.compile(r"<a\s+(?:id|name)=\"([^\"]+)\"")
FENCE = re.compile(r"^\s*(```|~~~)")


def github_anchor(heading):
    text = re.sub(r"<[^>]+>", "", heading)                 # inline HTML
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", text)   # links keep their text
    text = text.replace("`", "").strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)                   # punctuation, Unicode letters kept
    return text.replace(" ", "-")


def outside_fences(lines):
    fenced = False
    for number, line in enumerate(lines, 1):
        if FENCE.match(line):
            fenced = not fenced
            continue
        if not fenced:
            yield number, line


def anchors_of(path, cache={}):
    if path not in cache:
        seen, anchors = {}, set()
        lines = path.read_text(encoding="utf-8").splitlines()
        for _, line in outside_fences(lines):
            anchors.update(EXPLICIT_ANCHOR.findall(line))
            match = HEADING.match(line)
            if match:
                base = github_anchor(match.group(2))
                count = seen.get(base, 0)
                seen[base] = count + 1
                anchors.add(base if count == 0 else f"{base}-{count}")
        cache[path] = anchors
    return cache[path]


def broken_links(repo):
    documents = [repo / "README.md", *sorted((repo / "docs").glob("*.md"))]
    for document in documents:
        lines = document.read_text(encoding="utf-8").splitlines()
        for number, line in outside_fences(lines):
            for target in LINK.findall(re.sub(r"`[^`]*`", "", line)):
                if re.match(r"^[a-z][a-z0-9+.-]*:", target):   # http:, https:, mailto:
                    continue
                file_part, _, fragment = target.partition("#")
                linked = (document.parent / urllib.parse.unquote(file_part)).resolve() if file_part else document
                where = f"{document.relative_to(repo)}:{number}"
                if not linked.exists():
                    yield f"{where}: {target}: no such file"
                elif fragment and linked.suffix == ".md" and fragment not in anchors_of(linked):
                    yield f"{where}: {target}: {linked.name} has no heading or anchor '{fragment}'"


def main():
    repo = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else pathlib.Path(__file__).resolve().parents[2])
    problems = list(broken_links(repo.resolve()))
    for problem in problems:
        print(problem)
    if problems:
        print(f"{len(problems)} broken links: fix the target or the heading it names")
        return 1
    print("every relative link resolves")
    return 0


if __name__ == "__main__":
    sys.exit(main())
