"""tools/workflows/bake_cohort.smk: three generated phantoms (one broken) baked by
Snakemake; the other two complete, the failure is a report row; resumable; a changed
row re-bakes its case only; a bad table is one clear error; the Slurm mode plans
the same jobs."""
import csv
import json
import os
import pathlib
import subprocess
import sys

import pytest

REPO = pathlib.Path(__file__).resolve().parents[3]
WORKFLOW = REPO / "tools" / "workflows" / "bake_cohort.smk"
PROGRAM = os.environ.get("ORGANSIM_EXECUTABLE", str(REPO / "build" / "tools" / "organsim"))
QUICK = "--surface-vertices 800 --tet-size 12 --stations 8 --section-samples 32"


def snakemake(folder, cases, *extra):
    command = [sys.executable, "-m", "snakemake", "-s", str(WORKFLOW), "--config", f"cases={cases}", "out=out",
               f"organsim={PROGRAM}", f"bake_args={QUICK}", "--cores", "2", *extra]
    return subprocess.run(command, cwd=folder, capture_output=True, text=True)


@pytest.fixture(scope="module")
def cohort(tmp_path_factory):
    folder = tmp_path_factory.mktemp("cohort")
    cts = folder / "cts"
    cts.mkdir()
    for name, seed, mask in (("a", 1, False), ("b", 2, True), ("c", 3, False)):
        command = [PROGRAM, "phantom", "-o", cts / f"{name}.nii.gz", "--size", "96,96,48", "--seed", str(seed)]
        if mask:
            command += ["--mask", cts / f"{name}_mask.nii.gz"]
        subprocess.run(command, check=True, capture_output=True)
    # The broken case: its CT cut short, as an interrupted copy leaves it.
    data = (cts / "c.nii.gz").read_bytes()
    (cts / "c.nii.gz").write_bytes(data[: len(data) // 4])
    (folder / "cases.csv").write_text(
        "case,ct,label,seed,fixed_point\n"
        'phantom_a,cts/a.nii.gz,,"-65,5,0","-22.32,12.07,-53.22"\n'
        '"phantom_b","cts/b.nii.gz","cts/b_mask.nii.gz","",""\n'
        'phantom_c,cts/c.nii.gz,,"-65,5,0",\n')
    run = snakemake(folder, "cases.csv")
    return folder, run


def report_rows(folder):
    with open(folder / "out" / "cohort_report.csv", newline="") as f:
        return {row["case"]: row for row in csv.DictReader(f)}


def test_the_workflow_bakes_the_good_cases_and_reports_the_broken_one(cohort):
    folder, run = cohort
    assert run.returncode == 0, run.stderr
    out = folder / "out"
    for case in ("phantom_a", "phantom_b"):
        assert (out / f"{case}.organ").stat().st_size > 100_000
        report = json.loads((out / f"{case}.json").read_text())
        assert report["status"] == "ok" and report["case"] == case
        assert report["tetrahedra"]["count"] > 1000
        info = subprocess.run([PROGRAM, "info", out / f"{case}.organ", "--json"], capture_output=True, text=True)
        assert info.returncode == 0, info.stderr
    assert not (out / "phantom_c.organ").exists()
    failed = json.loads((out / "phantom_c.json").read_text())
    assert failed["status"] == "failed" and failed["exit_code"] == 1
    assert "truncated" in failed["error"] and "c.nii.gz" in failed["error"]
    assert not list(out.glob(".*tmp*")), "no temporary file is left"

    rows = report_rows(folder)
    assert list(rows) == ["phantom_a", "phantom_b", "phantom_c"]
    assert rows["phantom_a"]["status"] == "ok" and rows["phantom_a"]["fixed_point_source"] == "given point"
    assert rows["phantom_b"]["segmentation"].startswith("label map")
    assert 500 < float(rows["phantom_b"]["volume_ml"]) < 800
    assert float(rows["phantom_a"]["min_dihedral_deg"]) > 0
    assert rows["phantom_c"]["status"] == "failed" and "truncated" in rows["phantom_c"]["error"]
    assert rows["phantom_c"]["tetrahedra"] == ""
    page = (out / "cohort_report.html").read_text()
    assert "3 case(s)" in page and "2 baked" in page and "1 failed" in page
    assert page.count('<tr class="ok">') == 2 and page.count('<tr class="failed">') == 1


def test_a_second_run_has_nothing_to_do_and_a_changed_row_rebakes_only_its_case(cohort):
    folder, first = cohort
    assert first.returncode == 0, first.stderr
    again = snakemake(folder, "cases.csv")
    assert again.returncode == 0, again.stderr
    assert "Nothing to be done" in again.stderr
    baked_before = (folder / "out" / "phantom_b.organ").stat().st_mtime_ns
    changed = (folder / "cases.csv").read_text().replace('"phantom_b","cts/b.nii.gz","cts/b_mask.nii.gz","",""',
                                                           'phantom_b,cts/b.nii.gz,cts/b_mask.nii.gz,,"-30,10,-50"')
    (folder / "cases_changed.csv").write_text(changed)
    rerun = snakemake(folder, "cases_changed.csv")
    assert rerun.returncode == 0, rerun.stderr
    assert "case=phantom_b" in rerun.stderr and "case=phantom_a" not in rerun.stderr
    assert (folder / "out" / "phantom_b.organ").stat().st_mtime_ns != baked_before
    assert report_rows(folder)["phantom_b"]["fixed_point_mm"] == "-30.0,10.0,-50.0"


def test_a_table_the_workflow_cannot_use_is_one_clear_error(tmp_path):
    (tmp_path / "bad.csv").write_text("case,ct,seed\nx,ct.nii.gz,\"1,2,3\"\n")
    run = snakemake(tmp_path, "bad.csv")
    assert run.returncode != 0
    assert "bad.csv:1: the header must be exactly case,ct,label,seed,fixed_point" in run.stderr
    (tmp_path / "twice.csv").write_text("case,ct,label,seed,fixed_point\nx,a.nii.gz,,,\nx,b.nii.gz,,,\n")
    run = snakemake(tmp_path, "twice.csv")
    assert "twice.csv:3: case 'x' appears twice (first on line 2)" in run.stderr


def test_the_slurm_mode_plans_the_same_jobs_with_their_resources(cohort):
    folder, _ = cohort
    (folder / "more.csv").write_text((folder / "cases.csv").read_text() + "phantom_d,cts/b.nii.gz,cts/b_mask.nii.gz,,\n")
    plan = snakemake(folder, "more.csv", "--slurm", "--jobs", "10", "--default-resources", "slurm_account=surgery",
                     "slurm_partition=cpu", "--dry-run")
    assert plan.returncode == 0, plan.stderr
    assert "case=phantom_d" in plan.stdout + plan.stderr
    assert "slurm_partition=cpu" in plan.stdout + plan.stderr and "mem_mb=6000" in plan.stdout + plan.stderr
