#!/usr/bin/env python3
"""Runs the shell commands of README.md and docs/**/*.md as they are written.

Every fenced shell block (```sh, ```bash, ```shell, ```console) in those files carries a
marker, an HTML comment on the line just above its opening fence:

  <!-- run -->                  run the block, as written, with bash (set -e, pipefail) from
                                the root of a scratch copy of the repository; exit 0 expected
  <!-- run: after-demo -->       the same, once demo_output/liver.organ exists (the block says
                                "after bash tools/scripts/demo.sh"): baked first by the very command
                                tools/scripts/demo.sh bakes it with
  <!-- run: interrupt=S -->      a command that runs until Ctrl-C: SIGINT to the block's
                                process group after S seconds; exit 0 expected
  <!-- run: timeout=S -->        the block's limit (default 300 s)
  <!-- run: synopsis -->         a synopsis (placeholders, [options]), not a command line: each
                                line's `PROGRAM COMMAND --help` runs and must list every
                                --option the line names
  <!-- run: skip REASON -->      not run; REASON is printed (a haptic device, a cluster, root,
                                a benchmark's minutes on an idle machine, ...)

Options combine with commas (`<!-- run: after-demo, interrupt=3 -->`); a command that needs
a display says `xvfb-run -a` itself. A shell block without a marker is a failure: every
documented command is either run or skipped for a stated reason.

Each document's blocks run in document order in their own scratch copy of the repository
(git's tracked and untracked-but-not-ignored files; the build folder linked in as build/,
so that `build/tools/organsim` is the build's program). Nothing is written into the
checkout. A failing block is reported with its document, line and command.

  python3 tests/docs/run_documented_commands.py [--build DIR] [--keep] [--list] [DOC ...]
"""
from __future__ import annotations

import argparse
import dataclasses
import os
import pathlib
import re
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import time

REPO = pathlib.Path(__file__).resolve().parents[2]
SHELL_LANGUAGES = {"sh", "bash", "shell", "console"}
MARKER = re.compile(r"^\s*<!--\s*run(?::\s*(?P<options>.*?))?\s*-->\s*$")
FENCE = re.compile(r"^(?P<indent>\s*)(?P<fence>`{3,}|~{3,})\s*(?P<info>[^`\s]*)")
DEFAULT_TIMEOUT = 300.0
# What tools/scripts/demo.sh bakes demo_output/liver.organ with (found in it, so that the two never differ).
DEMO_MODEL = '"$out/liver.organ"'


class DocsError(Exception):
    pass


@dataclasses.dataclass
class Block:
    document: str  # relative to the repository, e.g. "README.md"
    line: int  # the opening fence's line, 1-based
    language: str
    text: str  # the block's lines, as written
    marker: str | None  # the marker comment's options ("" for a plain <!-- run -->), None without one
    marker_line: int = 0

    @property
    def where(self):
        return f"{self.document}:{self.line}"

    def options(self):
        """{'skip': reason, 'after-demo': True, 'interrupt': 3.0, 'timeout': 300.0, 'synopsis': True}"""
        text = (self.marker or "").strip()
        if text.startswith("skip"):
            reason = text[4:].strip(" :—-")
            if not reason:
                raise DocsError(f"{self.document}:{self.marker_line}: `<!-- run: skip REASON -->` needs its reason")
            return {"skip": reason}
        options = {"timeout": DEFAULT_TIMEOUT}
        for word in filter(None, (w.strip() for w in text.split(","))):
            key, _, value = word.partition("=")
            if key in ("after-demo", "synopsis") and not value:
                options[key] = True
            elif key in ("interrupt", "timeout") and value:
                options[key] = float(value)
            else:
                raise DocsError(f"{self.document}:{self.marker_line}: unknown run marker option '{word}' "
                                "(after-demo, synopsis, interrupt=S, timeout=S, or skip REASON)")
        return options


def documents(repo=REPO):
    """README.md, then docs/**/*.md in path order."""
    found = [repo / "README.md"] + sorted((repo / "docs").rglob("*.md"))
    return [p for p in found if p.is_file()]


def shell_blocks(path, repo=REPO):
    """The fenced shell blocks of one Markdown file, in order, with their markers."""
    lines = pathlib.Path(path).read_text(encoding="utf-8").splitlines()
    name = str(pathlib.Path(path).resolve().relative_to(repo.resolve()))
    blocks = []
    i = 0
    while i < len(lines):
        opening = FENCE.match(lines[i])
        if not opening:
            i += 1
            continue
        fence, language = opening["fence"], opening["info"].lower()
        end = i + 1
        while end < len(lines) and not lines[end].strip().startswith(fence):
            end += 1
        if language in SHELL_LANGUAGES:
            marker = MARKER.match(lines[i - 1]) if i > 0 else None
            indent = len(opening["indent"])
            body = [l[indent:] if l[:indent].strip() == "" else l for l in lines[i + 1:end]]
            blocks.append(Block(name, i + 1, language, "\n".join(body) + "\n",
                                (marker["options"] or "") if marker else None, i if marker else 0))
        i = end + 1
    return blocks


