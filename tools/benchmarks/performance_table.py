#!/usr/bin/env python3
"""Runs organsim's benchmarks and writes their figures as docs/performance.md's table.

Each row of the table is one figure: what is measured, the value, the command that
measures it, and the CPU it ran on. Re-running this script is how a figure changes;
`--only NAME,...` measures some rows again and keeps the others as they are.

  python3 tools/benchmarks/performance_table.py [--build build] [--model demo_output/liver.organ]
                                                [--only NAME,...] [--list] [--check]

--model is the liver that README command (a) bakes (`bash tools/scripts/demo.sh`); the rows that
press it need it. --check only verifies that the document's table has one row per figure
here, in order, each with this script's command (a test runs it). The full run takes
about 3 minutes on two cores; run it on an otherwise idle machine.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import os
import pathlib
import re
import shlex
import subprocess
import sys
import tempfile
from typing import Callable

REPO = pathlib.Path(__file__).resolve().parents[2]
DOCUMENT = REPO / "docs" / "performance.md"
BEGIN = "<!-- performance-table: begin (tools/benchmarks/performance_table.py writes the rows) -->"
END = "<!-- performance-table: end -->"
HEADER = ("| figure | value | command | CPU |", "|---|---|---|---|")
SESSION = "data_samples/liver_two_tools.session"
LIVER_CT = "data_samples/real_ct_totalseg/example_ct.nii.gz"
LIVER_LABEL = "data_samples/real_ct_totalseg/liver_mask_ct.nii.gz"


@dataclasses.dataclass
class Figure:
    name: str
    what: str
    command: str  # as a user types it from the repository root; MODEL is the demo's liver
    read: Callable[[str], str]  # the command's standard output -> the value cell
    environment: dict = dataclasses.field(default_factory=dict)


def benchmarks(output):
    """Google Benchmark's JSON: {name: run} (aggregates keep their own names)."""
    return {b["name"]: b for b in json.loads(output)["benchmarks"]}


def median_of(runs, name, key="real_time"):
    """The median over --benchmark_repetitions, or the single run's value."""
    return runs[name + "_median"][key] if name + "_median" in runs else runs[name][key]


def read_bake_bench(output):
    run = next(iter(benchmarks(output).values()))
    stages = ", ".join(f"{k[:-2]} {run[k]:.2f}" for k in
                       ("read CT s", "segment s", "surface s", "tetrahedra s", "beam tables s") if k in run)
    return (f"**{run['real_time'] / 1e3 if run['time_unit'] == 'ms' else run['real_time']:.2f} s** "
            f"({stages}); {run['tetrahedra']:,.0f} tetrahedra, smallest dihedral {run['min dihedral deg']:.1f}°")


def read_bake(output):
    report = json.loads(output)
    tets = report["tetrahedra"]
    total = report["seconds"]["total"]
    return (f"**{total:.2f} s**; {tets['count']:,} tetrahedra on {tets['vertices']:,} nodes, "
            f"smallest dihedral {tets['min_dihedral_deg']:.2f}°, radius–edge ratio ≤ {tets['max_radius_edge_ratio']:.2f}")


def read_segment_bench(output):
    runs = benchmarks(output)
    cells = []
    for name, run in runs.items():
        unit = 1e-3 if run["time_unit"] == "ms" else 1.0
        cells.append(f"{name.split('/')[0].removeprefix('BM_')}: **{run['real_time'] * unit:.2f} s**")
    return "; ".join(cells)


def read_load(output):
    runs = benchmarks(output)
    return (f"read and check **{median_of(runs, 'BM_LoadModelFile100k'):.1f} ms**, "
            f"ready to simulate {median_of(runs, 'BM_LoadAndPrepareOrgan100k'):.1f} ms")


def read_beam_force(output):
    runs = benchmarks(output)
    return f"**{median_of(runs, 'BM_ForcePerTool/1'):.1f} ns** per tool"


def read_deformation(output):
    runs = benchmarks(output)
    cells = [f"{tools} tool{'s' if tools > 1 else ''} **{median_of(runs, f'BM_Deformation/vertices:100000/tools:{tools}/threads:2/real_time') / 1e3:.2f} ms**"
             for tools in (1, 4, 8)]
    return ", ".join(cells) + " (two threads)"


def read_force_tick(output):
    runs = benchmarks(output)
    return (f"1 tool **{median_of(runs, 'BM_ForceTick/1'):.3f} µs**, "
            f"8 tools **{median_of(runs, 'BM_ForceTick/8'):.3f} µs**; grasping: 1 tool "
            f"{median_of(runs, 'BM_ForceTickGrasping/1'):.3f} µs, 8 tools {median_of(runs, 'BM_ForceTickGrasping/8'):.3f} µs")


