// Force-loop compute per tick with 1, 2, 4 and 8 tools in contact (scripted
// devices, safety included), on a 100k-vertex organ.
#include <cmath>
#include <memory>

#include <benchmark/benchmark.h>

#include "organsim/realtime/engine.h"
#include "organsim/devices/scripted_device.h"
#include "test_models.h"

namespace {

using namespace organsim;
using namespace organsim::devices;
using namespace organsim::realtime;

constexpr double kRadius = 0.08;  // the test sphere, m

const multibeam::BeamOrgan& organ() {
  static const multibeam::BeamOrgan sphere(testing::make_sphere_model(100000, 20));
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

void BM_ForceTick(benchmark::State& state) {
  const int tools = static_cast<int>(state.range(0));
  std::vector<std::unique_ptr<ScriptedDevice>> devices;
  std::vector<HapticDevice*> pointers;
  for (int k = 0; k < tools; ++k) {
    devices.push_back(std::make_unique<ScriptedDevice>(pressing(k, tools), SafetyLimits{}, 1024));
    pointers.push_back(devices.back().get());
  }
  Engine engine(organ(), pointers, {});
  double time = 0.0;
  for (int tick = 0; tick < 200; ++tick, time += 1e-3) {  // contacts established
    if (tick % 16 == 0) engine.deformation_step(time);
    engine.force_tick(time);
  }
  for (int k = 0; k < tools; ++k)
    if (!engine.telemetry(k).in_contact) state.SkipWithError("a tool is not in contact");
  // Ticks at one instant: the same work as a live tick (devices, contacts,
  // safety), with the simulation fresh and the force steady.
  engine.deformation_step(time);
  for (auto _ : state) engine.force_tick(time);
  state.counters["tools"] = tools;
}
BENCHMARK(BM_ForceTick)->Arg(1)->Arg(2)->Arg(4)->Arg(8)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