def scratch_copy(repo, build, into):
    """A copy of the repository's files (no .git, no build outputs) with build/ linked to the build."""
    root = pathlib.Path(into) / "repo"
    try:
        listed = subprocess.run(["git", "-C", str(repo), "ls-files", "-z", "--cached", "--others",
                                 "--exclude-standard"], capture_output=True, check=True).stdout
        files = sorted({f for f in listed.decode().split("\0") if f})
    except (OSError, subprocess.CalledProcessError):  # not a git checkout: everything but the usual outputs
        skip = {".git", "build", "demo_output", ".snakemake", "__pycache__"}
        files = [str(p.relative_to(repo)) for p in repo.rglob("*")
                 if (p.is_file() or p.is_symlink()) and not skip & set(p.relative_to(repo).parts)]
    for name in files:
        source = repo / name
        if not (source.is_file() or source.is_symlink()):
            continue  # listed but deleted in the working tree
        target = root / name
        target.parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(source, target, follow_symlinks=False)
    if (root / "build").exists() or (root / "build").is_symlink():
        raise DocsError(f"{repo}: build is a tracked path")
    (root / "build").symlink_to(pathlib.Path(build).resolve(), target_is_directory=True)
    return root


def demo_bake_command(repo):
    """tools/scripts/demo.sh's command that bakes $out/liver.organ, as bash that runs from the repository root."""
    text = (repo / "tools" / "scripts" / "demo.sh").read_text()
    for command in re.sub(r"\\\n", " ", text).splitlines():
        if " bake " in command and f"-o {DEMO_MODEL}" in command:
            return ('repo=$PWD; build=$PWD/build; out=$PWD/demo_output; sample=$repo/data_samples/real_ct_totalseg\n'
                    'mkdir -p "$out"\n' + command.strip() + "\n")
    raise DocsError(f"tools/scripts/demo.sh: no command bakes {DEMO_MODEL}")


@dataclasses.dataclass
class Result:
    block: Block
    status: str  # "ran", "skipped", "failed"
    seconds: float = 0.0
    message: str = ""


def tail(text, lines=40):
    kept = text.rstrip().splitlines()[-lines:]
    return "\n".join("    " + l for l in kept)


