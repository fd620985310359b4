// The real-time pieces: wait-free hand-off, force safety, contact detection on
// the deformed surface, and the engine's loops stepped deterministically.
#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <cstring>
#include <cmath>
#include <memory>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "organsim/organ_fem/organ_fem.h"
#include "organsim/realtime/engine.h"
#include "organsim/realtime/model_registry.h"
#include "organsim/realtime/loop_runner.h"
#include "organsim/devices/scripted_device.h"
#include "organsim/lockfree/triple_buffer.h"
#include "test_models.h"

namespace organsim::realtime {
namespace {

using namespace organsim::devices;

struct Payload {
  std::uint64_t sequence = 0;
  std::uint64_t check[15] = {};  // each sequence × (k + 1): a torn read would mix two sequences
};

TEST(TripleBuffer, ReaderSeesOnlyWholeValuesInOrderUnderConcurrentLoad) {
  TripleBuffer<Payload> buffer;
  constexpr std::uint64_t kReads = 20000;
  std::atomic<std::uint64_t> reads{0};
  std::atomic<bool> done{false};
  std::uint64_t written = 0;
  // The writer publishes until the reader has taken kReads values (however the
  // two threads get scheduled: on a loaded machine the reader may wait seconds
  // for a core), then stops; a minute at most.
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  std::thread writer([&] {
    for (std::uint64_t s = 1; reads.load(std::memory_order_relaxed) < kReads &&
                              (s % 4096 != 0 || std::chrono::steady_clock::now() < deadline);
         ++s) {
      Payload& p = buffer.write_slot();
      p.sequence = s;
      for (int k = 0; k < 15; ++k) p.check[k] = s * (k + 1);
      buffer.publish();
      written = s;
    }
    done.store(true, std::memory_order_release);
  });
  std::uint64_t last = 0, torn = 0, backwards = 0;
  while (true) {
    const bool finished = done.load(std::memory_order_acquire);
    if (buffer.update()) {
      const Payload& p = buffer.read();
      for (int k = 0; k < 15; ++k) torn += p.check[k] != p.sequence * (k + 1);
      backwards += p.sequence <= last;
      last = p.sequence;
      reads.fetch_add(1, std::memory_order_relaxed);
    } else if (finished) {
      break;
    }
  }
  writer.join();
  EXPECT_EQ(torn, 0u);
  EXPECT_EQ(backwards, 0u);  // each update brings a newer value
  EXPECT_GE(reads.load(), kReads);
  EXPECT_EQ(last, written);  // the last value always arrives
}

TEST(SurfaceBvh, RefitFollowsTheDeformedSurfaceAndFindsEnteringCrossings) {
  const model::OrganModel model = testing::make_sphere_model(2000, 4);  // radius 0.08 m, centred
  geometry::SurfaceBvh tree(model.surface_vertices, model.surface_triangles);
  geometry::SegmentHit hit;
  ASSERT_TRUE(tree.first_crossing({0.2, 0.001, 0.002}, {0.0, 0.001, 0.002}, true, hit));
  EXPECT_TRUE(hit.entering);
  EXPECT_NEAR(hit.position[0], 0.08, 1e-3);
  // Leaving the sphere is not an entering crossing; the whole diameter enters once.
  EXPECT_FALSE(tree.first_crossing({0.0, 0.001, 0.002}, {0.2, 0.001, 0.002}, true, hit));
  ASSERT_TRUE(tree.first_crossing({0.0, 0.001, 0.002}, {0.2, 0.001, 0.002}, false, hit));
  EXPECT_FALSE(hit.entering);
  // Shifted by 5 cm along x, refit: the crossing moves with it.
  std::vector<model::Point3> moved = model.surface_vertices;
  for (model::Point3& p : moved) p[0] += 0.05;
  tree.refit(moved.data());
  ASSERT_TRUE(tree.first_crossing({0.3, 0.001, 0.002}, {0.0, 0.001, 0.002}, true, hit));
  EXPECT_NEAR(hit.position[0], 0.13, 1e-3);
  EXPECT_NEAR(tree.closest_point({0.0, 0.0, 0.0}).distance, 0.03, 1e-3);
}

// The helper cylinder (radius 30 mm, x from 0 to 150 mm, clamped at x = 0).
struct CylinderEngine : ::testing::Test {
  testing::CylinderSpec spec;
  organ::Organ organ{testing::make_cylinder_model(spec)};

