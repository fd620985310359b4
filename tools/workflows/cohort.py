#!/usr/bin/env python3
"""Cohort baking, the parts bake_cohort.smk runs (docs/cohort.md).

  cohort.py bake --organsim PROGRAM --out DIR --case ID --ct CT [--label L] [--seed=X,Y,Z]
                 [--fixed-point=X,Y,Z] [--threads N] [--bake-args="…"]
      bakes one case into DIR/ID.organ and writes DIR/ID.json: the bake report with
      "case", "status": "ok" and "wall_seconds", or, when the bake fails,
      {"case", "status": "failed", "error", "exit_code", "wall_seconds"} and no model.
      Exits 0 either way, so that one broken case never stops the cohort.
  cohort.py report --cases CASES.csv --out DIR
      writes DIR/cohort_report.csv and DIR/cohort_report.html, one row per case.

Every file is written whole or not at all (a temporary file, then a rename).
"""
import argparse
import csv
import html
import json
import os
import pathlib
import re
import shlex
import subprocess
import sys
import tempfile
import time

COLUMNS = ["case", "ct", "label", "seed", "fixed_point"]
CASE_ID = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._-]*$")


def case_options(label, seed, fixed_point):
    """A row's segmentation and clamp as options that both organsim bake and
    cohort.py bake take (--seed=… so that a negative coordinate is not an option)."""
    words = ["--label", label] if label else []
    if seed:
        words.append("--seed=" + seed)
    if fixed_point:
        words.append("--fixed-point=" + fixed_point)
    return words


class Case:
    """One row of the cases table; paths resolved against the table's folder."""

    def __init__(self, row, folder, line):
        self.case = row["case"].strip()
        self.line = line
        resolve = lambda p: str((folder / p.strip()).resolve()) if p.strip() else ""
        self.ct = resolve(row["ct"])
        self.label = resolve(row["label"])
        self.seed = row["seed"].strip()
        self.fixed_point = row["fixed_point"].strip()

    def inputs(self):
        """The input files that exist (a missing one is the case's failure, not the workflow's)."""
        return [p for p in (self.ct, self.label) if p and os.path.exists(p)]

    def arguments(self):
        """The row as cohort.py bake arguments, shell-quoted."""
        words = ["--ct", self.ct, *case_options(self.label, self.seed, self.fixed_point)]
        return " ".join(shlex.quote(w) for w in words)


def read_cases(path):
    """{case id: Case} in the table's order. Raises ValueError naming the file and
    line for a table the workflow cannot use (its header, a case id, a repeated id)."""
    path = pathlib.Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except OSError as e:
        raise ValueError(f"cases table {path}: {e.strerror}; pass --config cases=FILE.csv") from None
    reader = csv.DictReader(text.splitlines())
    if reader.fieldnames is None or [f.strip() for f in reader.fieldnames] != COLUMNS:
        raise ValueError(f"{path}:1: the header must be exactly {','.join(COLUMNS)} (found {reader.fieldnames})")
    cases = {}
    for line, row in enumerate(reader, start=2):
        if None in row or any(row[c] is None for c in COLUMNS):
            raise ValueError(f"{path}:{line}: expected {len(COLUMNS)} fields; quote values that hold commas "
                             f'("X,Y,Z")')
        case = Case(row, path.parent, line)
        if not CASE_ID.match(case.case):
            raise ValueError(f"{path}:{line}: case id '{case.case}' must be letters, digits, '.', '_' or '-' "
                             "(it names the output files)")
        if case.case in cases:
            raise ValueError(f"{path}:{line}: case '{case.case}' appears twice (first on line "
                             f"{cases[case.case].line})")
        cases[case.case] = case
    if not cases:
        raise ValueError(f"{path}: no cases below the header")
    return cases


def default_program(workflow_dir):
    """The organsim of this checkout's build, else the one on PATH."""
    built = pathlib.Path(workflow_dir).resolve().parents[1] / "build" / "tools" / "organsim"
    return str(built) if built.exists() else "organsim"


def write_atomically(path, text):
    path = pathlib.Path(path)
    fd, temporary = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.tmp-")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as out:
            out.write(text)
            out.flush()
            os.fsync(out.fileno())
        os.replace(temporary, path)
    except BaseException:
        os.unlink(temporary)
        raise


def bake(a):
    out = pathlib.Path(a.out)
    out.mkdir(parents=True, exist_ok=True)
    model = out / f"{a.case}.organ"
    command = [a.organsim, "bake", a.ct, "-o", str(model), "--json", "--threads", str(a.threads),
               *case_options(a.label, a.seed, a.fixed_point), *shlex.split(a.bake_args)]
    print("$", " ".join(shlex.quote(c) for c in command), flush=True)
    start = time.monotonic()
    try:
        done = subprocess.run(command, capture_output=True, text=True)
        code, stdout, stderr = done.returncode, done.stdout, done.stderr
    except OSError as e:
        code, stdout, stderr = 127, "", f"organsim bake: error: cannot run {a.organsim}: {e.strerror}\n"
    wall = time.monotonic() - start
    sys.stderr.write(stderr)
    if code == 0:
        result = json.loads(stdout)
        result.update(case=a.case, status="ok", wall_seconds=wall)
    else:
        errors = [l for l in stderr.splitlines() if "error:" in l]
        error = errors[-1].split("error:", 1)[1].strip() if errors else (stderr.strip().splitlines() or ["?"])[-1]
        result = dict(case=a.case, status="failed", error=error, exit_code=code, wall_seconds=wall)
        if model.exists():  # organsim writes whole models only; never leave one beside a failure
            model.unlink()
    write_atomically(out / f"{a.case}.json", json.dumps(result, indent=1) + "\n")
    print(f"{a.case}: {result['status']}" + (f": {result['error']}" if code else ""), flush=True)