def run_script(script, cwd, timeout, interrupt=None):
    """bash SCRIPT (set -eE, pipefail), with an ERR trap naming the failing line and command.
    Returns (exit code, output, failing line in the script or None, failing command)."""
    scratch = pathlib.Path(tempfile.mkdtemp(prefix="docs-block-"))
    try:
        (scratch / "block.sh").write_text(script)
        failure = scratch / "failure"
        wrapper = ("set -eE -o pipefail\n"
                   "trap 'printf \"%s\\n%s\\n\" \"$LINENO\" \"$BASH_COMMAND\" > \"$ORGANSIM_DOCS_FAILURE\"' ERR\n"
                   f". {shlex.quote(str(scratch / 'block.sh'))}\n")
        env = dict(os.environ, ORGANSIM_DOCS_FAILURE=str(failure))
        with open(scratch / "output", "w") as log:
            process = subprocess.Popen(["bash", "-c", wrapper], cwd=cwd, env=env, stdin=subprocess.DEVNULL,
                                       stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        note = ""
        try:
            if interrupt is not None:
                try:
                    process.wait(timeout=interrupt)
                    note = f"\n(it ended by itself within {interrupt:g} s, before Ctrl-C)"
                except subprocess.TimeoutExpired:
                    os.killpg(process.pid, signal.SIGINT)  # Ctrl-C: the terminal signals the whole group
            process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()
            note = f"\n(killed after {timeout:g} s)"
        try:
            os.killpg(process.pid, signal.SIGKILL)  # whatever the block left running in the background
        except ProcessLookupError:
            pass
        output = (scratch / "output").read_text(errors="replace") + note
        if note.startswith("\n(killed"):
            return None, output, None, ""
        line, command = None, ""
        if process.returncode and failure.exists():
            recorded = failure.read_text().split("\n", 1)
            line, command = int(recorded[0]), recorded[1].strip() if len(recorded) > 1 else ""
        return process.returncode, output, line, command
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def check_synopsis(block, cwd, timeout):
    """Each line: PROGRAM COMMAND --help runs, and lists every --option the line names."""
    problems = []
    lines = re.sub(r"\\\n", " ", block.text).splitlines()
    for offset, line in enumerate(lines, start=1):
        command = re.split(r"\s#\s", line, maxsplit=1)[0].strip()
        if not command:
            continue
        words = command.split()
        if len(words) < 2:
            problems.append(f"{block.document}:{block.line + offset}: not PROGRAM COMMAND …: {command}")
            continue
        try:
            done = subprocess.run([words[0], words[1], "--help"], cwd=cwd, capture_output=True, text=True,
                                  timeout=timeout, stdin=subprocess.DEVNULL)
        except (OSError, subprocess.TimeoutExpired) as e:
            problems.append(f"{block.document}:{block.line + offset}: {words[0]} {words[1]} --help: {e}")
            continue
        if done.returncode != 0:
            problems.append(f"{block.document}:{block.line + offset}: `{words[0]} {words[1]} --help` exited "
                            f"{done.returncode}:\n{tail(done.stdout + done.stderr)}")
            continue
        helptext = done.stdout + done.stderr
        for option in sorted(set(re.findall(r"(?<![\w-])--[A-Za-z][\w-]*", command))):
            if not re.search(rf"(?<![\w-]){re.escape(option)}(?![\w-])", helptext):
                problems.append(f"{block.document}:{block.line + offset}: `{words[0]} {words[1]}` has no option "
                                f"{option}: {command}")
    return problems


class DocumentRun:
    """One document's blocks, in order, in one scratch copy of the repository."""

    def __init__(self, document, build, workdir, repo=REPO, log=print):
        self.document, self.build, self.repo, self.log = document, build, repo, log
        self.blocks = shell_blocks(repo / document, repo)
        self.root = None
        self.workdir = pathlib.Path(workdir)
        self.demo_ready = False

    def unmarked(self):
        return [b for b in self.blocks if b.marker is None]

    def prepare(self):
        if self.root is None:
            self.root = scratch_copy(self.repo, self.build, self.workdir)
        return self.root

    def run(self, block):
        options = block.options()
        command_text = block.text.rstrip()
        if "skip" in options:
            return Result(block, "skipped", message=options["skip"])
        root = self.prepare()
        start = time.monotonic()
        if options.get("after-demo") and not self.demo_ready:
            code, output, _, _ = run_script(demo_bake_command(self.repo), root, DEFAULT_TIMEOUT)
            if code != 0:
                return Result(block, "failed", time.monotonic() - start,
                              f"{block.where}: preparing demo_output/liver.organ as tools/scripts/demo.sh does "
                              f"failed (exit {code}):\n{tail(output)}")
            self.demo_ready = True
        if options.get("synopsis"):
            problems = check_synopsis(block, root, options["timeout"])
            return Result(block, "failed" if problems else "ran", time.monotonic() - start, "\n".join(problems))
        code, output, line, command = run_script(block.text, root, options["timeout"], options.get("interrupt"))
        seconds = time.monotonic() - start
        if code == 0:
            return Result(block, "ran", seconds, output)
        if line is not None and 1 <= line <= block.text.count("\n"):
            where = f"{block.document}:{block.line + line}"
            written = block.text.splitlines()[line - 1].strip()
        else:
            where, written = block.where, command_text
        reason = ("timed out" if code is None else f"killed by signal {-code}" if code < 0 else f"exit {code}")
        return Result(block, "failed", seconds,
                      f"{where}: {reason}: {written}\n  (bash ran: {command or '?'})\n{tail(output)}")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--build", default=os.environ.get("ORGANSIM_BUILD_DIR", str(REPO / "build")),
                        help="the build folder (default: $ORGANSIM_BUILD_DIR, else build/)")
    parser.add_argument("--keep", action="store_true", help="keep the scratch copies (their paths are printed)")
    parser.add_argument("--list", action="store_true", help="list the blocks and their markers, run nothing")
    parser.add_argument("documents", nargs="*", help="README.md, docs/cli.md, ... (default: all)")
    a = parser.parse_args()
    names = a.documents or [str(p.relative_to(REPO)) for p in documents()]
    failures, total = 0, time.monotonic()
    for name in names:
        workdir = tempfile.mkdtemp(prefix="organsim-docs-")
        try:
            run = DocumentRun(name, a.build, workdir)
            for block in run.unmarked():
                print(f"FAIL {block.where}: a ```{block.language} block without a marker: add <!-- run --> "
                      "(or <!-- run: skip REASON -->) on the line above it", flush=True)
                failures += 1
            for block in run.blocks:
                if block.marker is None:
                    continue
                if a.list:
                    print(f"{block.where}: <!-- run{': ' + block.marker if block.marker else ''} -->")
                    continue
                result = run.run(block)
                if result.status == "skipped":
                    print(f"skip {block.where}: {result.message}", flush=True)
                elif result.status == "ran":
                    print(f"ok   {block.where} ({result.seconds:.1f} s)", flush=True)
                else:
                    failures += 1
                    print(f"FAIL {result.message}", flush=True)
        finally:
            if a.keep and not a.list:
                print(f"     {name}: scratch copy kept in {workdir}")
            else:
                shutil.rmtree(workdir, ignore_errors=True)
    print(f"{failures} failure(s), {time.monotonic() - total:.0f} s")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
