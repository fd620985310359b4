#!/usr/bin/env python3
"""Fails when a C++ file of the repository is not formatted as .clang-format says.

    python3 tests/docs/check_formatting.py [REPO] [--fix]

Checks every tracked .h, .hpp and .cpp file (git ls-files) with Debian's clang-format-14
(or clang-format); --fix formats them in place instead.
"""
import pathlib
import shutil
import subprocess
import sys

SUFFIXES = {".h", ".hpp", ".cpp"}


def formatter():
    for name in ("clang-format-14", "clang-format"):
        path = shutil.which(name)
        if path:
            return path
    raise SystemExit("clang-format-14 is not installed: `apt-get install clang-format-14` (tools/scripts/setup.sh installs it)")


def cpp_files(repo):
    listed = subprocess.run(["git", "ls-files", "-z"], cwd=repo, capture_output=True, check=True).stdout
    names = [name for name in listed.decode().split("\0") if pathlib.Path(name).suffix in SUFFIXES]
    return [name for name in names if (repo / name).is_file()]


def main():
    arguments = [a for a in sys.argv[1:] if a != "--fix"]
    repo = pathlib.Path(arguments[0] if arguments else pathlib.Path(__file__).resolve().parents[2]).resolve()
    files = cpp_files(repo)
    if "--fix" in sys.argv:
        subprocess.run([formatter(), "-i", "--style=file", *files], cwd=repo, check=True)
        print(f"formatted {len(files)} files")
        return 0
    result = subprocess.run([formatter(), "--dry-run", "--Werror", "--style=file", *files], cwd=repo,
                            capture_output=True, text=True)
    unformatted = sorted({line.split(":", 1)[0] for line in result.stderr.splitlines() if ": error:" in line})
    if result.returncode != 0:
        for name in unformatted:
            print(f"{name}: not formatted")
        print(f"{len(unformatted)} of {len(files)} C++ files are not formatted as .clang-format says: "
              f"run `python3 tests/docs/check_formatting.py --fix`")
        if not unformatted:
            print(result.stderr[-2000:])
        return 1
    print(f"all {len(files)} C++ files formatted")
    return 0


if __name__ == "__main__":
    sys.exit(main())
