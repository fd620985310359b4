#!/usr/bin/env bash
# README command (a): set up, build, and run the main job on the shipped sample.
# For now: make a phantom CT, write a model with the test helpers, and print the
# model summary (later issues make this CT -> bake -> replayed session).
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bash "$repo/tools/setup.sh"
build=${ORGANSIM_BUILD_DIR:-$repo/build}
out=${ORGANSIM_DEMO_DIR:-$repo/demo_output}
mkdir -p "$out"

echo "== organsim phantom: synthetic abdominal CT with a liver-like organ"
"$build/tools/organsim" phantom -o "$out/phantom_ct.nii.gz" --mask "$out/phantom_liver_mask.nii.gz"
echo
echo "== model written by the test helpers (a cylinder with exact beam tables)"
"$build/tests/organsim-test-model" cylinder -o "$out/cylinder.organ"
"$build/tools/organsim" info "$out/cylinder.organ" --beam 300
