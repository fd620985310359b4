#!/usr/bin/env python3
"""Ushiki et al.'s multi-beam figures at their own scale (docs/multibeam.md).

The paper's liver has 2,394 mass points and 9,258 tetrahedra; it reports, per
tool, 0.082 ms for the force loop and 3.75 ms for the organ's deformation
(Pentium 4, 3 GHz); it cites its single-beam predecessor for changing the
organ's volume less than a linear FEM under large deformations. This bakes the shipped CT at that
scale (--tet-size 9.5 --clamp-cells 0 --facet-distance 0.6: about 9,200
tetrahedra on 2,600 nodes, a 3,000-vertex surface), times the beam's force and
creation and the deformation with 1, 2, 4 and 8 tools (multibeam_bench on the
model), and presses one site 5, 10, 20 and 30 mm in along its normal with the
multi-beam, linear and co-rotational FEM models (`organsim compare`), writing
each model's volume change to a CSV and, with --plot, a chart. Only the chart is
shipped (docs/images/ushiki_volume.png); the CSV's figures are docs/multibeam.md's
volume table, so it goes to a scratch path:

    python3 tools/experiments/ushiki_scale.py --build build \\
        --csv /tmp/ushiki_volume.csv --plot docs/images/ushiki_volume.png
"""
import argparse
import csv
import json
import math
import os
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SAMPLE = os.path.join(REPO, "data_samples", "real_ct_totalseg")
# The shipped session's first tool: a point of the anterior surface and its inward normal.
SITE = (-7.1, -252.0, 356.2)
INWARD = (0.28, -4.46, 2.24)
MODELS = ("beam", "linear", "corotational")


def run(command, **kwargs):
    done = subprocess.run(command, capture_output=True, text=True, **kwargs)
    if done.returncode != 0:
        sys.exit(f"ushiki_scale.py: {' '.join(command)} failed:\n{done.stderr.strip()}")
    return done.stdout


def bench(build, model):
    """Google Benchmark's JSON for the beam's force, creation and deformation on the model."""
    environment = dict(os.environ, ORGANSIM_BENCH_MODEL=model)
    out = run([os.path.join(build, "tests", "multibeam_bench"),
               "--benchmark_filter=^(BM_ForcePerTool/1|ModelBeamCreation|ModelDeformation/tools:[0-9]+)$",
               "--benchmark_repetitions=5", "--benchmark_format=json"], env=environment)
    fastest = {}
    for b in json.loads(out)["benchmarks"]:
        if b.get("run_type") != "iteration":
            continue
        seconds = b["real_time"] * {"ns": 1e-9, "us": 1e-6, "ms": 1e-3}[b["time_unit"]]
        fastest[b["run_name"]] = min(seconds, fastest.get(b["run_name"], math.inf))
    return fastest


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", default=os.path.join(REPO, "build"))
    parser.add_argument("--depths", default="5,10,20,30", help="press depths, mm")
    parser.add_argument("--csv", required=True, help="volume change per depth and model (written)")
    parser.add_argument("--plot", help="a PNG chart of the CSV (needs xvfb-run where there is no display)")
    args = parser.parse_args()
    organsim = os.path.join(args.build, "tools", "organsim")

    with tempfile.TemporaryDirectory() as work:
        model = os.path.join(work, "liver_ushiki.organ")
        baked = json.loads(run([organsim, "bake", os.path.join(SAMPLE, "example_ct.nii.gz"), "--label",
                                os.path.join(SAMPLE, "liver_mask_ct.nii.gz"), "--tet-size", "9.5",
                                "--clamp-cells", "0", "--facet-distance", "0.6", "-o", model, "--json"]))
        print(f"liver: {baked['surface']['vertices']} surface vertices, {baked['tetrahedra']['vertices']} nodes, "
              f"{baked['tetrahedra']['count']} tetrahedra (paper: 2,394 mass points, 9,258 tetrahedra)")

        times = bench(args.build, model)
        deform = {int(name.split(":")[1]): s for name, s in times.items() if name.startswith("ModelDeformation")}
        per_added_tool = (deform[8] - deform[1]) / 7
        print("\n| figure | paper (Pentium 4, 3 GHz) | ours |\n|---|---|---|")
        print(f"| force loop per tool (the beam's force from the tool's displacement) | 0.082 ms | "
              f"{times['BM_ForcePerTool/1'] * 1e9:.1f} ns |")
        print(f"| beam creation when a contact begins | — | {times['ModelBeamCreation'] * 1e6:.1f} µs |")
        print(f"| deformation, one tool (distortion and normals of the surface) | 3.75 ms | "
              f"{deform[1] * 1e6:.0f} µs |")
        print(f"| deformation per added tool (1 → 8 tools: {deform[1] * 1e6:.0f} → {deform[8] * 1e6:.0f} µs) | "
              f"3.75 ms | {per_added_tool * 1e6:.0f} µs |")

        depths = [float(d) for d in args.depths.split(",")]
        norm = math.sqrt(sum(c * c for c in INWARD))
        rows = []
        for depth in depths:
            move = ",".join(f"{c / norm * depth:.3f}" for c in INWARD)
            tool = ",".join(f"{c}" for c in SITE) + "/" + move
            result = json.loads(run([organsim, "compare", model, "--models", ",".join(MODELS), "--reference", "linear",
                                     "--tool", tool, "--json", "--quiet"]))
            rows.append([depth] + [result["models"][m]["volume_change_percent"] for m in MODELS])
        with open(args.csv, "w", newline="") as f:
            writer = csv.writer(f)
            writer.writerow(["depth_mm"] + list(MODELS))
            writer.writerows(rows)
        print("\n| press (mm) | " + " | ".join(MODELS) + " |\n|---|" + "---|" * len(MODELS))
        for row in rows:
            print(f"| {row[0]:g} | " + " | ".join(f"{v:+.3f} %" for v in row[1:]) + " |")

        if args.plot:
            command = [organsim, "plot", args.csv, "--x", "depth_mm", "--y", ",".join(MODELS), "--title",
                       "Volume change against press depth (liver at Ushiki et al.'s scale)", "--x-label",
                       "press depth (mm)", "--y-label", "volume change (%)", "-o", args.plot]
            if not os.environ.get("DISPLAY"):
                command = ["xvfb-run", "-a"] + command
            run(command)
            print(f"\nplotted {args.plot}")


if __name__ == "__main__":
    main()
