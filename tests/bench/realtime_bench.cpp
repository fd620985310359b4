// Force-loop compute per tick with 1, 2, 4 and 8 tools in contact (scripted
// devices, safety included), on a 100k-vertex organ, pressing or grasping, and with the fast models
// matched to the FEM reference through the site law; and the contact tree's
// refit, full vs only above the moved vertices (the paper's partial refit).
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>
#include <memory>

#include <benchmark/benchmark.h>

#include "machine_limits.h"

#include "organsim/realtime/engine.h"
#include "organsim/devices/scripted_device.h"
#include "organsim/geometry/closest_point.h"
#include "test_models.h"

namespace {

using namespace organsim;
using namespace organsim::devices;
using namespace organsim::realtime;

constexpr double kRadius = 0.08;  // the test sphere, m

const organ::Organ& organ() {
  static const organ::Organ sphere(testing::make_sphere_model(100000, 20));
  return sphere;
}

// Tool k approaches its own point of the sphere from 10 mm outside and stays 5 mm in.
Trajectory pressing(int k, int count) {
  const double z = 1.0 - (2.0 * k + 1.0) / count, azimuth = k * M_PI * (3.0 - std::sqrt(5.0));
  const Eigen::Vector3d n(std::sqrt(1 - z * z) * std::cos(azimuth), std::sqrt(1 - z * z) * std::sin(azimuth), z);
  Trajectory t;
  t.times = {0.0, 0.1};
  t.positions = {(kRadius + 0.01) * n, (kRadius - 0.005) * n};
  return t;
}

// Tool k pressing as above, then a grasper: its jaws close once it is in and
// it lifts its point to 3 mm outside the sphere, where it holds it.
Trajectory grasping(int k, int count) {
  Trajectory t = pressing(k, count);
  const Eigen::Vector3d n = t.positions.front().normalized();
  t.times.push_back(0.2);
  t.positions.push_back((kRadius + 0.003) * n);
  t.jaw_times = {0.12};
  t.jaw_closed = {1};
  return t;
}

// Ticks with `tools` tools pressing `organ`'s sphere, each from its own side
// (or grasping it and lifting).
void tick_pressing_tools(benchmark::State& state, const organ::Organ& organ, const EngineOptions& options, int tools,
                         bool grasp = false) {
  std::vector<std::unique_ptr<ScriptedDevice>> devices;
  std::vector<HapticDevice*> pointers;
  for (int k = 0; k < tools; ++k) {
    devices.push_back(
        std::make_unique<ScriptedDevice>(grasp ? grasping(k, tools) : pressing(k, tools), SafetyLimits{}, 1024));
    pointers.push_back(devices.back().get());
  }
  Engine engine(organ, pointers, options);
  double time = 0.0;
  for (int tick = 0; tick < 300; ++tick, time += 1e-3) {  // contacts established (and grasps lifted)
    if (tick % 16 == 0) engine.deformation_step(time);
    engine.force_tick(time);
  }
  for (int k = 0; k < tools; ++k) {
    if (!engine.telemetry(k).in_contact) state.SkipWithError("a tool is not in contact");
    if (grasp && engine.telemetry(k).grasps != 1) state.SkipWithError("a tool does not grasp");
  }
  // Ticks at one instant: the same work as a live tick (devices, contacts,
  // safety), with the simulation fresh and the force steady.
  engine.deformation_step(time);
  for (auto _ : state) engine.force_tick(time);
  state.counters["tools"] = tools;
}

// The multi-beam model's own force law, the tools' 2.5 mm tips.
void BM_ForceTick(benchmark::State& state) {
  tick_pressing_tools(state, organ(), {}, static_cast<int>(state.range(0)));
}
BENCHMARK(BM_ForceTick)->Arg(1)->Arg(2)->Arg(4)->Arg(8)->Unit(benchmark::kMicrosecond);

// The same with every tool a grasper holding its point 3 mm above the surface
// (docs/realtime.md#grasping): no friction cone, a pulling force.
void BM_ForceTickGrasping(benchmark::State& state) {
  tick_pressing_tools(state, organ(), {}, static_cast<int>(state.range(0)), true);
}
BENCHMARK(BM_ForceTickGrasping)->Arg(1)->Arg(8)->Unit(benchmark::kMicrosecond);

// The fast models matched to the FEM reference (docs/matching.md): with site
// compliances the force each tool feels is the site law's for its 2.5 mm tip,
// evaluated every tick from the touched vertices' compliances and the depth
// curve. range(0): 0 the multi-beam model, 1 the mass-spring model;
// range(1): tools. A 10k-vertex sphere: the tick does not depend on the size.
const organ::Organ& matched_organ() {
  static const organ::Organ sphere([] {
    model::OrganModel m = testing::make_sphere_model(10000, 20);
    testing::add_uniform_site_compliance(m, 0.1);  // m/N: 10 N/m, about a liver's median site (8.9 N/m)
    return m;
  }());
  return sphere;
}

void BM_ForceTickSiteLaw(benchmark::State& state) {
  EngineOptions options;
  options.model = state.range(0) == 0 ? "beam" : "springs";
  state.SetLabel(options.model);
  tick_pressing_tools(state, matched_organ(), options, static_cast<int>(state.range(1)));
}
BENCHMARK(BM_ForceTickSiteLaw)
    ->ArgsProduct({{0, 1}, {1, 8}})
    ->ArgNames({"model", "tools"})
    ->Unit(benchmark::kMicrosecond);

// Refit of the contact tree of a sphere with range(0) vertices after a dent:
// range(1) per mille of the vertices moved (a cap around one contact, as a
// dynamic region moves them); 1000 ‰ is the full refit.
void BM_ContactTreeRefit(benchmark::State& state) {
  const model::OrganModel model = testing::make_sphere_model(static_cast<std::size_t>(state.range(0)), 2);
  const double fraction = static_cast<double>(state.range(1)) / 1000.0;
  std::vector<model::Point3> dented = model.surface_vertices;
  std::vector<std::uint32_t> moved;
  // The cap z ≥ z₀ that holds that fraction of the vertices.
  std::vector<double> heights;
  for (const model::Point3& p : dented) heights.push_back(-p[2]);
  const auto rank = static_cast<std::ptrdiff_t>(std::min(fraction, 1.0) * static_cast<double>(heights.size() - 1));
  std::nth_element(heights.begin(), heights.begin() + rank, heights.end());
  const double cap = -heights[static_cast<std::size_t>(rank)];
  for (std::uint32_t v = 0; v < dented.size(); ++v)
    if (dented[v][2] >= cap) {
      dented[v][2] -= 0.1 * (dented[v][2] - cap);
      moved.push_back(v);
    }
  geometry::SurfaceBvh tree(model.surface_vertices, model.surface_triangles);
  const bool full = state.range(1) >= 1000;
  for (auto _ : state) {
    if (full) {
      tree.refit(dented.data());
    } else {
      tree.refit(dented.data(), moved.data(), moved.size());
    }
    benchmark::ClobberMemory();
  }
  state.counters["moved_vertices"] = static_cast<double>(moved.size());
}
BENCHMARK(BM_ContactTreeRefit)
    ->ArgsProduct({{3000, 100000}, {10, 100, 1000}})
    ->ArgNames({"vertices", "moved_per_mille"})
    ->Unit(benchmark::kMicrosecond);

}  // namespace

ORGANSIM_BENCHMARK_MAIN();
