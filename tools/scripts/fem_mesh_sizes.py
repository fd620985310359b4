#!/usr/bin/env python3
"""The FEM models' frame time against the mesh size (docs/fem.md#finer-meshes).

Bakes the shipped CT with its liver label map at finer and finer --tet-size
(no site compliances: the FEM models do not read them), replays the shipped
two-tool session in real time through the co-rotational and PSH models on each,
and writes per size and model: tetrahedra, the set-up (ordering, factorization;
seconds and the process's resident memory after it), the model's own frame
estimate, the p50/p99 of the frames in which a tool holds the organ (the
FEM models have nothing to solve in the others), the frames dropped and those that kept the organ's
shape (a step that would have inverted a tetrahedron or thrown the organ out
of balance: cheap frames that do not follow the tools). Prints a Markdown table and the
fitted power law of frame p50 and set-up time in the number of tetrahedra, and
draws them on log-log axes. --from-csv redraws an earlier run without measuring.

    python3 tools/scripts/fem_mesh_sizes.py --build build --sizes 8,6.3,5,4.2,3.7 \\
        --csv docs/fem/mesh_sizes.csv --plot docs/images/fem_mesh_sizes.png
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
SESSION = os.path.join(REPO, "data_samples", "liver_two_tools.session")
MODELS = ("corotational", "psh")


def run(command):
    done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        sys.exit(f"fem_mesh_sizes: {' '.join(command)} failed ({done.returncode}):\n{done.stderr}")
    return done.stdout


def fitted_exponent(xs, ys):
    """Least-squares slope of log y against log x."""
    lx = [math.log(x) for x in xs]
    ly = [math.log(y) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sum((a - mx) ** 2 for a in lx)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", default=os.path.join(REPO, "build"), help="the build directory")
    parser.add_argument("--sizes", default="8,6.5,5.2,4.4", help="--tet-size values, mm")
    parser.add_argument("--models", default=",".join(MODELS), help="FEM models to replay")
    parser.add_argument("--csv", help="write the rows here")
    parser.add_argument("--plot", help="draw frame p50 and set-up time against tetrahedra here (PNG)")
    parser.add_argument("--from-csv", help="measure nothing: report (table, fits, plot) the rows of an earlier --csv")
    args = parser.parse_args()
    rows = read_rows(args.from_csv) if args.from_csv else measure(args)
    report(rows, args)


def read_rows(path):
    with open(path, newline="") as source:
        rows = list(csv.DictReader(source))
    for r in rows:
        for key in ("tet_size_mm", "setup_s", "resident_mib", "estimate_ms", "p50_ms", "p99_ms"):
            r[key] = float(r[key])
        for key in ("tetrahedra", "dropped", "frames"):
            r[key] = int(r[key])
        r["kept_shape"] = int(r["kept_shape"]) if r.get("kept_shape") not in (None, "") else None  # older runs
    return rows


def measure(args):
    organsim = os.path.join(args.build, "tools", "organsim")
    rows = []
    with tempfile.TemporaryDirectory() as scratch:
        for size in [float(s) for s in args.sizes.split(",")]:
            model = os.path.join(scratch, f"liver_{size:g}.organ")
            bake = json.loads(run([organsim, "bake", os.path.join(SAMPLE, "example_ct.nii.gz"),
                                   "--label", os.path.join(SAMPLE, "liver_mask_ct.nii.gz"),
                                   "--tet-size", f"{size:g}", "--no-site-compliance", "--quiet", "--json",
                                   "-o", model]))
            tetrahedra = bake["tetrahedra"]["count"]
            for name in args.models.split(","):
                replay = json.loads(run([organsim, "replay", model, SESSION, "--model", name, "--json"]))
                frames = replay["deformation_loop"]
                rows.append({
                    "tet_size_mm": size,
                    "tetrahedra": tetrahedra,
                    "model": name,
                    "setup_s": round(replay["setup"]["seconds"], 3),
                    "resident_mib": round(replay["setup"]["resident_mib"], 1),
                    "estimate_ms": round(replay["setup"]["estimated_frame_ms"], 2),
                    "p50_ms": round(frames["contact_compute"]["p50_ms"], 2),
                    "p99_ms": round(frames["contact_compute"]["p99_ms"], 2),
                    "dropped": frames["dropped"],
                    "frames": frames["frames"],
                    "kept_shape": replay["instabilities"],
                })
                print(json.dumps(rows[-1]), file=sys.stderr, flush=True)
    return rows


def report(rows, args):
    models = list(dict.fromkeys(r["model"] for r in rows))
    if args.csv and not args.from_csv:
        with open(args.csv, "w", newline="") as out:
            writer = csv.DictWriter(out, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    print("| --tet-size | tetrahedra | model | set-up | resident | estimate | frame p50 | p99 | dropped | kept shape |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['tet_size_mm']:g} mm | {r['tetrahedra']:,} | {r['model']} | {r['setup_s']:.2f} s | "
              f"{r['resident_mib']:.0f} MiB | {r['estimate_ms']:.1f} ms | {r['p50_ms']:.1f} ms | "
              f"{r['p99_ms']:.1f} ms | {r['dropped']} of {r['frames'] + r['dropped']} | "
              f"{'—' if r['kept_shape'] is None else r['kept_shape']} |")
    fits = {}
    for name in models:
        mine = [r for r in rows if r["model"] == name]
        if len(mine) < 2:
            continue
        xs = [r["tetrahedra"] for r in mine]
        fits[name] = {key: fitted_exponent(xs, [r[key] for r in mine]) for key in ("p50_ms", "setup_s", "resident_mib")}
        print(f"{name}: frame p50 ~ n^{fits[name]['p50_ms']:.2f}, set-up ~ n^{fits[name]['setup_s']:.2f}, "
              f"resident memory ~ n^{fits[name]['resident_mib']:.2f}")
    if args.plot and fits:
        import matplotlib  # python3-matplotlib (tools/scripts/setup.sh installs it)
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        figure, axes = plt.subplots(1, 2, figsize=(10, 4))
        for name in fits:
            mine = [r for r in rows if r["model"] == name]
            xs = [r["tetrahedra"] for r in mine]
            axes[0].loglog(xs, [r["p50_ms"] for r in mine], "o-", label=f"{name} p50 (n^{fits[name]['p50_ms']:.2f})")
            axes[0].loglog(xs, [r["p99_ms"] for r in mine], "x--", label=f"{name} p99")
            axes[1].loglog(xs, [r["setup_s"] for r in mine], "o-", label=f"{name} (n^{fits[name]['setup_s']:.2f})")
        axes[0].axhline(1000 / 60, color="grey", lw=0.8, label="60 Hz frame")
        axes[0].axhline(1000 / 30, color="grey", lw=0.8, ls=":", label="30 Hz frame")
        axes[0].set(xlabel="tetrahedra", ylabel="frame compute, ms", title="real-time frames")
        axes[1].set(xlabel="tetrahedra", ylabel="set-up, s", title="set-up (ordering, factorization)")
        for a in axes:
            a.grid(True, which="both", lw=0.3)
            a.legend(fontsize=7)
        figure.tight_layout()
        figure.savefig(args.plot, dpi=110)


if __name__ == "__main__":
    main()
