#!/usr/bin/env python3
"""How cost grows with the work: the scaling curves of docs/performance.md.

`bake`: the phantom (`organsim phantom`) over its 384 x 312 x 192 mm field of
view at finer and finer grids, from 128 x 128 x 100 up to 512 x 512 x 1500
voxels, each baked (`organsim bake --json`, both cores): the time of every
stage and the process's peak resident memory (GNU time's %M).

`runtime`: `surface_scaling` (tests/bench/surface_scaling.cpp) on test spheres
of 3k to 1M vertices: load, deformation with 1 and 8 tools, normals, the force
tick, and the organ's memory.

Each writes a CSV with one row per size and, with --plot PREFIX, log-log charts
drawn by `organsim plot --log-x --log-y`, which prints each curve's fitted
exponent.

    python3 tools/experiments/scaling.py bake --csv docs/images/bake_scaling.csv --plot docs/images/bake_scaling
    python3 tools/experiments/scaling.py runtime --csv docs/images/runtime_scaling.csv --plot docs/images/runtime_scaling

--sizes picks the grids (NX,NY,NZ;...) or vertex counts (N,...); CI runs the smallest two.
"""
import argparse
import csv
import json
import os
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIELD_OF_VIEW_MM = (384.0, 312.0, 192.0)
SEED_MM = "-65,5,0"  # in the phantom's right lobe at this field of view (docs/cli.md, phantom)
BAKE_SIZES = "128,128,100;256,256,200;512,512,200;512,512,600;512,512,1000;512,512,1500"
# The stages a bake reports (bake --json's "seconds"."stages"), in order: the
# first four work on voxels, the others on the surface and the tetrahedra.
STAGES = ("read CT", "segment", "fixed point", "surface", "tetrahedra", "beam tables", "site compliance", "assemble",
          "supports")
VOXEL_STAGES = STAGES[:4]
SURFACE_SIZES = "3000,30000,100000,300000,1000000"


def run(command, **kwargs):
    done = subprocess.run(command, capture_output=True, text=True, **kwargs)
    if done.returncode != 0:
        sys.exit(f"scaling.py: {' '.join(command)} failed:\n{done.stderr.strip()}")
    return done


def write_csv(path, rows):
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(rows[0].keys()))
        writer.writeheader()
        writer.writerows(rows)


def plot(organsim, csv_path, x, x_label, columns, title, y_label, png):
    command = [organsim, "plot", csv_path, "--x", x, "--y", ",".join(columns), "--log-x", "--log-y",
               "--title", title, "--x-label", x_label, "--y-label", y_label, "-o", png]
    if not os.environ.get("DISPLAY"):
        command = ["xvfb-run", "-a"] + command
    print(run(command).stdout.rstrip())


def bake_curve(args, organsim):
    rows = []
    for size_text in args.sizes.split(";"):
        size = [int(n) for n in size_text.split(",")]
        spacing = [fov / n for fov, n in zip(FIELD_OF_VIEW_MM, size)]
        voxels = size[0] * size[1] * size[2]
        with tempfile.TemporaryDirectory() as work:
            ct = os.path.join(work, "phantom.nii")  # uncompressed: the bake's reading, not gzip's, is measured
            run([organsim, "phantom", "-o", ct, "--size", size_text, "--spacing",
                 ",".join(f"{s:.6g}" for s in spacing), "--quiet"])
            done = run(["/usr/bin/time", "-f", "peak_kib %M", organsim, "bake", ct, "-o",
                        os.path.join(work, "phantom.organ"), "--seed", SEED_MM, "--json", "--quiet"])
        peak_mib = int([line for line in done.stderr.splitlines() if line.startswith("peak_kib ")][-1].split()[1]) / 1024
        baked = json.loads(done.stdout)
        stages = baked["seconds"]["stages"]
        voxel_seconds = sum(stages.get(stage, 0.0) for stage in VOXEL_STAGES)
        row = {"voxels": voxels, "size": "x".join(map(str, size)), "total_s": baked["seconds"]["total"],
               "voxel_stages_s": voxel_seconds, "peak_mib": peak_mib, "ct_int16_mib": voxels * 2 / 2**20,
               "surface_vertices": baked["surface"]["vertices"], "tetrahedra": baked["tetrahedra"]["count"]}
        for stage in STAGES:
            row[stage.replace(" ", "_") + "_s"] = stages.get(stage, 0.0)
        rows.append(row)
        print(f"{row['size']:>14} ({voxels / 1e6:7.1f} M voxels): bake {row['total_s']:6.2f} s, on voxels "
              f"{voxel_seconds:.2f} s (" + ", ".join(f"{stage} {stages.get(stage, 0.0):.2f}" for stage in STAGES)
              + f"), peak memory {peak_mib:7.0f} MiB = {peak_mib / row['ct_int16_mib']:.2f} x the CT's int16 size"
              + f" ({row['ct_int16_mib']:.0f} MiB), {row['surface_vertices']} surface vertices, "
              f"{row['tetrahedra']} tetrahedra", flush=True)
    write_csv(args.csv, rows)
    if args.plot and len(rows) > 1:
        plot(organsim, args.csv, "voxels", "CT voxels",
             ["total_s", "voxel_stages_s"] + [s.replace(" ", "_") + "_s" for s in VOXEL_STAGES],
             "organsim bake: time per stage against the CT's size", "seconds", args.plot + "_time.png")
        plot(organsim, args.csv, "voxels", "CT voxels", ["peak_mib", "ct_int16_mib"],
             "organsim bake: peak resident memory", "MiB", args.plot + "_memory.png")


