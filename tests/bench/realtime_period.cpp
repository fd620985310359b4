// The real-time force loop's period while the deformation loop deforms a
// ~100k-vertex organ: run for N seconds (default 60) with two tools pressing and
// print the period and compute-time distributions and the deadline misses.
//   build/tests/realtime_period [seconds] [organ vertices]
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <memory>

#include "organsim/realtime/loop_runner.h"
#include "organsim/realtime/session.h"
#include "test_models.h"

int main(int argc, char** argv) {
  using namespace organsim;
  using namespace organsim::realtime;
  const double seconds = argc > 1 ? std::atof(argv[1]) : 60.0;
  const auto vertices = static_cast<std::size_t>(argc > 2 ? std::atof(argv[2]) : 100000);
  const multibeam::BeamOrgan organ(testing::make_sphere_model(vertices, 20));
  std::vector<std::unique_ptr<ScriptedDevice>> devices;
  std::vector<HapticDevice*> pointers;
  for (int k = 0; k < 2; ++k) {
    // Each tool presses in and out along its own axis, 1 s per cycle.
    const Eigen::Vector3d n = k == 0 ? Eigen::Vector3d(1, 0, 0) : Eigen::Vector3d(0, 0.6, 0.8);
    Trajectory t;
    for (double time = 0.0; time <= seconds + 1.0; time += 0.5) {
      t.times.push_back(time);
      t.positions.push_back((0.08 + (static_cast<long>(time * 2) % 2 == 0 ? 0.01 : -0.006)) * n);
    }
    devices.push_back(std::make_unique<ScriptedDevice>(t, SafetyLimits{}, 16));
    pointers.push_back(devices.back().get());
  }
  Engine engine(organ, pointers, {});
  const RunTimings timings = run_realtime(engine, seconds);
  const Percentiles period = percentiles(timings.force_periods), compute = percentiles(timings.force_computes);
  const Percentiles deform = percentiles(timings.deformation_computes);
  std::printf("organ: %zu vertices, 2 tools, %.0f s real time%s\n", organ.vertex_count(), seconds,
              timings.realtime_priority ? ", force loop SCHED_FIFO" : "");
  if (!timings.priority_warning.empty()) std::printf("warning: %s\n", timings.priority_warning.c_str());
  std::printf("force loop: %zu ticks; period p50 %.4f ms, p99 %.4f ms, max %.4f ms; compute p50 %.2f us, p99 %.2f us, "
              "max %.2f us; %llu periods > 2 ms\n",
              timings.force_computes.size(), period.p50 * 1e3, period.p99 * 1e3, period.max * 1e3, compute.p50 * 1e6,
              compute.p99 * 1e6, compute.max * 1e6, static_cast<unsigned long long>(timings.force_deadline_misses));
  double low = 1.0, high = 0.0;
  std::size_t within = 0;
  for (double p : timings.force_periods) within += std::abs(p - 1e-3) <= 1e-4;
  for (double p : timings.force_periods) low = std::min(low, p), high = std::max(high, p);
  std::printf("force periods within 1 ms ± 0.1 ms: %.3f %%; min %.4f ms\n",
              100.0 * within / std::max<std::size_t>(1, timings.force_periods.size()), low * 1e3);
  std::printf("deformation loop: %zu frames; compute p50 %.3f ms, p99 %.3f ms, max %.3f ms\n",
              timings.deformation_computes.size(), deform.p50 * 1e3, deform.p99 * 1e3, deform.max * 1e3);
  std::printf("contacts: tool 1 %u, tool 2 %u\n", engine.telemetry(0).contacts, engine.telemetry(1).contacts);
  return 0;
}
