// End-to-end pipeline speed: a 512×512×200 phantom CT at
// 0.8 mm, baked to a ~5k-vertex surface (≤ 30k tetrahedra, 20-station beams),
// with the time of every stage as a counter, plus writing the model file.
#include <benchmark/benchmark.h>

#include "machine_limits.h"

#include <chrono>
#include <filesystem>

#include "organsim/model/model_file.h"
#include "organsim/pipeline/bake.h"
#include "organsim/pipeline/image_io.h"
#include "organsim/pipeline/phantom.h"

namespace {

namespace fs = std::filesystem;

struct BigPhantom {
  std::string ct_path;
  std::array<double, 3> seed_mm;
};

const BigPhantom& big_phantom() {
  static const BigPhantom phantom = [] {
    organsim::pipeline::PhantomOptions options;
    options.size = {512, 512, 200};
    options.spacing_mm = {0.8, 0.8, 0.8};
    const organsim::pipeline::Phantom p = organsim::pipeline::make_phantom(options);
    BigPhantom big;
    big.ct_path = (fs::temp_directory_path() / "organsim_bench_phantom_512.nii.gz").string();
    organsim::pipeline::write_ct_image(*p.ct, big.ct_path);
    // The anatomy is scaled to the field of view (here by 160/192 along z):
    // the right-lobe seed of the 3 mm phantom, scaled the same way.
    const double scale = 0.8 * 200 / 192.0;
    big.seed_mm = {-65.0 * scale, 5.0 * scale, 0.0};
    return big;
  }();
  return phantom;
}

void BM_BakePhantom512x512x200(benchmark::State& state) {
  const BigPhantom& phantom = big_phantom();
  organsim::pipeline::BakeOptions options;
  options.ct_path = phantom.ct_path;
  options.seeded.seeds = {organsim::pipeline::SeedPoint::at_mm(phantom.seed_mm)};
  options.surface.target_vertices = 5000;
  options.program_version = "bench";
  const std::string model_path = (fs::temp_directory_path() / "organsim_bench_phantom_512.organ").string();
  organsim::pipeline::BakeReport report;
  double write_seconds = 0.0;
  for (auto _ : state) {
    const organsim::pipeline::BakeResult result = organsim::pipeline::bake(options);
    const auto start = std::chrono::steady_clock::now();
    organsim::model::write_organ_model_file(result.model, model_path);
    write_seconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    report = result.report;
  }
  for (const auto& [stage, seconds] : report.stage_seconds) state.counters[stage + " s"] = seconds;
  state.counters["write s"] = write_seconds / static_cast<double>(state.iterations());
  state.counters["surface vertices"] = static_cast<double>(report.surface_vertices);
  state.counters["tetrahedra"] = static_cast<double>(report.tetrahedra.tetrahedra);
  state.counters["min dihedral deg"] = report.tetrahedra.min_dihedral_deg;
  state.counters["mask mL"] = report.mask_volume_ml;
  state.counters["tet mL"] = report.tetrahedra_volume_ml;
  fs::remove(model_path);
}
BENCHMARK(BM_BakePhantom512x512x200)->Unit(benchmark::kSecond)->Iterations(2)->UseRealTime();

}  // namespace

ORGANSIM_BENCHMARK_MAIN();
