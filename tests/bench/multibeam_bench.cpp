// Multi-beam model speed: beam creation per contact, force per tool per haptic
// tick, and whole-organ distortion (normals included) for 2.4k- and
// 100k-vertex organs with 1–8 tools on one and two threads. When
// ORGANSIM_BENCH_MODEL names a baked model, ModelBeamCreation and
// ModelDeformation/tools:N measure the same on its surface (Ushiki et al.'s
// figures at their own scale: docs/multibeam.md), its tools at surface
// vertices spread along the vertex order, pressed 5 mm in along the normal.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <thread>

#include <benchmark/benchmark.h>

#include "machine_limits.h"

#include "organsim/model/model_file.h"
#include "organsim/multibeam/multibeam.h"
#include "test_models.h"

namespace {

using namespace organsim;
using namespace organsim::multibeam;

constexpr double kPi = 3.14159265358979323846;
constexpr double kRadius = 0.08;  // the test sphere's radius, m

const organ::Organ& organ(std::size_t vertices) {
  static const organ::Organ small(testing::make_sphere_model(2400, 20));
  static const organ::Organ large(testing::make_sphere_model(100000, 20));
  return vertices <= 2400 ? small : large;
}

// Tool points spread over the sphere (a Fibonacci lattice), pressed inwards 5 mm.
Eigen::Vector3d tool_point(int i, int count) {
  const double z = 1.0 - (2.0 * i + 1.0) / count;
  const double azimuth = i * kPi * (3.0 - std::sqrt(5.0));
  const double r = std::sqrt(1.0 - z * z);
  return kRadius * Eigen::Vector3d(r * std::cos(azimuth), r * std::sin(azimuth), z);
}

std::unique_ptr<MultiBeam> attached(const organ::Organ& o, int tools, std::vector<Eigen::Vector3d>& displacements) {
  MultiBeamOptions options;
  options.max_tools = static_cast<std::uint32_t>(tools);
  auto beams = std::make_unique<MultiBeam>(o, options);
  displacements.clear();
  for (int i = 0; i < tools; ++i) {
    // The first `tools` of one set of eight points, so that each further tool
    // adds a tool and changes none of the others (each tool's cost depends on
    // how its beam crosses the vertex order).
    const Eigen::Vector3d p = tool_point(i, std::max(tools, 8));
    if (beams->attach(i, p) != Status::ok) throw std::runtime_error("attach failed");
    displacements.push_back(-0.005 * p.normalized());
  }
  return beams;
}

void BM_BeamCreation(benchmark::State& state) {
  const organ::Organ& o = organ(2400);
  MultiBeam beams(o, {});
  int i = 0;
  for (auto _ : state) {
    const Status s = beams.attach(0, tool_point(i++ % 64, 64));
    benchmark::DoNotOptimize(s);
  }
  state.counters["elements"] = beams.stations();
}
BENCHMARK(BM_BeamCreation)->Unit(benchmark::kMicrosecond);

void BM_ForcePerTool(benchmark::State& state) {
  const int tools = static_cast<int>(state.range(0));
  std::vector<Eigen::Vector3d> displacements;
  const auto beams = attached(organ(2400), tools, displacements);
  Eigen::Vector3d force;
  for (auto _ : state)
    for (int i = 0; i < tools; ++i) {
      beams->force(i, displacements[i], force);
      benchmark::DoNotOptimize(force);
    }
  state.SetItemsProcessed(state.iterations() * tools);  // items = tool forces
  // F = -K d: a 3×3 matrix times a vector, 15 flops per tool.
  state.counters["x_arithmetic_limit"] = organsim::bench::times_arithmetic_limit(15.0 * tools);
}
BENCHMARK(BM_ForcePerTool)->Arg(1)->Arg(4)->Arg(8)->Unit(benchmark::kNanosecond);

// This shared VM's speed drifts by tens of percent over seconds; with
// --benchmark_repetitions=N --benchmark_enable_random_interleaving=true the
// minimum over the repetitions is the steadiest estimate of the cost.
double minimum(const std::vector<double>& values) { return *std::min_element(values.begin(), values.end()); }

// The frame's normals: MultiBeam::normals() on the single-precision points
// its distort() kept (here the rest shape).
void BM_Normals(benchmark::State& state) {
  const organ::Organ& o = organ(static_cast<std::size_t>(state.range(0)));
  const MultiBeam beams(o, {});
  std::vector<model::Point3> normals(o.vertex_count());
  for (auto _ : state) {
    beams.normals(0, o.vertex_count(), normals.data());
    benchmark::ClobberMemory();
  }
  // At least: each vertex's point, ring (six neighbours) and offset in, its
  // normal out (16 + 24 + 4 + 24 = 68 bytes); six edge cross products, their
  // sum and a normalization (about 100 flops).
  const auto n = static_cast<double>(o.vertex_count());
  state.counters["x_memory_limit"] = organsim::bench::times_memory_limit(68.0 * n);
  state.counters["x_arithmetic_limit"] = organsim::bench::times_arithmetic_limit(100.0 * n);
}
BENCHMARK(BM_Normals)->Arg(2400)->Arg(100000)->Unit(benchmark::kMicrosecond)->ComputeStatistics("min", minimum);

// compute_vertex_normals(): any double positions (the other models' frames,
// the viewer's rest shape).
void BM_NormalsOfDoublePositions(benchmark::State& state) {
  const organ::Organ& o = organ(static_cast<std::size_t>(state.range(0)));
  std::vector<model::Point3> normals(o.vertex_count());
  for (auto _ : state) {
    compute_vertex_normals(o, o.model().surface_vertices.data(), normals.data(), 0, o.vertex_count());
    benchmark::ClobberMemory();
  }
  // As above with 24-byte points (76 bytes).
  const auto n = static_cast<double>(o.vertex_count());
  state.counters["x_memory_limit"] = organsim::bench::times_memory_limit(76.0 * n);
  state.counters["x_arithmetic_limit"] = organsim::bench::times_arithmetic_limit(100.0 * n);
}
BENCHMARK(BM_NormalsOfDoublePositions)
    ->Arg(2400)
    ->Arg(100000)
    ->Unit(benchmark::kMicrosecond)
    ->ComputeStatistics("min", minimum);

// A helper thread that runs the second half of each phase; the caller runs the
// first half and waits for it (spinning: this is a throughput benchmark).
class SecondThread {
 public:
  template <typename Work>
  explicit SecondThread(Work work)
      : thread_([this, work] {
          std::uint64_t seen = 0;
          while (true) {
            std::uint64_t g;
            while ((g = generation_.load(std::memory_order_acquire)) == seen) std::this_thread::yield();
            if (g == kStop) return;
            seen = g;
            work(phase_.load(std::memory_order_relaxed));
            done_.store(g, std::memory_order_release);
          }
        }) {}
  ~SecondThread() {
    generation_.store(kStop, std::memory_order_release);
    thread_.join();
  }
  void start(int phase) {
    phase_.store(phase, std::memory_order_relaxed);
    generation_.store(++issued_, std::memory_order_release);
  }
  void wait() const {
    while (done_.load(std::memory_order_acquire) != issued_) std::this_thread::yield();
  }

