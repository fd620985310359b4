# Bakes a cohort of CTs into organsim models, in parallel and resumable, with a
# cohort report (docs/cohort.md).
#
#   snakemake -s tools/workflows/bake_cohort.smk --config cases=FILE.csv out=DIR --cores N
#
# FILE.csv has the header case,ct,label,seed,fixed_point: a case id, the CT (a
# NIfTI/NRRD/MHA file or a DICOM directory), a label map or empty, a seed X,Y,Z
# in mm or empty, a fixed point X,Y,Z in mm or empty; quote fields that hold
# commas. Relative paths are relative to FILE.csv's folder.
# Optional: organsim=PATH (default: this checkout's build, else organsim on PATH),
# threads=N per bake (default 2), bake_args="…" (further organsim bake options).
#
# Writes DIR/<case>.organ and DIR/<case>.json (the bake report) per case, and
# DIR/cohort_report.csv and DIR/cohort_report.html. A case that fails gets a
# report row with its one-line error and no model; the others go on. On a Slurm
# cluster, add --slurm (docs/cohort.md).
import os
import sys

sys.path.insert(0, workflow.basedir)
import cohort

if "cases" not in config or "out" not in config:
    raise ValueError("bake_cohort: pass --config cases=FILE.csv out=DIR")
CASES = cohort.read_cases(config["cases"])
OUT = config["out"].rstrip("/") or "."
ORGANSIM = config.get("organsim") or cohort.default_program(workflow.basedir)
THREADS = int(config.get("threads", 2))
BAKE_ARGS = str(config.get("bake_args", ""))
PYTHON = sys.executable
HELPER = os.path.join(workflow.basedir, "cohort.py")

wildcard_constraints:
    case="[A-Za-z0-9][A-Za-z0-9._-]*",

localrules: all, report

rule all:
    input:
        f"{OUT}/cohort_report.csv",
        f"{OUT}/cohort_report.html",

rule bake:
    input:
        lambda w: CASES[w.case].inputs(),
    output:
        f"{OUT}/{{case}}.json",
    params:
        # The row itself: a changed row bakes its case again.
        row=lambda w: CASES[w.case].arguments(),
    log:
        f"{OUT}/logs/{{case}}.log",
    threads: THREADS
    resources:
        mem_mb=6000,
        runtime=60,
    # --bake-args=VALUE, one word: Snakemake leaves an empty value unquoted (nothing at all),
    # and a value that is one option ("--fast") must not be read as an option itself.
    shell:
        "{PYTHON:q} {HELPER:q} bake --organsim {ORGANSIM:q} --out {OUT:q} --case {wildcards.case} {params.row}"
        " --threads {threads} --bake-args={BAKE_ARGS:q} > {log:q} 2>&1"

rule report:
    input:
        expand(f"{OUT}/{{case}}.json", case=list(CASES)),
    output:
        f"{OUT}/cohort_report.csv",
        f"{OUT}/cohort_report.html",
    params:
        cases=config["cases"],
    shell:
        "{PYTHON:q} {HELPER:q} report --cases {params.cases:q} --out {OUT:q}"
