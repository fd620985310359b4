// Mass-spring model speed: one step per integrator on the paper's 225- and
// 625-point grids and on a liver-sized 3,000-vertex closed surface with body
// springs, one thread; and the engine's force tick with the spring model.
// A spring costs about 20 flops and a square root per force evaluation: the
// "ns per spring" counter compares a step against that. The "blowups" counter
// says how often a run diverged and was reset (0: every timed step was a real
// step of a stable simulation; docs/springs.md gives the measured limits).
#include <cstdlib>
#include <memory>
#include <vector>

#include <benchmark/benchmark.h>

#include "machine_limits.h"

#include "organsim/devices/scripted_device.h"
#include "organsim/model/model_file.h"
#include "organsim/organ/organ.h"
#include "organsim/realtime/engine.h"
#include "organsim/springs/mass_spring.h"
#include "test_models.h"

namespace {

using namespace organsim;
using namespace organsim::springs;

constexpr Integrator kIntegrators[] = {Integrator::explicit_euler, Integrator::midpoint, Integrator::rk4,
                                       Integrator::symplectic_euler, Integrator::implicit_euler};
constexpr const char* kNames[] = {"euler", "midpoint", "rk4", "symplectic", "implicit"};
// Force evaluations per step: implicit Euler's are its CG iterations' matrix products instead.
constexpr int kEvaluations[] = {1, 2, 4, 1, 1};

SpringNetwork grid(std::uint32_t side) {
  GridOptions g;
  g.columns = g.rows = side;
  return make_grid_network(g);
}

SpringNetwork liver_sized_surface() {
  OrganNetworkOptions n;
  n.stiffness = 25.0;  // k = E·ℓ̄ for E = 5 kPa and 5 mm edges
  return make_organ_network(testing::make_sphere_model(3000, 4), n);
}

void run_steps(benchmark::State& state, SpringNetwork network, double dt) {
  const auto which = static_cast<std::size_t>(state.range(0));
  SimulationOptions s;
  s.integrator = kIntegrators[which];
  s.dt = dt;
  const std::size_t springs = network.springs.size();
  // Per spring: two node indices, rest length, stiffness, damping (32 bytes).
  const double spring_bytes = 32.0 * static_cast<double>(springs);
  MassSpring simulation(std::move(network), s);
  simulation.set_external_force(static_cast<std::uint32_t>(simulation.network().surface_nodes / 2),
                                Eigen::Vector3d(0, 0, -0.05));
  double blowups = 0.0;
  for (auto _ : state) {
    if (simulation.step() != StepStatus::ok) {
      simulation.reset();
      ++blowups;
    }
    benchmark::DoNotOptimize(simulation.position(0));
  }
  state.SetLabel(kNames[which]);
  state.counters["blowups"] = blowups;
  state.counters["springs"] = static_cast<double>(springs);
  // At least the spring list, streamed once per force evaluation.
  state.counters["x_memory_limit"] = organsim::bench::times_memory_limit(spring_bytes * kEvaluations[which]);
  state.counters["ns_per_spring_evaluation"] =
      benchmark::Counter(static_cast<double>(springs * kEvaluations[which]),
                         benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void BM_StepGrid225(benchmark::State& state) { run_steps(state, grid(15), 1e-3); }
void BM_StepGrid625(benchmark::State& state) { run_steps(state, grid(25), 1e-3); }
void BM_StepLiverSurface3000(benchmark::State& state) { run_steps(state, liver_sized_surface(), 1e-4); }
BENCHMARK(BM_StepGrid225)->DenseRange(0, 4)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_StepGrid625)->DenseRange(0, 4)->Unit(benchmark::kMicrosecond);
BENCHMARK(BM_StepLiverSurface3000)->DenseRange(0, 4)->Unit(benchmark::kMicrosecond);

/// A baked liver's surface network as the engine builds it (k = E·ℓ̄, masses
/// ρV/n, body springs), from the model file named by ORGANSIM_BENCH_MODEL (e.g.
/// demo_output/liver.organ, which README command (a) bakes from the shipped CT);
/// skipped without it.
void BM_StepBakedLiver(benchmark::State& state) {
  const char* path = std::getenv("ORGANSIM_BENCH_MODEL");
  if (path == nullptr) {
    state.SkipWithError("set ORGANSIM_BENCH_MODEL to a baked model file (e.g. demo_output/liver.organ)");
    return;
  }
  const model::ModelReadResult read = model::read_organ_model_file(path);
  if (!read) {
    state.SkipWithError(read.error.c_str());
    return;
  }
  run_steps(state, make_organ_network(*read.model, {}), 1e-4);
}
BENCHMARK(BM_StepBakedLiver)->DenseRange(0, 4)->Unit(benchmark::kMicrosecond);

/// The force loop's cost with the spring model: the same 3×3 linearization as the beam's.
void BM_EngineForceTickSprings(benchmark::State& state) {
  static const organ::Organ organ(testing::make_sphere_model(3000, 20));
  devices::Trajectory press;
  press.times = {0.0, 1.0};
  press.positions = {Eigen::Vector3d(0, 0, 0.09), Eigen::Vector3d(0, 0, 0.07)};
  std::vector<std::unique_ptr<devices::ScriptedDevice>> owned;
  std::vector<devices::HapticDevice*> pointers;
  for (int i = 0; i < state.range(0); ++i) {
    owned.push_back(std::make_unique<devices::ScriptedDevice>(press, devices::SafetyLimits{}, 0));
    pointers.push_back(owned.back().get());
  }
  realtime::EngineOptions options;
  options.model = "springs";
  realtime::Engine engine(organ, pointers, options);
  double now = 0.0;
  for (int frame = 0; frame < 40; ++frame) {  // make contact and settle into it
    for (int tick = 0; tick < 16; ++tick) engine.force_tick(now += 1e-3);
    engine.deformation_step(now);
  }
  for (auto _ : state) engine.force_tick(now += 1e-3);
  state.counters["tools"] = static_cast<double>(state.range(0));
}
BENCHMARK(BM_EngineForceTickSprings)->Arg(1)->Arg(4)->Unit(benchmark::kNanosecond);

}  // namespace

ORGANSIM_BENCHMARK_MAIN();