def read_springs(output):
    runs = benchmarks(output)
    names = {0: "explicit Euler", 1: "midpoint", 2: "RK4", 3: "symplectic Euler", 4: "implicit Euler"}
    return ", ".join(f"{label} {median_of(runs, f'BM_StepBakedLiver/{i}'):.0f} µs" for i, label in names.items())


def read_replay(output):
    report = json.loads(output)
    frames = report["deformation_loop"]
    compute = frames["compute"]
    kept = f"; {report['instabilities']} kept their shape" if report.get("instabilities") else ""
    return (f"frame p50 **{compute['p50_ms']:.2f} ms**, p99 **{compute['p99_ms']:.2f} ms**, "
            f"max {compute['max_ms']:.2f} ms; {frames['dropped']} of {frames['frames']} frames dropped{kept}")


def read_psh_press(output):
    run = next(r for name, r in benchmarks(output).items() if name.startswith("PshPress"))
    return (f"**{run['real_time']:.0f} ms** per Newton iteration ({run['newton_iterations']:.0f} iterations; "
            f"{run.get('label', 'the default solver')})")


def read_period(output):
    match = re.search(r"period p50 ([\d.]+) ms, p99 ([\d.]+) ms, max ([\d.]+) ms;.*?(\d+) periods > 2 ms", output)
    if not match:
        raise ValueError("no force-loop period line in realtime_period's output")
    return (f"period p50 **{match[1]} ms**, p99 **{match[2]} ms**, max {match[3]} ms; "
            f"{match[4]} {'period' if match[4] == '1' else 'periods'} over 2 ms")


def read_igtl(output):
    report = json.loads(output)
    if report["failures"]:
        raise ValueError("igtl_load failed: " + "; ".join(report["failures"]))
    cells = []
    for phase in report["phases"]:
        latency = phase["in_contact_latency"]
        cells.append(f"{phase['phase']}: p50 **{latency['p50_ms']:.2f} ms**, p99 **{latency['p99_ms']:.2f} ms**")
    floor = report["machine_floor"]
    return ("pose in → force out, " + "; ".join(cells) +
            f" (machine floor: {floor['gaps_over_1ms']} gaps over 1 ms in 2 s, largest {floor['largest_gap_ms']:.2f} ms)")


def read_end_to_end(output):
    floor = re.search(r"gaps > 0\.1 ms \d+, > 1 ms (\d+), > 2 ms (\d+); largest ([\d.]+) ms", output)
    view = next((json.loads(line) for line in output.splitlines() if line.startswith("{")), None)
    if not floor or view is None or "timing" not in view:
        raise ValueError("no machine floor line or no view --realtime JSON in the output")
    t = view["timing"]
    return (f"force period p50 **{t['force_period_p50_ms']:.3f} ms**, p99 {t['force_period_p99_ms']:.3f} ms, "
            f"max {t['force_period_max_ms']:.2f} ms, {t['force_deadline_misses']} over 2 ms; deformation p50 "
            f"{t['deformation_p50_ms']:.2f} ms, {t['frames_dropped']} of "
            f"{t['deformation_frames'] + t['frames_dropped']} frames dropped; drawn **{t['frames_drawn_per_second']:.1f} "
            f"frames per second**, drawing p50 {t['draw_p50_ms']:.1f} ms, p99 {t['draw_p99_ms']:.1f} ms (machine floor: "
            f"{floor[2]} gaps over 2 ms in 5 s, largest {float(floor[3]):.2f} ms)")


def read_report_cost(output):
    c = json.loads(output)
    return (f"replay --fast {c['fast_plain_s']:.2f} s, with --report {c['fast_report_s']:.2f} s: "
            f"**+{c['fast_report_s'] - c['fast_plain_s']:.2f} s**; real time {c['realtime_plain_s']:.2f} s, with "
            f"--report {c['realtime_report_s']:.2f} s (+{c['realtime_report_s'] - c['realtime_plain_s']:.2f} s, the "
            f"machine-floor probe as long as the session included); `organsim report` rebuilding the page "
            f"{c['rebuild_s']:.2f} s")


