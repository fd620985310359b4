#!/usr/bin/env bash
# Soak test of a held grasp: a grasper lifts the edge of a lobe of the liver
# baked from the shipped CT 20 mm and holds it for MINUTES while a probe presses
# beside it once (tools/sessions/retract_and_probe.py --hold), replayed in real
# time with one deformation model. Checks that the held grasp is stable: the
# grasper's force does not drift while it holds (the organ's elastic energy and
# the held patch stay where they were), the organ's resident memory stays flat,
# and the grasp never slips; reports the loops' figures with the CPU.
#
#   tools/scripts/soak_held_grasp.sh MINUTES [MODEL] [BUILD_DIR]     (MODEL: corotational by default)
#
# Exits non-zero when the replay fails, the grasp slips or lets go, the force
# drifts by more than 1 % of its value, or the resident memory grows by more
# than 1 % between the first and last samples (tools/sessions/held_grasp_drift.py).
set -euo pipefail
minutes=${1:?usage: tools/scripts/soak_held_grasp.sh MINUTES [MODEL] [BUILD_DIR]}
model=${2:-corotational}
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
build=$(cd "${3:-$repo/build}" && pwd)
organsim=$build/tools/organsim
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
hold=$(awk -v m="$minutes" 'BEGIN { print m * 60 }')

echo "held-grasp soak: $minutes min, $model model, on $(grep -m1 'model name' /proc/cpuinfo | cut -d: -f2 | sed 's/^ //'), $(nproc) CPUs"
"$organsim" bake "$repo/data_samples/real_ct_totalseg/example_ct.nii.gz" \
  --label "$repo/data_samples/real_ct_totalseg/liver_mask_ct.nii.gz" -o "$work/liver.organ" --quiet >/dev/null
PYTHONPATH="$build/python" /usr/bin/python3 "$repo/tools/sessions/retract_and_probe.py" "$work/liver.organ" \
  -o "$work/held.session" --hold "$hold"
"$organsim" replay "$work/liver.organ" "$work/held.session" --model "$model" --forces "$work/forces.csv" \
  --progress 60 --json >"$work/summary.json" 2>"$work/progress.jsonl"
/usr/bin/python3 "$repo/tools/sessions/held_grasp_drift.py" "$work/forces.csv" "$work/progress.jsonl" "$work/summary.json" \
  --hold-from 7 --hold-until "$(awk -v h="$hold" 'BEGIN { print 1.9 + h - 0.5 }')"