def runtime_curve(args, organsim):
    bench = os.path.join(args.build, "tests", "surface_scaling")
    out = run([bench, "--benchmark_format=json", "--benchmark_min_time=0.2"],
              env=dict(os.environ, ORGANSIM_SCALING_SIZES=args.sizes)).stdout
    report = json.loads(out)
    print(f"cpu: {report['context'].get('cpu', '?')}, {report['context'].get('simd', '?')}")
    by_size = {}
    for b in report["benchmarks"]:
        if b.get("error_occurred"):
            sys.exit(f"scaling.py: {b['name']}: {b.get('error_message', 'failed')}")
        seconds = b["real_time"] * {"ns": 1e-9, "us": 1e-6, "ms": 1e-3}[b["time_unit"]]
        name = b["name"].split("/")[0]
        if name == "Deformation":
            name += "_" + b["name"].split("tools:")[1] + "_tools"
        row = by_size.setdefault(int(b["vertices"]), {"vertices": int(b["vertices"])})
        row[name + "_s"] = seconds
        if "file_MB" in b:
            row["file_mb"], row["organ_mb"] = b["file_MB"], b["organ_MB"]
    rows = [by_size[n] for n in sorted(by_size)]
    for row in rows:
        print(f"{row['vertices']:>8} vertices: load {row['Load_s'] * 1e3:8.1f} ms, deformation 1 / 8 tools "
              f"{row['Deformation_1_tools_s'] * 1e3:7.2f} / {row['Deformation_8_tools_s'] * 1e3:7.2f} ms, normals "
              f"{row['Normals_s'] * 1e3:6.2f} ms, force tick {row['ForceTick_s'] * 1e6:.3f} us, file "
              f"{row['file_mb']:.0f} MB, organ {row['organ_mb']:.0f} MB", flush=True)
    write_csv(args.csv, rows)
    if args.plot and len(rows) > 1:
        plot(organsim, args.csv, "vertices", "surface vertices",
             ["Load_s", "Deformation_1_tools_s", "Deformation_8_tools_s", "Normals_s", "ForceTick_s"],
             "The runtime against the surface's size", "seconds", args.plot + "_time.png")
        plot(organsim, args.csv, "vertices", "surface vertices", ["file_mb", "organ_mb"],
             "The model file and the organ in memory", "MB", args.plot + "_memory.png")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("curve", choices=("bake", "runtime"))
    parser.add_argument("--build", default=os.path.join(REPO, "build"))
    parser.add_argument("--sizes", help=f"bake: grids NX,NY,NZ separated by ';' (default {BAKE_SIZES}); runtime: "
                        f"vertex counts separated by ',' (default {SURFACE_SIZES})")
    parser.add_argument("--csv", required=True, help="one row per size (written)")
    parser.add_argument("--plot", help="prefix of the charts: PREFIX_time.png and PREFIX_memory.png")
    args = parser.parse_args()
    organsim = os.path.join(args.build, "tools", "organsim")
    if args.curve == "bake":
        args.sizes = args.sizes or BAKE_SIZES
        bake_curve(args, organsim)
    else:
        args.sizes = args.sizes or SURFACE_SIZES
        runtime_curve(args, organsim)


if __name__ == "__main__":
    main()
