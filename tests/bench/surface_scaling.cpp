// How the runtime's cost grows with the organ's surface (docs/performance.md):
// test spheres of 3k to 1M vertices with 20-station beam tables. Per size: the
// model file's load until the organ is ready to simulate, the multi-beam
// deformation of a frame (distortion and normals, one thread) with 1 and 8
// tools, the normals alone, and the engine's force tick with one tool, which
// should not grow with the surface. Counters: the file's size and the heap
// the organ holds once loaded.
#include <malloc.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "machine_limits.h"
#include "organsim/devices/scripted_device.h"
#include "organsim/model/model_file.h"
#include "organsim/multibeam/multibeam.h"
#include "organsim/organ/organ.h"
#include "organsim/realtime/engine.h"
#include "test_models.h"

namespace {

using namespace organsim;

constexpr double kRadius = 0.08;  // the test sphere's radius, m
constexpr int kStations = 20;

/// Heap bytes in use, large blocks mapped on their own included (freed blocks
/// the allocator keeps are not counted), MB.
double heap_in_use_mb() {
  const struct mallinfo2 heap = ::mallinfo2();
  return static_cast<double>(heap.uordblks + heap.hblkhd) / 1e6;
}

/// The model file of a size, in the temporary folder (this process's own).
std::string scratch_name(std::size_t vertices) {
  return "organsim_surface_scaling_" + std::to_string(::getpid()) + "_" + std::to_string(vertices) + ".organ";
}

/// A sphere of about `vertices` vertices: its model file (written once, in
/// the temporary folder), the organ read from it, and the memory it took.
struct Sized {
  std::string path;
  double file_mb = 0.0;
  double organ_mb = 0.0;
  std::unique_ptr<organ::Organ> organ;
};

Sized& sized(std::size_t vertices) {
  static std::map<std::size_t, Sized> cache;
  Sized& s = cache[vertices];
  if (s.organ) return s;
  s.path = (std::filesystem::temp_directory_path() / (scratch_name(vertices))).string();
  model::write_organ_model_file(testing::make_sphere_model(vertices, kStations), s.path);
  s.file_mb = static_cast<double>(std::filesystem::file_size(s.path)) / 1e6;
  const double before = heap_in_use_mb();
  model::ModelReadResult read = model::read_organ_model_file(s.path);
  if (!read) throw std::runtime_error(read.error);
  s.organ = std::make_unique<organ::Organ>(std::move(*read.model));
  s.organ_mb = heap_in_use_mb() - before;
  return s;
}

// The tool presses 5 mm in at the sphere's pole.
const Eigen::Vector3d kPole(0.0, 0.0, kRadius);

void BM_LoadReadyToSimulate(benchmark::State& state) {
  Sized& s = sized(static_cast<std::size_t>(state.range(0)));
  for (auto _ : state) {
    model::ModelReadResult read = model::read_organ_model_file(s.path);
    if (!read) {
      state.SkipWithError(read.error.c_str());
      break;
    }
    const organ::Organ organ(std::move(*read.model));
    benchmark::DoNotOptimize(organ.vertex_count());
  }
  state.counters["vertices"] = static_cast<double>(s.organ->vertex_count());
  state.counters["file_MB"] = s.file_mb;
  state.counters["organ_MB"] = s.organ_mb;
}

void BM_Deformation(benchmark::State& state) {
  const organ::Organ& o = *sized(static_cast<std::size_t>(state.range(0))).organ;
  const int tools = static_cast<int>(state.range(1));
  multibeam::MultiBeamOptions options;
  options.max_tools = static_cast<std::uint32_t>(tools);
  multibeam::MultiBeam beams(o, options);
  std::vector<Eigen::Vector3d> displacements;
  for (int k = 0; k < tools; ++k) {
    // Tools spread over the sphere (a Fibonacci lattice), pressed 5 mm in.
    const double z = 1.0 - (2.0 * k + 1.0) / tools, azimuth = k * M_PI * (3.0 - std::sqrt(5.0));
    const Eigen::Vector3d p = kRadius * Eigen::Vector3d(std::sqrt(1 - z * z) * std::cos(azimuth),
                                                        std::sqrt(1 - z * z) * std::sin(azimuth), z);
    if (beams.attach(k, p) != multibeam::Status::ok) state.SkipWithError("attach failed");
    displacements.push_back(-0.005 * p.normalized());
  }
  const std::size_t n = o.vertex_count();
  std::vector<model::Point3> positions(n), normals(n);
  for (auto _ : state) {
    beams.deform(displacements.data(), positions.data(), normals.data(), n);
    benchmark::ClobberMemory();
  }
  state.counters["vertices"] = static_cast<double>(n);
}

void BM_Normals(benchmark::State& state) {
  const organ::Organ& o = *sized(static_cast<std::size_t>(state.range(0))).organ;
  const multibeam::MultiBeam beams(o, {});
  std::vector<model::Point3> normals(o.vertex_count());
  for (auto _ : state) {
    beams.normals(0, o.vertex_count(), normals.data());
    benchmark::ClobberMemory();
  }
  state.counters["vertices"] = static_cast<double>(o.vertex_count());
}

void BM_ForceTick(benchmark::State& state) {
  const organ::Organ& o = *sized(static_cast<std::size_t>(state.range(0))).organ;
  devices::Trajectory press;
  press.times = {0.0, 0.1};
  press.positions = {kPole * (1.0 + 0.01 / kRadius), kPole * (1.0 - 0.005 / kRadius)};
  devices::ScriptedDevice device(press, devices::SafetyLimits{}, 1024);
  std::vector<devices::HapticDevice*> tools{&device};
  realtime::Engine engine(o, tools, {});
  double time = 0.0;
  for (int tick = 0; tick < 200; ++tick, time += 1e-3) {  // the contact established
    if (tick % 16 == 0) engine.deformation_step(time);
    engine.force_tick(time);
  }
  if (!engine.telemetry(0).in_contact) state.SkipWithError("the tool is not in contact");
  engine.deformation_step(time);
  for (auto _ : state) engine.force_tick(time);
  state.counters["vertices"] = static_cast<double>(o.vertex_count());
}

// The sizes: ORGANSIM_SCALING_SIZES (comma-separated vertex counts) or 3k to 1M.
std::vector<std::int64_t> sizes() {
  std::vector<std::int64_t> out;
  const char* given = std::getenv("ORGANSIM_SCALING_SIZES");
  std::string text = given ? given : "3000,30000,100000,300000,1000000";
  for (std::size_t start = 0; start < text.size();) {
    const std::size_t comma = std::min(text.find(',', start), text.size());
    out.push_back(std::stoll(text.substr(start, comma - start)));
    start = comma + 1;
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  organsim::bench::add_machine_context();
  const std::vector<std::int64_t> vertices = sizes();
  benchmark::RegisterBenchmark("Load", BM_LoadReadyToSimulate)->ArgsProduct({vertices})->Unit(benchmark::kMillisecond);
  benchmark::RegisterBenchmark("Deformation", BM_Deformation)
      ->ArgNames({"vertices", "tools"})
      ->ArgsProduct({vertices, {1, 8}})
      ->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark("Normals", BM_Normals)->ArgsProduct({vertices})->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark("ForceTick", BM_ForceTick)->ArgsProduct({vertices})->Unit(benchmark::kMicrosecond);
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  for (const std::int64_t n : vertices)
    std::remove((std::filesystem::temp_directory_path() / (scratch_name(static_cast<std::size_t>(n)))).c_str());
  return 0;
}
