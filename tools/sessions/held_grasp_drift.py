#!/usr/bin/env python3
"""Whether a held grasp stayed put: reads a replay's forces (--forces), progress lines
(--progress with --json, on stderr) and summary (--json) and prints the grasper's force
drift while it held, the resident memory over the run and the loops' figures.

    held_grasp_drift.py FORCES.csv PROGRESS.jsonl SUMMARY.json --hold-from S --hold-until S

The grasper is tool 1. Its force is taken second by second (the median of each second's
ticks, so that a tick disturbed by the machine losing the CPU is not read as drift); the
drift is the largest distance of a later second's force from the first second's. Ticks
more than 1 % off their second's force are counted and reported as transients.
Exits 1 when tool 1 lost contact in the window, its grasp slipped or did not begin, the
drift exceeds 1 % of the reference force, or the resident memory grew by more than 1 %.
"""
import argparse
import json
import sys

import numpy as np


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("forces")
    parser.add_argument("progress")
    parser.add_argument("summary")
    parser.add_argument("--hold-from", type=float, required=True, help="s: the window starts (the lift done)")
    parser.add_argument("--hold-until", type=float, required=True, help="s: the window ends (before the jaws open)")
    args = parser.parse_args()

    table = np.loadtxt(args.forces, delimiter=",", skiprows=1)
    grasper = table[(table[:, 1] == 1) & (table[:, 0] >= args.hold_from) & (table[:, 0] <= args.hold_until)]
    if len(grasper) == 0:
        sys.exit(f"{args.forces}: no force of tool 1 between {args.hold_from} and {args.hold_until} s")
    second = np.floor(grasper[:, 0] - args.hold_from).astype(int)
    seconds = np.unique(second)
    medians = np.array([np.median(grasper[second == k, 2:5], axis=0) for k in seconds])
    first = medians[0]
    drift = np.linalg.norm(medians - first, axis=1)
    worst = int(np.argmax(drift))
    off = np.linalg.norm(grasper[:, 2:5] - medians[np.searchsorted(seconds, second)], axis=1)
    transients = grasper[off > 0.01 * np.linalg.norm(first), 0]
    held = bool(grasper[:, 5].all())
    summary = json.load(open(args.summary, encoding="utf-8"))
    tool = summary["tools"][0]
    samples = [json.loads(line) for line in open(args.progress, encoding="utf-8") if line.startswith("{")]
    memory = [s["resident_mib"] for s in samples]
    growth = (memory[-1] - memory[0]) / memory[0] if len(memory) >= 2 else 0.0
    loop, frames = summary["force_loop"], summary["deformation_loop"]

    print(f"held          {args.hold_until - args.hold_from:.0f} s, in contact throughout: {held}; "
          f"grasps {tool['grasps']}, slips {tool['grasp_slips']}")
    print(f"grasper force {np.linalg.norm(first) * 1e3:.2f} mN in the first second; largest drift of a second's "
          f"force {drift.max() * 1e3:.4f} mN ({100 * drift.max() / np.linalg.norm(first):.3f} %) at "
          f"{args.hold_from + seconds[worst]:.0f} s; {len(transients)} tick(s) more than 1 % off their second's force"
          + (f" (first at {transients[0]:.3f} s)" if len(transients) else ""))
    print(f"memory        {memory[0] if memory else float('nan'):.1f} -> {memory[-1] if memory else float('nan'):.1f} "
          f"MiB over {len(memory)} samples ({100 * growth:+.2f} %)")
    print(f"force loop    {loop['ticks']} ticks, period p50 {loop['period']['p50_ms']:.3f} ms, p99 "
          f"{loop['period']['p99_ms']:.3f} ms, max {loop['period']['max_ms']:.3f} ms, "
          f"{loop['deadline_misses']} deadline misses")
    print(f"frames        {frames['frames']} computed, {frames['dropped']} dropped, compute p50 "
          f"{frames['compute']['p50_ms']:.2f} ms, p99 {frames['compute']['p99_ms']:.2f} ms, "
          f"max {frames['compute']['max_ms']:.2f} ms")
    failed = []
    if not held:
        failed.append("the grasp let go while held")
    if tool["grasps"] < 1 or tool["grasp_slips"] > 0:
        failed.append("the grasp did not hold (no grasp, or a slip)")
    if drift.max() > 0.01 * np.linalg.norm(first):
        failed.append("the grasper's force drifted by more than 1 %")
    if growth > 0.01:
        failed.append("the resident memory grew by more than 1 %")
    for reason in failed:
        print(f"FAILED: {reason}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
