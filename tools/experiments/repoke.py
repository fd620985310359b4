#!/usr/bin/env python3
"""Re-press a model's fast models at the presses of an earlier evaluation.

`organsim calibrate MODEL --evaluate --json` keeps every press's tool and the
reference's force (which does not depend on the fast models). This presses the
fast models of MODEL (another bake or calibration of the same organ) at those
tools with `organsim poke` and prints their force factor and direction error
against the kept reference forces, per press and per depth: a fast model's change
measured in seconds instead of the evaluation's hours (docs/matching.md). For new
evaluations `calibrate --evaluate --reference-cache DIR` does the same and more
(the surface difference too). The presses use the evaluation's tip radius; the
mass-spring model is held for `poke`'s settling time, which is the evaluation's
for a model whose springs are not softened by a calibration.

    python3 tools/experiments/repoke.py build/tools/organsim liver.organ evaluation.json --models beam,springs
"""
import argparse
import json
import math
import subprocess


def press(organsim, model, fast_model, tool, tip_radius_mm):
    """The fast model's force (N) at the tool, or None where poke failed or gave none."""
    run = subprocess.run([organsim, 'poke', model, '--model', fast_model, '--tool', tool,
                          '--tip-radius', repr(tip_radius_mm), '--json'], capture_output=True, text=True)
    if run.returncode != 0:
        return None
    force = json.loads(run.stdout)['tools'][0]['force_n']
    return force if math.hypot(*force) > 0 else None


def angle_deg(a, b):
    cos = sum(x * y for x, y in zip(a, b)) / (math.hypot(*a) * math.hypot(*b))
    return math.degrees(math.acos(max(-1.0, min(1.0, cos))))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('organsim', help='the organsim program')
    parser.add_argument('model', help='the model file whose fast models are pressed')
    parser.add_argument('evaluation', help="an earlier `calibrate --evaluate --json` output on the same organ")
    parser.add_argument('--models', default='beam,springs', help='fast models, comma-separated')
    args = parser.parse_args()
    evaluation = json.load(open(args.evaluation))
    presses = [p for p in evaluation['presses'] if p['reference_solved']]
    for fast_model in args.models.split(','):
        rows = []
        for p in presses:
            force = press(args.organsim, args.model, fast_model, p['tool'], evaluation['tip_radius_mm'])
            before = p[fast_model].get('force_ratio')
            if force is None or before is None:
                print('%s site %d %s %g mm: no force (now or in the evaluation), left out'
                      % (fast_model, p['site'], p['direction'], p['depth_mm']))
                continue
            reference = p['reference_force_n']
            rows.append((p['site'], p['direction'], p['depth_mm'], math.hypot(*force) / math.hypot(*reference),
                         before, angle_deg(force, reference)))
            print('%s site %d %-8s %4g mm: ratio %.3f (in the evaluation %.3f), direction %.1f deg'
                  % ((fast_model,) + rows[-1]))
        for depth in sorted({r[2] for r in rows}):
            at = [r for r in rows if r[2] == depth]
            factor = lambda k: math.exp(math.sqrt(sum(math.log(r[k]) ** 2 for r in at) / len(at)))
            print('%s %g mm: force factor %.3f (in the evaluation %.3f), direction at most %.1f deg over %d presses'
                  % (fast_model, depth, factor(3), factor(4), max(r[5] for r in at), len(at)))


if __name__ == '__main__':
    main()
