#!/usr/bin/env python3
"""He et al.'s Table 2 protocol at the printed step, their fixed against dynamic
deformation region (Fig. 5) and a pull beside the press, with
`organsim springs` (docs/springs.md).

The paper's grids (225 and 625 points), 5 N at the centre, threshold 0.001 m,
100 steps of dt = 0.01 s, explicit Euler, midpoint and RK4. As printed (spring
damping 0.4/0.4/0.24 N s/m) every explicit integrator blows up at step 4; this
runs the reading of the damping under which they run: point damping
c = 0.4 N s/m on each node's own velocity, no spring damping (explicit Euler is
stable for 0.28 <= c <= 2 N s/m at this step; docs/springs.md). Per grid,
integrator and region (all vertices, He et al.'s fixed region of --region-rings
springs around the load, their dynamic region): the time per step, the force
point's depth and the largest vertex distance from the whole-grid run, for a
5 N load and for a small one (0.05 N, without gravity, which alone sags the
whole grid), where the paper prefers the fixed region. Then the pull (+5 N) beside the press (-5 N). Prints Markdown; writes
the plots into OUT_DIR.

    python3 tools/experiments/springs_table2.py --build build --out docs/springs
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
# The paper's settings are organsim springs' defaults but for the grid spacing
# (the paper gives none; 10 mm as in springs_paper.sh) and the damping reading.
PAPER = ["--spacing", "10", "--dt", "0.01", "--steps", "100", "--damping", "0,0,0", "--point-damping", "0.4"]
GRIDS = ("15x15", "25x25")
INTEGRATORS = ("euler", "midpoint", "rk4")
REGIONS = ("all", "fixed", "dynamic")
REPEATS = 3  # the fastest of these runs' time per step (the machine is shared)


class Runner:
    def __init__(self, organsim, work):
        self.organsim, self.work = organsim, work

    def run(self, name, *args):
        """One run: its JSON document and its per-step trace rows."""
        trace = os.path.join(self.work, name + ".csv")
        done = subprocess.run([self.organsim, "springs", *PAPER, *args, "--json", "--trace", trace, "--quiet"],
                              capture_output=True, text=True)
        if done.returncode != 0:
            sys.exit(f"springs_table2.py: organsim springs {' '.join(args)} failed:\n{done.stderr.strip()}")
        with open(trace, newline="") as f:
            return json.loads(done.stdout), list(csv.DictReader(f))

    def fastest(self, name, *args):
        result, rows = self.run(name, *args)
        for _ in range(REPEATS - 1):
            again, _ = self.run(name, *args)
            result["time_per_step_us"] = min(result["time_per_step_us"], again["time_per_step_us"])
        return result, rows


def largest_distance(a, b):
    return max(math.dist(p, q) for p, q in zip(a["positions"], b["positions"]))


def plot(organsim, csv_path, y, title, y_label, png):
    command = [organsim, "plot", csv_path, "--x", "step", "--y", y, "--title", title, "--x-label",
               "step (dt = 0.01 s)", "--y-label", y_label, "-o", png, "--quiet"]
    if not os.environ.get("DISPLAY"):
        command = ["xvfb-run", "-a"] + command
    subprocess.run(command, check=True, capture_output=True)
    print(f"\n![{title}]({png})")


def write_columns(path, columns):
    """A CSV of `step` and the given {label: [value per step]} (blank past a column's end)."""
    steps = max(len(v) for v in columns.values())
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["step", *columns])
        for s in range(steps):
            writer.writerow([s + 1, *(v[s] if s < len(v) else "" for v in columns.values())])


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--build", default=os.path.join(REPO, "build"))
    parser.add_argument("--out", required=True, help="folder for the plots (PNG)")
    parser.add_argument("--region-rings", default="3", help="the fixed region's size in springs from the load")
    args = parser.parse_args()
    organsim = os.path.join(args.build, "tools", "organsim")
    os.makedirs(args.out, exist_ok=True)

    with tempfile.TemporaryDirectory() as work:
        runner = Runner(organsim, work)
        print("## Table 2's protocol at dt = 0.01 s (point damping c = 0.4 N s/m)\n")
        print(f"The fixed region: the vertices within {args.region_rings} springs of the load. Depth: the force "
              "point's dz after the 100 steps; off: the largest distance of any vertex from the whole-grid run "
              "after the same steps; time: the fastest of "
              f"{REPEATS} runs.\n")
        print("| load | grid | integrator | region | active vertices (last step) | µs per step | 100 steps (ms) "
              "| depth (mm) | off the whole grid (mm) |")
        print("|---|---|---|---|---|---|---|---|---|")
        traces = {}
        loads = (("5 N", ["--force", "0,0,-5"]), ("0.05 N, no gravity", ["--force", "0,0,-0.05", "--gravity", "0"]))
        for load, load_args in loads:
            for grid in GRIDS:
                for integrator in INTEGRATORS:
                    whole = None
                    for region in REGIONS:
                        name = f"{grid}_{integrator}_{region}_{load_args[1]}"
                        result, rows = runner.fastest(name, "--grid", grid, "--integrator", integrator, "--region",
                                                      region, "--region-rings", args.region_rings, *load_args)
                        if not result["stable"]:
                            sys.exit(f"springs_table2.py: {name} blew up at step {result['steps'] + 1}")
                        whole = whole or result
                        traces[name] = rows
                        us = result["time_per_step_us"]
                        print(f"| {load} | {grid} | {integrator} | {region} | {result['active_vertices'][-1]} | "
                              f"{us:.1f} | {us * result['steps'] / 1000:.2f} | "
                              f"{result['force_vertex_displacement'][2] * 1e3:.2f} | "
                              f"{largest_distance(result, whole) * 1e3:.2f} |")

        regions_csv = os.path.join(work, "regions.csv")
        write_columns(regions_csv, {region: [float(r["force_vertex_dz_m"]) * 1e3 for r in traces[f"25x25_midpoint_{region}_0,0,-5"]]
                                    for region in REGIONS})
        plot(organsim, regions_csv, ",".join(REGIONS), "Force point depth by region, 25x25 grid, 5 N, midpoint",
             "dz (mm)", os.path.join(args.out, "regions_dt0.01.png"))
        active_csv = os.path.join(work, "active.csv")
        write_columns(active_csv, {region: [int(r["active_vertices"]) for r in traces[f"25x25_midpoint_{region}_0,0,-5"]]
                                   for region in REGIONS})
        plot(organsim, active_csv, ",".join(REGIONS), "Integrated vertices by region, 25x25 grid, 5 N, midpoint",
             "vertices", os.path.join(args.out, "regions_active_dt0.01.png"))

        print("\n## Pull beside press: ±5 N at the centre, 15x15, midpoint, dt = 0.01 s\n")
        print("| load | force point dz after 100 steps (mm) | kinetic energy at the last step (J) |")
        print("|---|---|---|")
        columns = {}
        for label, force in (("press", "0,0,-5"), ("pull", "0,0,5")):
            result, rows = runner.run(label, "--grid", "15x15", "--integrator", "midpoint", "--force", force)
            columns[label] = [float(r["force_vertex_dz_m"]) * 1e3 for r in rows]
            print(f"| {label} ({force} N) | {result['force_vertex_displacement'][2] * 1e3:+.2f} | "
                  f"{result['energy'][-1]['kinetic']:.3g} |")
        pull_csv = os.path.join(work, "pull.csv")
        write_columns(pull_csv, columns)
        plot(organsim, pull_csv, "press,pull", "Pull beside press, 15x15 grid, 5 N, midpoint", "dz (mm)",
             os.path.join(args.out, "pull_press_dt0.01.png"))


if __name__ == "__main__":
    main()
