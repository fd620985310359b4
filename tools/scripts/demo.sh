#!/usr/bin/env bash
# README command (a): set up, build, and run the main job on the shipped sample:
# a real CT with its liver label map -> organsim bake (and again from one seed,
# no label map) -> the model's summary ->
# a static two-tool press (organsim poke), multi-beam and then the
# pressure-stabilized hyperelastic FEM with its difference from the beams ->
# a replayed two-tool session in real time (organsim replay) with forces and
# loop timings, through the multi-beam, mass-spring and FEM models side by side.
set -euo pipefail
repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
bash "$repo/tools/scripts/setup.sh"
build=${ORGANSIM_BUILD_DIR:-$repo/build}
out=${ORGANSIM_DEMO_DIR:-$repo/demo_output}
sample=$repo/data_samples/real_ct_totalseg
mkdir -p "$out"

echo "== organsim bake: real abdominal CT (TotalSegmentator sample, CC BY 4.0) + its liver label map"
"$build/tools/organsim" bake "$sample/example_ct.nii.gz" --label "$sample/liver_mask_ct.nii.gz" \
  -o "$out/liver.organ" --intermediates "$out/liver_intermediates"
echo
echo "== organsim bake: the same real CT from one seed, no label map (Dice against the label map printed)"
"$build/tools/organsim" bake "$sample/example_ct.nii.gz" --seed-voxel 86,47,108 \
  --reference "$sample/liver_mask_ct.nii.gz" -o "$out/liver_from_seed.organ"
echo
echo "== organsim bake: the synthetic phantom from a seed, clamped at the portal vein entry"
"$build/tools/organsim" bake "$repo/data_samples/phantom_ct.nii.gz" --seed -65,5,0 \
  --fixed-point -29.76,16.10,-70.96 -o "$out/phantom_liver.organ"
echo
echo "== organsim info: what the baked model holds"
"$build/tools/organsim" info "$out/liver.organ" --beam 0
echo
echo "== organsim poke: two tools press the baked liver (multi-beam model): forces and deformation"
"$build/tools/organsim" poke "$out/liver.organ" --tool -7.1,-252.0,356.2/0.28,-4.46,2.24 --tool -99.4,-217.0,387.9/3.29,1.61,1.62 \
  --out "$out/liver_poked.vtp"
echo
echo "== organsim poke --model psh --compare beam: the same presses through the pressure-stabilized Mooney-Rivlin FEM"
echo "   (Ogata et al.; Newton to equilibrium on the model's tetrahedra) and how far the multi-beam model is from it"
"$build/tools/organsim" poke "$out/liver.organ" --tool -7.1,-252.0,356.2/0.28,-4.46,2.24 --tool -99.4,-217.0,387.9/3.29,1.61,1.62 \
  --model psh --compare beam
echo
echo "== organsim replay: a recorded two-tool session through the real-time engine (1 kHz forces, 60 Hz deformation)"
"$build/tools/organsim" replay "$out/liver.organ" "$repo/data_samples/liver_two_tools.session" \
  --forces "$out/liver_two_tools_forces.csv"
echo
echo "== organsim replay --model beam,springs,corotational,psh: the same session through the multi-beam, mass-spring,"
echo "   co-rotational FEM and pressure-stabilized FEM models"
"$build/tools/organsim" replay "$out/liver.organ" "$repo/data_samples/liver_two_tools.session" \
  --model beam,springs,corotational,psh
echo
echo "== organsim replay: two hands on the liver: a grasper lifts the edge of a lobe 20 mm and holds it while a probe"
echo "   presses beside it, then both let go (multi-beam, mass-spring and co-rotational FEM models)"
"$build/tools/organsim" replay "$out/liver.organ" "$repo/data_samples/liver_retract_and_probe.session" \
  --model beam,springs,corotational
echo
echo "== organsim compare: the same presses with every model, each against the PSH FEM (Ogata et al.'s Table 5 measure)"
"$build/tools/organsim" compare "$out/liver.organ" --tool -7.1,-252.0,356.2/0.28,-4.46,2.24 --tool -99.4,-217.0,387.9/3.29,1.61,1.62
echo
echo "Outputs in $out (models; mask, surface and tetrahedra for 3D Slicer / ParaView in liver_intermediates/)."