  static Trajectory path(std::initializer_list<std::pair<double, Eigen::Vector3d>> samples) {
    Trajectory t;
    for (const auto& [time, position] : samples) {
      t.times.push_back(time);
      t.positions.push_back(position);
    }
    return t;
  }
};

TEST_F(CylinderEngine, PressAndReleaseAtTheFarCap) {
  // Approach the far cap along −x, press 5 mm, hold, retreat.
  SafetyLimits limits;
  limits.max_force = 10.0;
  ScriptedDevice device(path({{0.0, {0.16, 0.0, 0.0}},
                              {0.3, {0.145, 0.0, 0.0}},
                              {0.8, {0.145, 0.0, 0.0}},
                              {1.0, {0.16, 0.0, 0.0}},
                              {1.2, {0.16, 0.0, 0.0}}}),
                        limits, 2000);
  Engine engine(organ, {&device}, {});
  run_fast(engine, 1.2);
  EXPECT_EQ(engine.telemetry(0).contacts, 1u);
  const double expected = organ.model().material.young_modulus * M_PI * spec.radius * spec.radius * 0.005 / spec.length;
  bool touched = false, released_after = false;
  for (std::size_t r = 0; r < device.record_count(); ++r) {
    const ForceRecord& f = device.record(r);
    if (f.time > 0.5 && f.time < 0.8) {
      EXPECT_TRUE(f.in_contact);
      EXPECT_NEAR(f.force[0], expected, 1e-4 * expected) << f.time;  // EAδ/L, pushing the tool back (+x)
      touched = true;
    }
    if (f.time > 0.95) {
      EXPECT_FALSE(f.in_contact) << f.time;
      EXPECT_EQ(f.force, Eigen::Vector3d::Zero()) << f.time;
      released_after = true;
    }
  }
  EXPECT_TRUE(touched);
  EXPECT_TRUE(released_after);
}

TEST_F(CylinderEngine, ASpringsDynamicRegionReportsEveryVertexItMoves) {
  // The engine refits its contact tree only above the vertices a model says it
  // moved: every vertex whose position changed in a frame must be listed.
  ModelOptions options;
  options.edit<SpringModelOptions>().simulation.region = springs::Region::dynamic;
  const std::unique_ptr<DeformationModel> model = make_deformation_model("springs", organ, options, 1);
  const std::size_t n = organ.vertex_count();
  std::vector<model::Point3> previous = organ.model().surface_vertices, positions(n), normals(n);
  std::array<ContactLinearization, 1> contacts{};
  geometry::ToolTip tip;  // a 5 mm probe pushed along the cylinder's axis into its end
  tip.radius = 2.5e-3;
  tip.axis = Eigen::Vector3d::UnitX();
  ASSERT_TRUE(model->attach(0, {spec.length, 0.0, 0.0}, tip, contacts[0]));
  std::size_t most = 0, changed_total = 0;
  for (int frame = 0; frame < 90; ++frame) {
    if (frame == 45) model->detach(0);
    const Eigen::Vector3d press(-0.005 * std::min(1.0, frame / 20.0), 0.0, 0.0);
    ASSERT_TRUE(model->step(1.0 / 60.0, &press, positions.data(), normals.data(), contacts.data()));
    std::size_t count = 0;
    const std::uint32_t* moved = model->moved_vertices(count);
    ASSERT_NE(moved, nullptr) << frame;
    const std::set<std::uint32_t> listed(moved, moved + count);
    EXPECT_EQ(listed.size(), count) << frame;  // no repeats
    for (std::uint32_t v = 0; v < n; ++v)
      if (positions[v] != previous[v]) {
        EXPECT_TRUE(listed.count(v)) << "frame " << frame << ", vertex " << v;
        ++changed_total;
      }
    most = std::max(most, count);
    if (frame < 45) {
      EXPECT_GT(model->active_nodes(), 0u) << frame;  // the tool's neighbourhood at least
    }
    previous = positions;
  }
  EXPECT_GT(changed_total, 0u);
  EXPECT_LT(most, n / 2);  // a region, not the organ
  // Integrating every node, the model claims nothing narrower than all.
  const std::unique_ptr<DeformationModel> everywhere = make_deformation_model("springs", organ, {}, 1);
  ASSERT_TRUE(everywhere->attach(0, {spec.length, 0.0, 0.0}, {}, contacts[0]));
  const Eigen::Vector3d press(-0.001, 0.0, 0.0);
  ASSERT_TRUE(everywhere->step(1.0 / 60.0, &press, positions.data(), normals.data(), contacts.data()));
  std::size_t count = 1;
  EXPECT_EQ(everywhere->moved_vertices(count), nullptr);
  EXPECT_EQ(count, 0u);
}

TEST_F(CylinderEngine, AFastToolCannotPassThroughTheOrgan) {
  // Across the whole 60 mm diameter within one force tick: the swept test still
  // finds where it entered, and the force pushes it back out (clamped).
  SafetyLimits limits;
  limits.max_force = 0.3;
  ScriptedDevice device(
      path({{0.0, {0.1, 0.05, 0.0}}, {0.1, {0.1, 0.05, 0.0}}, {0.101, {0.1, -0.05, 0.0}}, {0.5, {0.1, -0.05, 0.0}}}),
      limits, 1000);
  Engine engine(organ, {&device}, {});
  run_fast(engine, 0.5);
  EXPECT_EQ(engine.telemetry(0).contacts, 1u);
  const ForceRecord& last = device.record(device.record_count() - 1);
  EXPECT_TRUE(last.in_contact);
  EXPECT_NEAR(last.force.norm(), 0.3, 1e-9);  // clamped to the device limit
  EXPECT_GT(last.force[1], 0.0);              // back towards +y, where it came from
  EXPECT_GT(engine.safety(0).clamp_count(), 0u);
}

// A 5 mm probe (the default tip) approaches the cylinder's side, presses
// 3 mm, slides 30 mm along it and leaves, replayed fast with every model: the
// force sent to the device never changes by more than the onset limit allows
// in one tick, rising or falling (it begins, slides and ends without a
// kick), the organ slips under the tip within Coulomb's cone (tangential
// force ≤ μ × normal force), and nothing is felt once the tip is out.
/// The press-slide-leave run of the test below with one model on `organ`.
void enter_slide_and_leave(const organ::Organ& organ, const RegisteredModel& model, const std::string& label) {
  ScriptedDevice device(CylinderEngine::path({{0.0, {0.08, 0.045, 0.0}},
                                              {0.3, {0.08, 0.027, 0.0}},
                                              {0.5, {0.08, 0.027, 0.0}},
                                              {1.1, {0.11, 0.027, 0.0}},
                                              {1.4, {0.11, 0.045, 0.0}},
                                              {1.6, {0.11, 0.045, 0.0}}}),
                        {}, 2000);
  EngineOptions options;
  options.model = model.name;
  options.models.edit<fem::OrganFemOptions>().fixed_radius = 0.031;  // the clamped cap
  ASSERT_EQ(options.tip_radius, 2.5e-3);
  Engine engine(organ, {&device}, options);
  run_fast(engine, 1.6);
  EXPECT_GE(engine.telemetry(0).contacts, 1u) << label;
  const double step_limit = device.limits().onset_rate * 1e-3;  // N per 1 ms tick
  double largest_step = 0.0, largest_force = 0.0;
  Eigen::Vector3d previous = Eigen::Vector3d::Zero();
  for (std::size_t r = 0; r < device.record_count(); ++r) {
    const ForceRecord& f = device.record(r);
    largest_step = std::max(largest_step, (f.force - previous).norm());
    largest_force = std::max(largest_force, f.force.norm());
    previous = f.force;
    if (f.in_contact && f.time > 0.6 && f.time < 1.1) {
      // Sliding along +x on the side: the cone about +y, widened by the
      // 24-sided section's faces (their normals lie within 7.5° of +y).
      const double normal = f.force.y(), tangential = std::hypot(f.force.x(), f.force.z());
      const double widened = std::tan(std::atan(options.friction) + M_PI / 24.0);
      EXPECT_LE(tangential, widened * normal) << label << " at " << f.time;
    }
    if (f.time > 1.45) {
      EXPECT_EQ(f.force, Eigen::Vector3d::Zero()) << label << " at " << f.time;
    }
  }
  ::testing::Test::RecordProperty(label + "_largest_step_mN", std::to_string(largest_step * 1e3));
  ::testing::Test::RecordProperty(label + "_largest_force_mN", std::to_string(largest_force * 1e3));
  EXPECT_GT(largest_force, step_limit) << label << ": the press is felt";
  // The onset limit bounds the magnitude's growth; a turn of the force as
  // it grows may add a little.
  EXPECT_LE(largest_step, 1.1 * step_limit) << label;
}

// A 5 mm probe (the default tip) approaches the cylinder's side, presses
// 3 mm, slides 30 mm along it and leaves, replayed fast with every model: the
// force sent to the device never changes by more than the onset limit allows
// in one tick, rising or falling (it begins, slides and ends without a
// kick), the organ slips under the tip within Coulomb's cone (tangential
// force ≤ μ × normal force), and nothing is felt once the tip is out. The
// fast models run twice: with their own forces, and on a model with site
// compliances, where they give the site law's (docs/matching.md).
TEST_F(CylinderEngine, AFiniteTipEntersSlidesAndLeavesWithoutAForceJump) {
  for (const RegisteredModel* model : registered_models()) {
    if (std::string(model->name) == "stvk") continue;  // co-rotational's large-strain sibling: same contact code
    enter_slide_and_leave(organ, *model, model->name);
  }
  model::OrganModel with_sites = testing::make_cylinder_model(spec);  // the fast models give the site law's force
  testing::add_uniform_site_compliance(with_sites, 0.01);
  const organ::Organ matched(std::move(with_sites));
  for (const char* name : {"beam", "springs"})
    enter_slide_and_leave(matched, *find_model(name), std::string(name) + "_matched");
}

// A tool pressed 3 mm into the cylinder's side steps 0.2 mm deeper between two
// ticks: the force rises by the contact's stiffness times the step in the
// tick the step arrives, whether or not a fresh deformation frame arrives in
// that tick too (as every step of a tracker or a network client at 60 Hz may).
// The blend that ramps one frame's linearization into the next must not ramp
// the tool's own move: before, a step that met a frame took 1/60 s to be felt.
TEST_F(CylinderEngine, AStepThatArrivesWithAFreshFrameIsFeltAtOnce) {
  // N along +y (outward): the force's change from the tick before `step_time` to that tick.
  const auto rise_at = [&](const std::string& model, double step_time) {
    ScriptedDevice device(path({{0.0, {0.08, 0.045, 0.0}},
                                {0.3, {0.08, 0.027, 0.0}},
                                {step_time - 4e-4, {0.08, 0.027, 0.0}},
                                {step_time - 1e-4, {0.08, 0.0268, 0.0}}}),
                          {}, 2000);
    EngineOptions options;
    options.model = model;
    options.models.edit<fem::OrganFemOptions>().fixed_radius = 0.031;  // the clamped cap
    Engine engine(organ, {&device}, options);
    run_fast(engine, step_time + 0.05);
    Eigen::Vector3d before = Eigen::Vector3d::Constant(NAN), after = Eigen::Vector3d::Constant(NAN);
    for (std::size_t r = 0; r < device.record_count(); ++r) {
      const ForceRecord& f = device.record(r);
      if (std::abs(f.time - (step_time - 1e-3)) < 1e-7) before = f.force;
      if (std::abs(f.time - step_time) < 1e-7) after = f.force;
    }
    return after.y() - before.y();
  };
  const double device_onset_limit = SafetyLimits{}.onset_rate * 1e-3;  // N per 1 ms tick
  for (const char* model : {"beam", "springs", "linear"}) {
    // Frames come at multiples of 1/60 s: 0.5 s is the 30th; 0.508 s lies between two.
    const double between_frames = rise_at(model, 0.508), with_a_frame = rise_at(model, 0.5);
    ::testing::Test::RecordProperty(
        std::string(model) + "_rise_mN",
        std::to_string(1e3 * with_a_frame) + " with a frame, " + std::to_string(1e3 * between_frames) + " between");
    EXPECT_GT(between_frames, 1e-3) << model << ": the step is felt (N)";
    EXPECT_LT(between_frames, 0.9 * device_onset_limit) << model << ": below the onset limit's 40 mN a tick";
    EXPECT_NEAR(with_a_frame, between_frames, 0.1 * between_frames) << model;
  }
}

TEST_F(CylinderEngine, AShaftPressingSidewaysMakesContactAlongTheShaft) {
  // The tip stays below the organ (never inside it); the vertical shaft sweeps
  // into its side (y from +40 mm to +25 mm at x = 100 mm). The contact is where
  // the shaft entered, and the organ pushes the shaft back towards +y (and,
  // through the beam's much stiffer axial direction, along x as well).
  Trajectory t = path({{0.0, {0.1, 0.04, -0.06}}, {0.3, {0.1, 0.025, -0.06}}, {0.6, {0.1, 0.025, -0.06}}});
  t.shafts.assign(3, Eigen::Vector3d(0.0, 0.0, 1.0));
  SafetyLimits limits;
  limits.max_force = 10.0;
  ScriptedDevice device(t, limits, 1000);
  Engine engine(organ, {&device}, {});
  run_fast(engine, 0.6);
  EXPECT_EQ(engine.telemetry(0).contacts, 1u);
  const ForceRecord& last = device.record(device.record_count() - 1);
  EXPECT_TRUE(last.in_contact);
  EXPECT_GT(last.force[1], 0.01);
  EXPECT_LT(std::abs(last.force[2]), 0.2 * last.force.norm());
}

// A tip the surface came onto (resting 0.5 mm inside the far cap of a 0.6 m
// cylinder, its whole 0.30 m shaft inside the organ, so neither the tip's path
// nor the shaft crossed the surface): the contact is the tip's, and the organ
// pushes it out gently. (The shaft's offset was once taken from the shaft test
// that missed: the contact point 0.30 m up the shaft, the force at its limit.)
TEST_F(CylinderEngine, ATipTheSurfaceCameOntoTouchesWithItsTipAlone) {
  testing::CylinderSpec long_spec;
  long_spec.length = 0.6;
  const organ::Organ long_organ(testing::make_cylinder_model(long_spec));
  Trajectory t = path({{0.0, {0.5995, 0.0, 0.0}}, {0.3, {0.5995, 0.0, 0.0}}});
  t.shafts.assign(2, Eigen::Vector3d(-1.0, 0.0, 0.0));
  ScriptedDevice device(t, {}, 1000);
  Engine engine(long_organ, {&device}, {});
  run_fast(engine, 0.3);
  EXPECT_EQ(engine.telemetry(0).contacts, 1u);
  const ForceRecord& last = device.record(device.record_count() - 1);
  EXPECT_TRUE(last.in_contact);
  EXPECT_GT(last.force[0], 0.0);  // out of the cap, along +x
  EXPECT_LT(last.force.norm(), 0.2);
}

// One tool presses the free end's top down 10 mm, holds, and leaves; the
// other rests 0.5 mm below its bottom. The FEM organ comes down onto the
// resting tool, which is caught above the rest surface: its contact holds
// (it ends only once the tool draws back beyond where it began) and the
// organ pushes on it; once the press lets go the organ would pull the
// resting tool, and that contact ends too: the organ is at rest. (It ended
// on its first force tick, began again the next frame, and so on.)
TEST_F(CylinderEngine, AnOrganThatMovesOntoARestingToolPushesOnIt) {
  ScriptedDevice pressing(path({{0.0, {0.14, 0.04, 0.0}},
                                {0.4, {0.14, 0.02, 0.0}},
                                {1.0, {0.14, 0.02, 0.0}},
                                {1.2, {0.14, 0.04, 0.0}},
                                {1.6, {0.14, 0.04, 0.0}}}),
                          {}, 2000);
  ScriptedDevice resting(path({{0.0, {0.145, -0.0305, 0.0}}, {1.6, {0.145, -0.0305, 0.0}}}), {}, 2000);
  EngineOptions options;
  options.model = "corotational";
  options.models.edit<fem::OrganFemOptions>().fixed_radius = 0.031;  // the clamped cap
  Engine engine(organ, {&pressing, &resting}, options);
  run_fast(engine, 1.6);
  EXPECT_EQ(engine.telemetry(0).contacts, 1u);
  EXPECT_EQ(engine.telemetry(1).contacts, 1u);
  Eigen::Vector3d held = Eigen::Vector3d::Zero();
  for (std::size_t r = 0; r < resting.record_count(); ++r)
    if (std::abs(resting.record(r).time - 1.0) < 1e-9) held = resting.record(r).force;
  EXPECT_LT(held[1], -0.01) << "the organ pushes the resting tool down";
  const ForceRecord& last = resting.record(resting.record_count() - 1);
  EXPECT_FALSE(last.in_contact) << "the organ hangs on the resting tool";
  engine.surfaces().update();
  EXPECT_EQ(engine.surfaces().read().positions, organ.model().surface_vertices) << "the organ is not at rest";
}

// A tool whose pose is lost while pressing and found again 20 mm away (taken
// off the organ and placed elsewhere) does not resume the old contact: it
// would be dragged back to the old spot with the force limit. Found again
// where it was lost, it resumes (OpenHaptics.ADeviceThatFailsMidSession…).
TEST_F(CylinderEngine, AToolPlacedElsewhereWhileItsPoseWasLostLetsGoOfItsContact) {
  const double lost = std::numeric_limits<double>::quiet_NaN();  // a non-finite pose is no pose
  ScriptedDevice device(path({{0.0, {0.16, 0.0, 0.0}},
                              {0.3, {0.144, 0.0, 0.0}},
                              {0.45, {0.144, 0.0, 0.0}},
                              {0.4505, {lost, lost, lost}},
                              {0.5495, {lost, lost, lost}},
                              {0.55, {0.144, 0.0, 0.02}},
                              {1.0, {0.144, 0.0, 0.02}}}),
                        {}, 1000);
  Engine engine(organ, {&device}, {});
  run_fast(engine, 1.0);
  double pressed = 0.0;
  for (std::size_t r = 0; r < device.record_count(); ++r)
    if (device.record(r).time < 0.45) pressed = std::max(pressed, device.record(r).force.norm());
  EXPECT_GT(pressed, 0.1);
  const ForceRecord& last = device.record(device.record_count() - 1);
  EXPECT_LT(last.force.norm(), 0.2 * pressed) << "the old contact resumed";
}

TEST_F(CylinderEngine, FastModeIsBitIdenticalAcrossRuns) {
  auto run = [&] {
    ScriptedDevice a(path({{0.0, {0.16, 0.0, 0.0}}, {0.4, {0.144, 0.003, 0.0}}, {0.6, {0.16, 0.0, 0.0}}}), {}, 1000);
    ScriptedDevice b(path({{0.0, {0.08, 0.04, 0.0}}, {0.3, {0.08, 0.026, 0.001}}, {0.6, {0.08, 0.04, 0.0}}}), {}, 1000);
    Engine engine(organ, {&a, &b}, {});
    run_fast(engine, 0.6);
    std::vector<double> forces;
    for (const ScriptedDevice* d : {&a, &b})
      for (std::size_t r = 0; r < d->record_count(); ++r)
        for (int k = 0; k < 3; ++k) forces.push_back(d->record(r).force[k]);
    return forces;
  };
  const std::vector<double> first = run(), second = run();
  ASSERT_EQ(first.size(), second.size());
  EXPECT_EQ(std::memcmp(first.data(), second.data(), first.size() * sizeof(double)), 0);
  double peak = 0.0;
  for (double f : first) peak = std::max(peak, std::abs(f));
  EXPECT_GT(peak, 0.01);
}

TEST_F(CylinderEngine, AStalledDeformationLoopFadesTheForceOut) {
  ScriptedDevice device(path({{0.0, {0.16, 0.0, 0.0}}, {0.2, {0.146, 0.0, 0.0}}, {2.0, {0.146, 0.0, 0.0}}}), {}, 3000);
  Engine engine(organ, {&device}, {});
  run_fast(engine, 0.5);  // in contact, steady force
  const double steady = device.record(device.record_count() - 1).force.norm();
  ASSERT_GT(steady, 0.05);
  // Only the force loop runs from now on (the simulation has stalled).
  for (int tick = 501; tick <= 1000; ++tick) engine.force_tick(tick * 1e-3);
  double at_250ms = 0.0;
  for (std::size_t r = 0; r < device.record_count(); ++r)
    if (std::abs(device.record(r).time - 0.75) < 1e-9) at_250ms = device.record(r).force.norm();
  EXPECT_LT(at_250ms, 0.5 * steady);  // ramping down (stalled for 0.25 s: timeout 0.1 s, ramp 0.2 s)
  EXPECT_EQ(device.record(device.record_count() - 1).force.norm(), 0.0);
}

}  // namespace
}  // namespace organsim::realtime