FIGURES = [
    Figure("bake_phantom", "bake a 512 × 512 × 200 phantom CT to a 5k-vertex surface (both cores)",
           "build/tests/bake_bench --benchmark_format=json", read_bake_bench),
    Figure("bake_liver", "bake the shipped real CT with its label map (README's bake)",
           f"build/tools/organsim bake {LIVER_CT} --label {LIVER_LABEL} -o liver.organ --json", read_bake),
    Figure("segment", "seeded segmentation: the shipped real CT, the 512 × 512 × 200 phantom",
           "build/tests/segment_bench --benchmark_format=json", read_segment_bench),
    Figure("load", "load a model with a 100k-vertex surface and 20-station beam tables",
           "build/tests/model_file_bench --benchmark_filter='Load' --benchmark_repetitions=3 --benchmark_format=json",
           read_load),
    Figure("beam_force", "multi-beam force, one tool (the 1 kHz loop's work)",
           "build/tests/multibeam_bench --benchmark_filter='ForcePerTool/1$' --benchmark_repetitions=3 --benchmark_format=json",
           read_beam_force),
    Figure("deformation", "multi-beam whole-organ deformation (distortion and normals), 100k vertices",
           "build/tests/multibeam_bench --benchmark_filter='Deformation/vertices:100000/tools:[148]/threads:2' "
           "--benchmark_repetitions=3 --benchmark_format=json", read_deformation),
    Figure("force_tick", "engine force tick with 2.5 mm tips, pressing and grasping",
           "build/tests/realtime_bench --benchmark_filter='BM_ForceTick(Grasping)?/[18]$' --benchmark_repetitions=3 "
           "--benchmark_format=json",
           read_force_tick),
    Figure("springs_step", "mass-spring step on the baked liver, per integrator",
           "ORGANSIM_BENCH_MODEL=MODEL build/tests/springs_bench --benchmark_filter=StepBakedLiver "
           "--benchmark_repetitions=3 --benchmark_format=json", read_springs),
    Figure("frame_corotational", "real-time frame, co-rotational FEM, the shipped two-tool session",
           f"build/tools/organsim replay MODEL {SESSION} --model corotational --json", read_replay),
    Figure("frame_psh", "real-time frame, PSH FEM, the shipped two-tool session",
           f"build/tools/organsim replay MODEL {SESSION} --model psh --json", read_replay),
    Figure("frame_beam", "real-time frame, multi-beam, the shipped two-tool session",
           f"build/tools/organsim replay MODEL {SESSION} --model beam --json", read_replay),
    Figure("frame_grasp", "real-time frame, co-rotational FEM, the two-handed retract-and-probe session (a grasp lifts 20 mm)",
           "build/tools/organsim replay MODEL data_samples/liver_retract_and_probe.session --model corotational --json",
           read_replay),
    Figure("end_to_end_ushiki",
           "end to end at Ushiki et al.'s scale (9,218 tetrahedra, 3,000-vertex surface): multi-beam, the shipped "
           "two-tool session, 1 kHz force and 60 Hz deformation on their threads, every frame drawn (Xvfb, software "
           "OpenGL)",
           f"build/tools/organsim bake {LIVER_CT} --label {LIVER_LABEL} --tet-size 9.5 --clamp-cells 0 "
           f"--facet-distance 0.6 -o ushiki.organ > /dev/null && build/tests/cpu_stalls 5 && xvfb-run -a "
           f"build/tools/organsim view ushiki.organ --session {SESSION} --model beam --realtime --offscreen --json",
           read_end_to_end),
    Figure("report_cost", "the training report: what `--report` adds to a replay of the shipped two-tool session "
           "(multi-beam), and rebuilding the page with its four pictures",
           f"python3 tools/benchmarks/report_cost.py --build build MODEL {SESSION}", read_report_cost),
    Figure("psh_newton", "PSH static press on the baked liver, one Newton iteration",
           "ORGANSIM_BENCH_MODEL=MODEL build/tests/fem_bench --benchmark_filter=PshPress --benchmark_format=json",
           read_psh_press),
    Figure("force_loop_period", "force-loop period while a 100k-vertex organ deforms at 60 Hz, 30 s",
           "build/tests/realtime_period 30", read_period),
    Figure("igtl_latency", "`organsim serve` with 8 clients at 1 kHz, 20 s",
           "build/tests/igtl_load --seconds 20 --json", read_igtl),
]


def cpu_name():
    model = "unknown CPU"
    flags = set()
    identity = {}
    try:
        for line in pathlib.Path("/proc/cpuinfo").read_text().splitlines():
            key, _, value = line.partition(":")
            if key.strip() == "model name" and model == "unknown CPU":
                model = " ".join(value.split())
            elif key.strip() in ("cpu family", "model") and key.strip() not in identity:
                identity[key.strip()] = value.strip()
            elif key.strip() == "flags" and not flags:
                flags = set(value.split())
    except OSError:
        pass
    simd = "AVX-512" if "avx512f" in flags else "AVX2" if "avx2" in flags else "SSE2"
    if identity:  # a virtual machine's model name is often generic; family and model say which core
        model += f" (family {identity.get('cpu family', '?')} model {identity.get('model', '?')})"
    return f"{model}, {os.cpu_count()} vCPU, {simd}"


