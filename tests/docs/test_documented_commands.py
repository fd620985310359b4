"""The shell commands of README.md and docs/**/*.md, run as written: every fenced shell
block carries a marker (run_documented_commands.py says which), each document's blocks
run in order in a scratch copy of the repository, and the cohort page's command is one of
them, verbatim, baking every case with no optional configuration."""
import csv
import os
import pathlib
import shutil
import sys
import tempfile

import pytest

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import run_documented_commands as docs  # noqa: E402

BUILD = os.environ.get("ORGANSIM_BUILD_DIR", str(docs.REPO / "build"))
COHORT_COMMAND = "snakemake -s tools/workflows/bake_cohort.smk --config cases=cohort.csv out=models --cores 8"
DOCUMENTS = [str(p.relative_to(docs.REPO)) for p in docs.documents()]
BLOCKS = [b for name in DOCUMENTS for b in docs.shell_blocks(docs.REPO / name)]


@pytest.fixture(scope="module")
def runs():
    """One DocumentRun (one scratch copy) per document, shared by its blocks in order."""
    made, folders = {}, []

    def run_of(document):
        if document not in made:
            folders.append(tempfile.mkdtemp(prefix="organsim-docs-"))
            made[document] = docs.DocumentRun(document, BUILD, folders[-1])
        return made[document]

    yield run_of
    for folder in folders:
        shutil.rmtree(folder, ignore_errors=True)


def test_every_shell_block_is_run_or_skipped_for_a_reason():
    unmarked = [f"{b.where} (```{b.language})" for b in BLOCKS if b.marker is None]
    assert not unmarked, ("shell blocks without <!-- run --> or <!-- run: skip REASON --> on the line above: "
                          + ", ".join(unmarked))
    for block in BLOCKS:
        block.options()  # a marker it cannot read is an error naming the line


def test_the_cohort_page_runs_the_cohort_command_verbatim():
    for document in ("docs/cohort.md",):
        runnable = [b for b in BLOCKS if b.document == document and "skip" not in b.options()]
        assert any(b.text.strip() == COHORT_COMMAND for b in runnable), f"{document}: `{COHORT_COMMAND}` not run"


@pytest.mark.parametrize("block", [b for b in BLOCKS if b.marker is not None], ids=lambda b: b.where)
def test_documented_block(block, runs):
    result = runs(block.document).run(block)
    if result.status == "skipped":
        pytest.skip(f"{block.where}: {result.message}")
    print(f"{block.where}: {result.seconds:.1f} s")
    assert result.status == "ran", result.message


@pytest.mark.parametrize("document", ["docs/cohort.md"])
def test_the_documented_cohort_bakes_every_case(document, runs):
    root = runs(document).root
    if root is None or not (root / "models" / "cohort_report.csv").exists():
        pytest.fail(f"{document}: its cohort command did not run or wrote no report (see its block's test)")
    with open(root / "models" / "cohort_report.csv", newline="") as f:
        rows = {row["case"]: row for row in csv.DictReader(f)}
    assert set(rows) == {"real_ct", "phantom"}
    for case, row in rows.items():
        assert row["status"] == "ok", f"{document}: {case}: {row['error']}"
        assert (root / "models" / f"{case}.organ").stat().st_size > 100_000
    assert rows["real_ct"]["segmentation"].startswith("label map")
    assert rows["phantom"]["fixed_point_source"] == "given point"
