// The real-time calls allocate nothing: every operator new on the test's
// thread (where the calls under test run) is counted, and the count must not
// change across attach, force and deform. (The FEM models' tangent worker
// allocates on its own thread, outside the loops.)
#include <cmath>
#include <cstdlib>
#include <new>
#include <string>
#include <utility>
#include <vector>

#include <gtest/gtest.h>

#include "organsim/organ_fem/organ_fem.h"
#include "organsim/multibeam/multibeam.h"
#include "organsim/realtime/engine.h"
#include "organsim/realtime/model_registry.h"
#include "organsim/devices/scripted_device.h"
#include "organsim/springs/mass_spring.h"
#include "test_models.h"

namespace {
thread_local long allocations = 0;
}

void* operator new(std::size_t size) {
  ++allocations;
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
void* operator new(std::size_t size, std::align_val_t alignment) {
  ++allocations;
  const std::size_t a = static_cast<std::size_t>(alignment);
  if (void* p = std::aligned_alloc(a, (size + a - 1) / a * a)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
void operator delete(void* p, std::align_val_t) noexcept { std::free(p); }
void operator delete(void* p, std::size_t, std::align_val_t) noexcept { std::free(p); }

namespace organsim::multibeam {
namespace {

TEST(RealTime, AttachForceAndDeformAllocateNothing) {
  const testing::CylinderSpec spec;
  const organ::Organ organ(testing::make_cylinder_model(spec));
  for (MergeRule rule : {MergeRule::influence, MergeRule::sum}) {
    MultiBeamOptions options;
    options.max_tools = 4;
    options.merge = rule;
    MultiBeam beams(organ, options);
    std::vector<model::Point3> positions(organ.vertex_count()), normals(organ.vertex_count());
    const Eigen::Vector3d tips[4] = {{0.0, 0.004, 0.0}, {0.002, 0.0, 0.001}, {0.0, 0.0, -0.003}, {0.0, 0.001, 0.0}};
    Eigen::Vector3d force, total = Eigen::Vector3d::Zero();

    const long before = allocations;
    ASSERT_EQ(beams.attach(0, {spec.length, 0.0, 0.0}), Status::ok);
    ASSERT_EQ(beams.attach(1, {0.08, spec.radius, 0.0}), Status::ok);
    ASSERT_EQ(beams.attach(2, {0.12, 0.0, -spec.radius}), Status::ok);
    ASSERT_EQ(beams.attach(3, {0.12, 0.0, -spec.radius}), Status::ok);  // coincides with tool 2: merged
    for (int tick = 0; tick < 1000; ++tick)
      for (std::uint32_t tool = 0; tool < 4; ++tool) {
        ASSERT_EQ(beams.force(tool, tips[tool], force), Status::ok);
        total += force;
      }
    ASSERT_EQ(beams.deform(tips, positions.data(), normals.data(), positions.size()), Status::ok);
    beams.detach(1);
    ASSERT_EQ(beams.deform(tips, positions.data(), normals.data(), positions.size()), Status::ok);
    EXPECT_EQ(beams.attach(0, {std::nan(""), 0.0, 0.0}), Status::not_finite);
    const long after = allocations;
    EXPECT_EQ(after - before, 0) << "allocations in the real-time calls";
    EXPECT_TRUE(total.allFinite());
  }
}

TEST(RealTime, EngineLoopsAllocateNothingWithEveryModel) {
  const testing::CylinderSpec spec;
  const organ::Organ organ(testing::make_cylinder_model(spec));
  model::OrganModel with_sites = testing::make_cylinder_model(spec);  // the fast models give the site law's force
  testing::add_uniform_site_compliance(with_sites, 0.01);
  const organ::Organ matched_organ(std::move(with_sites));
  devices::Trajectory press, side;
  press.times = {0.0, 0.3, 0.6};
  press.positions = {{0.16, 0.0, 0.0}, {0.144, 0.002, 0.0}, {0.16, 0.0, 0.0}};
  side.times = {0.0, 0.2, 0.6};
  side.positions = {{0.08, 0.04, 0.0}, {0.08, 0.026, 0.0}, {0.08, 0.04, 0.0}};
  // A grasper on the side: closes its jaws at its deepest, lifts the side
  // 4 mm above rest, opens them (docs/realtime.md#grasping).
  devices::Trajectory grasper;
  grasper.times = {0.0, 0.2, 0.45, 0.6};
  grasper.positions = {{0.08, 0.04, 0.0}, {0.08, 0.026, 0.0}, {0.08, 0.034, 0.0}, {0.08, 0.04, 0.0}};
  grasper.jaw_times = {0.22, 0.47};
  grasper.jaw_closed = {1, 0};
  // Every registered model (model_registry.h), the springs also with a
  // dynamic region (partial refits of the contact tree) and with volume
  // springs, the fast models matched to a site law, and with tick records
  // (a training report: its ring fills and drops; nothing is allocated), and
  // every model with the side tool a grasper.
  enum class Variant { plain, dynamic_region, volume, matched, recorded, grasping };
  std::vector<std::pair<std::string, Variant>> variants;
  for (const realtime::RegisteredModel* model : realtime::registered_models())
    variants.emplace_back(model->name, Variant::plain);
  for (const realtime::RegisteredModel* model : realtime::registered_models())
    variants.emplace_back(model->name, Variant::grasping);
  ASSERT_GE(variants.size(), 6u);
  variants.emplace_back("springs", Variant::dynamic_region);
  variants.emplace_back("springs", Variant::volume);
  variants.emplace_back("beam", Variant::matched);
  variants.emplace_back("springs", Variant::matched);
  variants.emplace_back("beam", Variant::recorded);
  for (const auto& [kind, variant] : variants) {
    devices::ScriptedDevice a(press, {}, 1000), b(variant == Variant::grasping ? grasper : side, {}, 1000);
    realtime::EngineOptions options;
    options.model = kind;
    auto& network = options.models.edit<realtime::SpringModelOptions>();
    if (variant == Variant::dynamic_region) network.simulation.region = springs::Region::dynamic;
    network.network.volume_springs = variant == Variant::volume;
    network.volume_clamp_radius = 0.0;  // volume springs beside the body springs
    auto& finite_elements = options.models.edit<organsim::fem::OrganFemOptions>();
    finite_elements.fixed_radius = 0.031;  // the cylinder's clamped cap
    finite_elements.refresh_frames = 3;    // tangents adopted during the test
    if (variant == Variant::recorded) options.tick_records = 256;
    realtime::Engine engine(variant == Variant::matched ? matched_organ : organ, {&a, &b}, options);
    const long before = allocations;
    for (int tick = 0; tick <= 600; ++tick) {
      if (tick % 17 == 0) engine.deformation_step(tick * 1e-3);  // contacts begin, deform, end
      engine.force_tick(tick * 1e-3);
    }
    const long after = allocations;
    EXPECT_EQ(after - before, 0) << "allocations in the engine's loops, model " << kind;
    // The springs' surface relaxes after the tool has let go and may touch the
    // retreating tool once more: at least one contact per tool.
    EXPECT_GE(engine.telemetry(0).contacts, 1u) << kind;
    EXPECT_GE(engine.telemetry(1).contacts, 1u) << kind;
    EXPECT_GT(engine.telemetry(0).peak_force, 0.0) << kind;
    EXPECT_EQ(engine.model().instabilities(), 0u) << kind << " variant " << static_cast<int>(variant);
    if (variant == Variant::grasping) {
      EXPECT_EQ(engine.telemetry(1).grasps, 1u) << kind;
    }
    if (variant == Variant::recorded) {
      realtime::TickRecord record;
      std::size_t held = 0;
      while (engine.take_tick_record(0, record)) ++held;
      EXPECT_EQ(held, 256u);
      EXPECT_EQ(engine.dropped_tick_records(0), 601u - 256u);
    }
  }
}

}  // namespace
}  // namespace organsim::multibeam

namespace organsim::springs {
namespace {

TEST(RealTime, MassSpringStepsAndQueriesAllocateNothing) {
  GridOptions grid;
  grid.columns = grid.rows = 9;
  const std::uint32_t centre = 4 + 9 * 4;
  for (Region region : {Region::all, Region::dynamic, Region::fixed})
    for (Integrator integrator : {Integrator::explicit_euler, Integrator::midpoint, Integrator::rk4,
                                  Integrator::symplectic_euler, Integrator::implicit_euler}) {
      SimulationOptions options;
      options.integrator = integrator;
      options.region = region;
      options.dt = 0.002;
      MassSpring sim(make_grid_network(grid), options);
      Eigen::Vector3d force = Eigen::Vector3d::Zero();
      Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();
      double energy = 0.0;

      const long before = allocations;
      sim.set_external_force(centre, {0.0, 0.0, -0.2});
      for (int n = 0; n < 200; ++n) {
        ASSERT_EQ(sim.step(), StepStatus::ok);
        if (n == 50) sim.hold(centre + 2, sim.position(centre + 2) + Eigen::Vector3d(0.0, 0.0, 0.003));
        if (n == 100) sim.clear_external_forces();  // the dynamic region retires nodes
        if (n == 150) sim.release(centre + 2);
        force += sim.reaction_force(centre + 2);
        stiffness += sim.contact_stiffness(centre + 2);
        energy += sim.energy().total();
      }
      sim.reset();
      ASSERT_EQ(sim.step(), StepStatus::ok);
      const long after = allocations;
      EXPECT_EQ(after - before, 0) << "allocations in the mass-spring steps, integrator "
                                   << static_cast<int>(integrator) << ", region " << static_cast<int>(region);
      EXPECT_TRUE(force.allFinite() && stiffness.allFinite() && std::isfinite(energy));
    }
}

}  // namespace
}  // namespace organsim::springs
