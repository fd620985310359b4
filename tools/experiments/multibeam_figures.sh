#!/usr/bin/env bash
# The multi-beam paper's Figs. 5 and 8 on the shipped liver (shown in
# docs/multibeam.md): two tools 38 mm apart on the anterior surface pull apart
# by 8 mm each (and 4 mm outward). With superposition of the beams' fields
# (eq. 5, --merge sum) each action point is dragged by the other tool's field
# (Fig. 5); with the influence function (eq. 7) each follows its own tool
# exactly (Fig. 8). Prints what each action point did; writes
# OUT_DIR/liver_fig5_superposition.png and OUT_DIR/liver_fig8_influence.png
# (default docs/images).
#
# Usage: bash tools/experiments/multibeam_figures.sh [OUT_DIR]
# Needs build/tools/organsim and xvfb-run. About 30 s on 2 cores (most of it the bake).
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
organsim=${ORGANSIM:-$repo/build/tools/organsim}
out_dir=${1:-$repo/docs/images}
[[ -x $organsim ]] || { echo "multibeam_figures.sh: $organsim is missing: ninja -C build organsim" >&2; exit 1; }
command -v xvfb-run >/dev/null || { echo "multibeam_figures.sh: xvfb-run is missing (apt-get install xvfb xauth)" >&2; exit 1; }
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
mkdir -p "$out_dir"

samples=$repo/data_samples/real_ct_totalseg
"$organsim" bake "$samples/example_ct.nii.gz" --label "$samples/liver_mask_ct.nii.gz" -o "$work/liver.organ" --quiet >/dev/null
tools=(--tool -7.1,-252.0,356.2/8,-4,0 --tool -44.57,-256.77,368.31/-8,-4,0)
for merge in sum influence; do
  [[ $merge == sum ]] && name=liver_fig5_superposition || name=liver_fig8_influence
  echo "## --merge $merge ($name.png)"
  xvfb-run -a -s "-screen 0 1280x1024x24" "$organsim" poke "$work/liver.organ" "${tools[@]}" --merge "$merge" \
    --png "$out_dir/$name.png" | grep -E "^tool|action point moved"
done