def measure(figure, build, model):
    """Runs the row's command as written, from a scratch folder where build/ and data_samples/
    are the given build and the repository's samples (what it writes stays there)."""
    command = re.sub(r"\bMODEL\b", shlex.quote(str(model)), figure.command)
    with tempfile.TemporaryDirectory(prefix="organsim-perf-") as scratch:
        (pathlib.Path(scratch) / "build").symlink_to(build, target_is_directory=True)
        (pathlib.Path(scratch) / "data_samples").symlink_to(REPO / "data_samples", target_is_directory=True)
        (pathlib.Path(scratch) / "tools").symlink_to(REPO / "tools", target_is_directory=True)
        result = subprocess.run(["bash", "-c", command], cwd=scratch, capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError(f"{figure.name}: `{figure.command}` exited {result.returncode}:\n{result.stderr[-2000:]}")
    return figure.read(result.stdout if result.stdout.strip() else result.stderr)


def row(figure, value, cpu):
    return f"| {figure.what} | {value} | `{figure.command}` | {cpu} |"


def table_in(text):
    if BEGIN not in text or END not in text:
        raise SystemExit(f"{DOCUMENT}: no table between '{BEGIN}' and '{END}'")
    head, rest = text.split(BEGIN, 1)
    body, tail = rest.split(END, 1)
    rows = [line for line in body.strip().splitlines() if line.startswith("|")][2:]
    return head, rows, tail


def check(text):
    _, rows, _ = table_in(text)
    problems = []
    if len(rows) != len(FIGURES):
        problems.append(f"{len(rows)} rows for {len(FIGURES)} figures")
    for figure, line in zip(FIGURES, rows):
        cells = [c.strip() for c in line.strip("|").split(" | ")]
        if len(cells) != 4 or cells[0] != figure.what or cells[2] != f"`{figure.command}`":
            problems.append(f"row for {figure.name} does not match: {line[:160]}")
    return problems


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", type=pathlib.Path, default=REPO / "build")
    parser.add_argument("--model", type=pathlib.Path, default=REPO / "demo_output" / "liver.organ")
    parser.add_argument("--only", help="comma-separated figure names to measure again (default: all)")
    parser.add_argument("--list", action="store_true", help="list the figures and their commands")
    parser.add_argument("--check", action="store_true", help="check the document's table against the figures")
    args = parser.parse_args()

    if args.list:
        for figure in FIGURES:
            print(f"{figure.name:20} {figure.command}")
        return 0
    text = DOCUMENT.read_text(encoding="utf-8")
    if args.check:
        problems = check(text)
        for problem in problems:
            print(f"{DOCUMENT.name}: {problem}", file=sys.stderr)
        return 1 if problems else 0

    wanted = set(args.only.split(",")) if args.only else {f.name for f in FIGURES}
    unknown = wanted - {f.name for f in FIGURES}
    if unknown:
        parser.error(f"unknown figure(s) {', '.join(sorted(unknown))}: --list names them")
    if any(re.search(r"\bMODEL\b", f.command) for f in FIGURES if f.name in wanted) and not args.model.is_file():
        parser.error(f"{args.model} does not exist: run `bash tools/scripts/demo.sh` first, or give --model")
    head, rows, tail = table_in(text)
    old = {}
    for line in rows:
        for figure in FIGURES:
            if line.startswith(f"| {figure.what} |"):
                old[figure.name] = line
    cpu = cpu_name()
    new_rows = []
    for figure in FIGURES:
        if figure.name in wanted:
            print(f"measuring {figure.name}: {figure.command}", file=sys.stderr, flush=True)
            value = measure(figure, args.build.resolve(), args.model.resolve())
            print(f"  {value}", file=sys.stderr, flush=True)
            new_rows.append(row(figure, value, cpu))
        elif figure.name in old:
            new_rows.append(old[figure.name])
        else:
            new_rows.append(row(figure, "not measured", "—"))
    table = "\n".join([BEGIN, *HEADER, *new_rows, END])
    DOCUMENT.write_text(head + table + tail, encoding="utf-8")
    print(f"wrote {len(new_rows)} rows to {DOCUMENT.relative_to(REPO)}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