REPORT_COLUMNS = [
    ("case", "case"), ("status", "status"), ("ct", "CT"), ("segmentation", "segmentation"),
    ("volume_ml", "organ volume (mL)"), ("surface_vertices", "surface vertices"),
    ("surface_volume_ml", "surface volume (mL)"), ("tetrahedra", "tetrahedra"),
    ("tetrahedra_volume_ml", "tetrahedra volume (mL)"), ("min_dihedral_deg", "min dihedral (°)"),
    ("max_radius_edge_ratio", "max radius-edge ratio"), ("fixed_point_mm", "fixed point (mm, LPS)"),
    ("fixed_point_source", "fixed point from"), ("model_bytes", "model size (bytes)"),
    ("segment_s", "segment (s)"), ("tetrahedra_s", "tetrahedra (s)"), ("beam_tables_s", "beam tables (s)"),
    ("bake_s", "bake (s)"), ("wall_s", "wall (s)"), ("error", "error"),
]


def report_row(case, result):
    row = dict(case=case.case, ct=case.ct)
    if result is None:
        return dict(row, status="missing", error="no result: the bake job did not finish (see the workflow's log)")
    row.update(status=result["status"], wall_s=round(result["wall_seconds"], 2))
    if result["status"] != "ok":
        return dict(row, error=result.get("error", ""))
    seg, surface, tets = result["segmentation"], result["surface"], result["tetrahedra"]
    stages = result["seconds"]["stages"]
    return dict(
        row,
        segmentation=seg["method"], volume_ml=round(seg["volume_ml"], 1),
        surface_vertices=surface["vertices"], surface_volume_ml=round(surface["volume_ml"], 1),
        tetrahedra=tets["count"], tetrahedra_volume_ml=round(tets["volume_ml"], 1),
        min_dihedral_deg=round(tets["min_dihedral_deg"], 2),
        max_radius_edge_ratio=round(tets["max_radius_edge_ratio"], 2),
        fixed_point_mm=",".join(f"{x:.1f}" for x in result["fixed_point"]["position_mm"]),
        fixed_point_source=result["fixed_point"]["source"], model_bytes=result["model_bytes"],
        segment_s=round(stages.get("segment", 0.0), 2), tetrahedra_s=round(stages.get("tetrahedra", 0.0), 2),
        beam_tables_s=round(stages.get("beam tables", 0.0), 2), bake_s=round(result["seconds"]["total"], 2))


def report(a):
    cases = read_cases(a.cases)
    out = pathlib.Path(a.out)
    rows = []
    for case in cases.values():
        path = out / f"{case.case}.json"
        rows.append(report_row(case, json.loads(path.read_text()) if path.exists() else None))
    keys = [k for k, _ in REPORT_COLUMNS]
    lines = [",".join(keys)]
    for row in rows:
        cells = []
        for k in keys:
            value = str(row.get(k, ""))
            cells.append('"' + value.replace('"', '""') + '"' if any(c in value for c in ',"\n') else value)
        lines.append(",".join(cells))
    write_atomically(out / "cohort_report.csv", "\n".join(lines) + "\n")

    baked = sum(r["status"] == "ok" for r in rows)
    head = "".join(f"<th>{html.escape(title)}</th>" for _, title in REPORT_COLUMNS)
    body = "".join(
        f'<tr class="{html.escape(r["status"])}">' +
        "".join(f"<td>{html.escape(str(r.get(k, '')))}</td>" for k, _ in REPORT_COLUMNS) + "</tr>\n"
        for r in rows)
    page = f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>organsim cohort report</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; }}
table {{ border-collapse: collapse; font-size: 0.9em; }}
th, td {{ border: 1px solid #bbb; padding: 0.25em 0.5em; text-align: left; }}
th {{ background: #eee; }}
tr.failed td, tr.missing td {{ background: #fde2e2; }}
</style></head><body>
<h1>organsim cohort report</h1>
<p>{len(rows)} case(s) from {html.escape(str(pathlib.Path(a.cases).resolve()))}: {baked} baked,
{len(rows) - baked} failed. Models and bake reports: <code>CASE.organ</code>, <code>CASE.json</code>
in {html.escape(str(out.resolve()))}.</p>
<table>
<tr>{head}</tr>
{body}</table>
</body></html>
"""
    write_atomically(out / "cohort_report.html", page)
    print(f"cohort: {len(rows)} case(s), {baked} baked, {len(rows) - baked} failed; "
          f"{out / 'cohort_report.csv'}, {out / 'cohort_report.html'}")


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    commands = parser.add_subparsers(dest="command", required=True)
    b = commands.add_parser("bake")
    b.add_argument("--organsim", default="organsim")
    b.add_argument("--out", required=True)
    b.add_argument("--case", required=True)
    b.add_argument("--ct", required=True)
    b.add_argument("--label", default="")
    b.add_argument("--seed", default="")
    b.add_argument("--fixed-point", default="")
    b.add_argument("--threads", type=int, default=1)
    b.add_argument("--bake-args", default="", help="further organsim bake options, as one string")
    r = commands.add_parser("report")
    r.add_argument("--cases", required=True)
    r.add_argument("--out", required=True)
    a = parser.parse_args()
    try:
        bake(a) if a.command == "bake" else report(a)
    except ValueError as e:
        sys.exit(f"cohort: error: {e}")


if __name__ == "__main__":
    main()
