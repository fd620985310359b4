#!/usr/bin/env bash
# Soak test: a looping two-tool session replayed in real time through every
# deformation model, sampling resident memory and the loops' statistics at
# intervals, next to the machine's own floor (build/tests/cpu_stalls) measured
# in the same run.
#
#   tools/scripts/soak.sh MINUTES [BUILD_DIR]
#
# The multi-beam and mass-spring models run on a 100k-vertex organ (the test
# sphere); the FEM models (linear, corotational, stvk, psh) on the liver baked
# from the shipped CT, whose tetrahedra they solve (the sphere's fan of
# tetrahedra around its centre has no clamp for them). Each model gets a sixth
# of the time: a fifth of it measuring the floor, the rest replaying.
# Exits non-zero when a replay fails or a model's resident memory grows by more
# than 1 % between its first and last samples; reports the force loop's
# deadline misses against the floor (a CPU stall of more than 1 ms costs the
# loop a deadline: its period is 1 ms, its deadline 2 ms).
set -euo pipefail
minutes=${1:?usage: tools/scripts/soak.sh MINUTES [BUILD_DIR]}
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=$(cd "${2:-$repo/build}" && pwd)
organsim=$build/tools/organsim
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

echo "soak: $minutes min on $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) CPUs"
"$build/tests/organsim-test-model" sphere --vertices 100000 -o "$work/sphere.organ" >/dev/null
"$organsim" bake "$repo/data_samples/real_ct_totalseg/example_ct.nii.gz" \
  --label "$repo/data_samples/real_ct_totalseg/liver_mask_ct.nii.gz" -o "$work/liver.organ" --quiet >/dev/null

# Two tools press 5 mm in and come back out every 2 s (the session repeats).
cat >"$work/sphere.session" <<'EOF'
# organsim session 1
0,1,90,0,0
1,1,75,0,0
1.5,1,75,0,0
2,1,90,0,0
0,2,0,90,0
1,2,0,75,3
1.5,2,0,75,3
2,2,0,90,0
EOF
# The README's two liver presses (docs/cli.md), from 10 mm outside.
cat >"$work/liver.session" <<'EOF'
# organsim session 1
0,1,-7.1,-262.0,356.2
1,1,-7.1,-247.0,356.2
1.5,1,-7.1,-247.0,356.2
2,1,-7.1,-262.0,356.2
0,2,-89.4,-217.0,387.9
1,2,-103.4,-217.0,387.9
1.5,2,-103.4,-217.0,387.9
2,2,-89.4,-217.0,387.9
EOF

total=$((minutes * 60))
segment=$((total / 6))
floor_seconds=$((segment / 5 > 1 ? segment / 5 : 1))
replay_seconds=$((segment - floor_seconds))
interval=$((replay_seconds / 4 < 60 ? replay_seconds / 4 : 60))
interval=$((interval > 1 ? interval : 1))
status=0
for model in beam springs linear corotational stvk psh; do
  organ=liver
  case $model in beam | springs) organ=sphere ;; esac
  "$build/tests/cpu_stalls" "$floor_seconds" >"$work/floor_$model.txt"
  if ! "$organsim" replay "$work/$organ.organ" "$work/$organ.session" --model "$model" --repeat-for "$replay_seconds" \
    --progress "$interval" --json >"$work/summary_$model.json" 2>"$work/progress_$model.txt"; then
    echo "soak: $model: replay failed: $(tail -n 1 "$work/progress_$model.txt")"
    status=1
    continue
  fi
  /usr/bin/python3 - "$model" "$organ" "$work" "$floor_seconds" <<'PY' || status=1
import json, re, sys
model, organ, work, floor_seconds = sys.argv[1], sys.argv[2], sys.argv[3], float(sys.argv[4])
samples = [json.loads(line) for line in open(f"{work}/progress_{model}.txt") if line.startswith("{")]
summary = json.load(open(f"{work}/summary_{model}.json"))
floor = open(f"{work}/floor_{model}.txt").read()
gaps = int(re.search(r"> 1 ms (\d+)", floor).group(1))
late = int(re.search(r"later than 0.3 ms \d+, 1 ms (\d+)", floor).group(1))
floor_per_minute = (gaps + late) * 60.0 / floor_seconds
print(f"{model} on the {organ}: floor {gaps + late} CPU losses > 1 ms in {floor_seconds:.0f} s "
      f"({floor_per_minute:.1f}/min; {floor.splitlines()[0].split(': ')[-1]})")
print(f"  {'t (s)':>7} {'RSS MiB':>8} {'ticks':>7} {'p50 ms':>7} {'p99 ms':>7} {'max ms':>7} {'misses':>6} {'frames':>6}")
for s in samples:
    p = s["force_period"]
    print(f"  {s['progress_s']:7.0f} {s['resident_mib']:8.1f} {s['force_ticks']:7d} {p['p50_ms']:7.3f} "
          f"{p['p99_ms']:7.3f} {p['max_ms']:7.3f} {s['deadline_misses']:6d} {s['frames']:6d}")
loop = summary["force_loop"]
minutes = summary["duration_s"] / 60.0
misses_per_minute = loop["deadline_misses"] / minutes
print(f"  whole run: {loop['ticks']} ticks, period p50 {loop['period']['p50_ms']:.3f} ms, p99 {loop['period']['p99_ms']:.3f} ms, "
      f"max {loop['period']['max_ms']:.3f} ms; {loop['deadline_misses']} misses ({misses_per_minute:.1f}/min, "
      f"floor {floor_per_minute:.1f}/min); {summary['deformation_loop']['frames']} frames; "
      f"real-time priority {'yes' if loop['realtime_priority'] else 'no'}")
if summary["wall_s"] > 1.2 * summary["duration_s"] + 2.0:
    sys.exit(f"  {model}: the run took {summary['wall_s']:.0f} s of wall time for {summary['duration_s']:.0f} s: the loops fell behind")
if len(samples) < 2:
    sys.exit(f"  {model}: fewer than two memory samples")
first, last = samples[0]["resident_mib"], samples[-1]["resident_mib"]
growth = (last - first) / first * 100.0
verdict = "flat" if abs(growth) <= 1.0 else "GROWING"
print(f"  memory {first:.1f} -> {last:.1f} MiB ({growth:+.2f} %): {verdict}; misses "
      f"{'within' if misses_per_minute <= 2 * floor_per_minute + 1 else 'ABOVE'} the floor")
sys.exit(0 if verdict == "flat" else 1)
PY
done
exit $status