 private:
  static constexpr std::uint64_t kStop = ~std::uint64_t{0};
  std::atomic<std::uint64_t> generation_{0}, done_{0};
  std::atomic<int> phase_{0};
  std::uint64_t issued_ = 0;
  std::thread thread_;
};

void BM_Deformation(benchmark::State& state) {
  const std::size_t vertices = static_cast<std::size_t>(state.range(0));
  const int tools = static_cast<int>(state.range(1));
  const bool two_threads = state.range(2) == 2;
  const organ::Organ& o = organ(vertices);
  std::vector<Eigen::Vector3d> displacements;
  const auto beams = attached(o, tools, displacements);
  const std::size_t n = o.vertex_count(), half = n / 2 / organ::Organ::kPadding * organ::Organ::kPadding;
  std::vector<model::Point3> positions(n), normals(n);
  if (!two_threads) {
    for (auto _ : state) {
      beams->deform(displacements.data(), positions.data(), normals.data(), n);
      benchmark::ClobberMemory();
    }
  } else {
    SecondThread helper([&](int phase) {
      if (phase == 0)
        beams->distort(half, n, positions.data());
      else
        beams->normals(half, n, normals.data());
    });
    for (auto _ : state) {
      beams->prepare(displacements.data());
      helper.start(0);
      beams->distort(0, half, positions.data());
      helper.wait();
      helper.start(1);
      beams->normals(0, half, normals.data());
      helper.wait();
      benchmark::ClobberMemory();
    }
  }
  state.counters["vertices"] = static_cast<double>(n);
  // At least: rest position in, deformed position out, each tool's weight in,
  // and the normals pass (77 bytes) per vertex.
  state.counters["x_memory_limit"] =
      organsim::bench::times_memory_limit((125.0 + 8.0 * tools) * static_cast<double>(n));
  state.counters["ns_per_vertex_per_tool"] =
      benchmark::Counter(static_cast<double>(n) * tools * 1e-9,
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}
BENCHMARK(BM_Deformation)
    ->ArgNames({"vertices", "tools", "threads"})
    ->ArgsProduct({{2400, 100000}, {1, 2, 4, 8}, {1, 2}})
    ->Unit(benchmark::kMicrosecond)
    ->UseRealTime()
    ->ComputeStatistics("min", minimum);

const char* bench_model() { return std::getenv("ORGANSIM_BENCH_MODEL"); }

const organ::Organ& baked_organ() {
  static const organ::Organ baked = [] {
    model::ModelReadResult read = model::read_organ_model_file(bench_model());
    if (!read) throw std::runtime_error(read.error);
    return organ::Organ(std::move(*read.model));
  }();
  return baked;
}

/// `tools` beams on the baked organ at vertices spread along its (Morton)
/// vertex order, skipping any the model refuses (at the fixed point).
std::unique_ptr<MultiBeam> attached_on_model(int tools, std::vector<Eigen::Vector3d>& displacements) {
  const organ::Organ& o = baked_organ();
  MultiBeamOptions options;
  options.max_tools = static_cast<std::uint32_t>(std::max(tools, 1));
  auto beams = std::make_unique<MultiBeam>(o, options);
  displacements.clear();
  const std::size_t n = o.vertex_count(), stride = n / 8;
  for (std::size_t v = stride / 2; static_cast<int>(displacements.size()) < tools && v < n; v += stride) {
    const auto& x = o.model().surface_vertices[v];
    const auto& normal = o.rest_normals()[v];
    if (beams->attach(static_cast<std::uint32_t>(displacements.size()), {x[0], x[1], x[2]}) != Status::ok) continue;
    displacements.push_back(-0.005 * Eigen::Vector3d(normal[0], normal[1], normal[2]));
  }
  if (static_cast<int>(displacements.size()) < tools) throw std::runtime_error("too few surface sites took a beam");
  return beams;
}

void ModelBeamCreation(benchmark::State& state) {
  const organ::Organ& o = baked_organ();
  MultiBeam beams(o, {});
  const std::size_t n = o.vertex_count();
  std::size_t v = 0;
  for (auto _ : state) {
    const auto& x = o.model().surface_vertices[v];
    const Status s = beams.attach(0, {x[0], x[1], x[2]});
    benchmark::DoNotOptimize(s);
    v = (v + 97) % n;
  }
  state.counters["vertices"] = static_cast<double>(n);
}

void ModelDeformation(benchmark::State& state) {
  const int tools = static_cast<int>(state.range(0));
  std::vector<Eigen::Vector3d> displacements;
  const auto beams = attached_on_model(tools, displacements);
  const std::size_t n = baked_organ().vertex_count();
  std::vector<model::Point3> positions(n), normals(n);
  for (auto _ : state) {
    beams->deform(displacements.data(), positions.data(), normals.data(), n);
    benchmark::ClobberMemory();
  }
  state.counters["vertices"] = static_cast<double>(n);
}

// Only with a baked model.
const bool model_registered = [] {
  if (bench_model() == nullptr) return false;
  benchmark::RegisterBenchmark("ModelBeamCreation", ModelBeamCreation)->Unit(benchmark::kMicrosecond);
  benchmark::RegisterBenchmark("ModelDeformation", ModelDeformation)
      ->ArgName("tools")
      ->Arg(1)
      ->Arg(2)
      ->Arg(4)
      ->Arg(8)
      ->Unit(benchmark::kMicrosecond)
      ->ComputeStatistics("min", minimum);
  return true;
}();

}  // namespace

ORGANSIM_BENCHMARK_MAIN();
