// Model-file speed: loading (read + verify + decode + validate) and writing a
// model with a 100k-vertex simulation surface and 20-station beam tables.
#include <benchmark/benchmark.h>

#include "machine_limits.h"

#include <cstdio>
#include <filesystem>

#include "organsim/model/model_file.h"
#include "organsim/organ/organ.h"
#include "test_models.h"

namespace {

const organsim::model::OrganModel& large_model() {
  static const organsim::model::OrganModel model = organsim::testing::make_sphere_model(100000, 20);
  return model;
}

std::string large_model_file() {
  static const std::string path = [] {
    const std::string p = (std::filesystem::temp_directory_path() / "organsim_bench_100k.organ").string();
    organsim::model::write_organ_model_file(large_model(), p);
    return p;
  }();
  return path;
}

void BM_LoadModelFile100k(benchmark::State& state) {
  const std::string path = large_model_file();
  for (auto _ : state) {
    organsim::model::ModelReadResult r = organsim::model::read_organ_model_file(path);
    if (!r) state.SkipWithError(r.error.c_str());
    benchmark::DoNotOptimize(r.model->surface_vertices.data());
  }
  state.counters["vertices"] = static_cast<double>(large_model().surface_vertices.size());
  state.counters["file_MB"] = static_cast<double>(std::filesystem::file_size(path)) / 1e6;
  // The limit: copying the file once in memory (read it, write the model).
  state.counters["x_memory_limit"] =
      organsim::bench::times_memory_limit(2.0 * static_cast<double>(std::filesystem::file_size(path)));
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * std::filesystem::file_size(path)));
}
BENCHMARK(BM_LoadModelFile100k)->Unit(benchmark::kMillisecond);

// What a simulating program waits for: the file read and the multi-beam
// model's own layout (vertices along a Morton curve, their rings).
void BM_LoadAndPrepareOrgan100k(benchmark::State& state) {
  const std::string path = large_model_file();
  for (auto _ : state) {
    organsim::model::ModelReadResult r = organsim::model::read_organ_model_file(path);
    if (!r) state.SkipWithError(r.error.c_str());
    const organsim::organ::Organ organ(std::move(*r.model));
    benchmark::DoNotOptimize(organ.vertex_count());
  }
  state.counters["x_memory_limit"] =
      organsim::bench::times_memory_limit(2.0 * static_cast<double>(std::filesystem::file_size(path)));
}
BENCHMARK(BM_LoadAndPrepareOrgan100k)->Unit(benchmark::kMillisecond);

void BM_ParseInMemory100k(benchmark::State& state) {
  const std::vector<std::uint8_t> bytes = organsim::model::serialize_organ_model(large_model());
  for (auto _ : state) {
    organsim::model::ModelReadResult r = organsim::model::parse_organ_model(bytes.data(), bytes.size(), "bench");
    benchmark::DoNotOptimize(r.model->surface_vertices.data());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations() * bytes.size()));
}
BENCHMARK(BM_ParseInMemory100k)->Unit(benchmark::kMillisecond);

void BM_WriteModelFile100k(benchmark::State& state) {
  const std::string path = (std::filesystem::temp_directory_path() / "organsim_bench_write.organ").string();
  for (auto _ : state) organsim::model::write_organ_model_file(large_model(), path);
  std::filesystem::remove(path);
}
BENCHMARK(BM_WriteModelFile100k)->Unit(benchmark::kMillisecond);

}  // namespace

ORGANSIM_BENCHMARK_MAIN();
