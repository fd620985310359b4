// The real-time force loop's period while the deformation loop deforms a
// ~100k-vertex organ: run for N seconds (default 60) with two tools pressing and
// print the period and compute-time distributions and the deadline misses.
//   build/tests/realtime_period [seconds] [organ vertices] [pressing tools: 2, 1 or 0]
// With 0 pressing tools (one tool held away from the organ) and a small organ,
// both loops have almost nothing to do: what remains of the period's jitter
// and misses is the machine's and its scheduler's own (`realtime_period 60 200 0`).
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>

#include "organsim/realtime/loop_runner.h"
#include "organsim/devices/scripted_device.h"
#include "test_models.h"

int main(int argc, char** argv) {
  using namespace organsim;
  using namespace organsim::devices;
  using namespace organsim::realtime;
  const double seconds = argc > 1 ? std::atof(argv[1]) : 60.0;
  const auto vertices = static_cast<std::size_t>(argc > 2 ? std::atof(argv[2]) : 100000);
  const int pressing = argc > 3 ? std::atoi(argv[3]) : 2;
  if (pressing < 0 || pressing > 2) {
    std::fprintf(stderr, "pressing tools: 0, 1 or 2\n");
    return 2;
  }
  const organ::Organ organ(testing::make_sphere_model(vertices, 20));
  std::vector<std::unique_ptr<ScriptedDevice>> devices;
  std::vector<HapticDevice*> pointers;
  for (int k = 0; k < std::max(pressing, 1); ++k) {
    // Each tool presses in and out along its own axis, 1 s per cycle; an idle
    // tool stays 5 cm outside the organ.
    const Eigen::Vector3d n = k == 0 ? Eigen::Vector3d(1, 0, 0) : Eigen::Vector3d(0, 0.6, 0.8);
    Trajectory t;
    for (double time = 0.0; time <= seconds + 1.0; time += 0.5) {
      t.times.push_back(time);
      const double depth = pressing == 0 ? 0.05 : static_cast<long>(time * 2) % 2 == 0 ? 0.01 : -0.006;
      t.positions.push_back((0.08 + depth) * n);
    }
    devices.push_back(std::make_unique<ScriptedDevice>(t, SafetyLimits{}, 16));
    pointers.push_back(devices.back().get());
  }
  Engine engine(organ, pointers, {});
  const RunTimings timings = run_realtime(engine, seconds);
  const Percentiles period = timings.force_periods.percentiles(), compute = timings.force_computes.percentiles();
  const Percentiles deform = timings.deformation_computes.percentiles();
  std::printf("organ: %zu vertices, %d pressing tools, %.0f s real time%s\n", organ.vertex_count(), pressing, seconds,
              timings.realtime_priority ? ", force loop SCHED_FIFO" : "");
  if (!timings.priority_warning.empty()) std::printf("warning: %s\n", timings.priority_warning.c_str());
  std::printf(
      "force loop: %zu ticks; period p50 %.4f ms, p99 %.4f ms, max %.4f ms; compute p50 %.2f us, p99 %.2f us, "
      "max %.2f us; %llu periods > 2 ms\n",
      static_cast<std::size_t>(timings.force_computes.count()), period.p50 * 1e3, period.p99 * 1e3, period.max * 1e3,
      compute.p50 * 1e6, compute.p99 * 1e6, compute.max * 1e6,
      static_cast<unsigned long long>(timings.force_deadline_misses));
  const auto within = static_cast<double>(timings.force_periods.count_between(0.9e-3, 1.1e-3));
  std::printf("force periods within 1 ms ± 0.1 ms: %.3f %%; min %.4f ms\n",
              100.0 * within / static_cast<double>(std::max<std::uint64_t>(1, timings.force_periods.count())),
              timings.force_periods.min() * 1e3);
  std::printf("deformation loop: %zu frames; compute p50 %.3f ms, p99 %.3f ms, max %.3f ms\n",
              static_cast<std::size_t>(timings.deformation_computes.count()), deform.p50 * 1e3, deform.p99 * 1e3,
              deform.max * 1e3);
  std::printf("contacts:");
  for (std::size_t k = 0; k < pointers.size(); ++k) std::printf(" tool %zu %u", k + 1, engine.telemetry(k).contacts);
  std::printf("\n");
  return 0;
}
