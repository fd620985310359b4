// Seeded segmentation speed: `organsim segment`'s work
// on the shipped real CT (122×101×112 at 3 mm) and on a 512×512×200 phantom at
// 0.8 mm, with the time of each step as counters. Goal: ≤ 5 s for the
// 512×512×200 volume on the 2-core CI machine.
#include <benchmark/benchmark.h>

#include "machine_limits.h"

#include <filesystem>
#include <map>
#include <string>

#include "organsim/pipeline/ct_input.h"
#include "organsim/pipeline/phantom.h"
#include "organsim/pipeline/seeded_segmentation.h"

namespace {

using organsim::pipeline::CtImage;
using organsim::pipeline::SeededSegmentationOptions;
using organsim::pipeline::SeedPoint;

void run(benchmark::State& state, const CtImage& ct, const SeededSegmentationOptions& options) {
  std::map<std::string, double> steps;
  double volume_ml = 0.0;
  for (auto _ : state) {
    const auto result = organsim::pipeline::segment_from_seeds(ct, options);
    for (const auto& [step, seconds] : result.report.step_seconds) steps[step] += seconds;
    volume_ml = result.report.volume_ml;
  }
  for (const auto& [step, seconds] : steps)
    state.counters[step + " s"] = seconds / static_cast<double>(state.iterations());
  state.counters["organ mL"] = volume_ml;
  const auto size = ct.GetLargestPossibleRegion().GetSize();
  state.counters["voxels"] = static_cast<double>(size[0] * size[1] * size[2]);
}

void BM_SegmentShippedRealCt(benchmark::State& state) {
  static const CtImage::Pointer ct = organsim::pipeline::read_ct(
      (std::filesystem::path(ORGANSIM_DATA_SAMPLES) / "real_ct_totalseg" / "example_ct.nii.gz").string());
  SeededSegmentationOptions options;
  options.seeds = {SeedPoint::at_voxel({86, 47, 108})};
  run(state, *ct, options);
}
BENCHMARK(BM_SegmentShippedRealCt)->Unit(benchmark::kSecond)->Iterations(3)->UseRealTime();

void BM_SegmentPhantom512x512x200(benchmark::State& state) {
  static const CtImage::Pointer ct = [] {
    organsim::pipeline::PhantomOptions options;
    options.size = {512, 512, 200};
    options.spacing_mm = {0.8, 0.8, 0.8};
    return organsim::pipeline::make_phantom(options).ct;
  }();
  // The right-lobe seed of the 3 mm phantom, scaled as the anatomy is to this field of view.
  const double scale = 0.8 * 200 / 192.0;
  SeededSegmentationOptions options;
  options.seeds = {SeedPoint::at_mm({-65.0 * scale, 5.0 * scale, 0.0})};
  run(state, *ct, options);
}
BENCHMARK(BM_SegmentPhantom512x512x200)->Unit(benchmark::kSecond)->Iterations(2)->UseRealTime();

}  // namespace

ORGANSIM_BENCHMARK_MAIN();
