// The OpenHaptics backend end to end against the stand-in HD library: loaded at
// run time, its servo scheduler drives the force loop at 1 kHz, device limits
// and units are respected, and the forces are the beam's.
#include <dlfcn.h>

#include <chrono>
#include <cmath>
#include <thread>

#include <gtest/gtest.h>

#include "organsim/devices/openhaptics.h"
#include "test_models.h"

namespace organsim::devices {
namespace {

template <typename Function>
Function control(const char* name) {
  void* library = dlopen(FAKE_HD_LIBRARY, RTLD_NOW | RTLD_NOLOAD);
  EXPECT_NE(library, nullptr);
  auto function = reinterpret_cast<Function>(dlsym(library, name));
  dlclose(library);
  return function;
}

TEST(OpenHaptics, ServoDrivesTheForceLoopWithinTheDeviceLimits) {
  const HdLibrary library(FAKE_HD_LIBRARY);
  const testing::CylinderSpec spec;  // far cap at x = 150 mm, clamped at x = 0
  const multibeam::BeamOrgan organ(testing::make_cylinder_model(spec));

  OpenHapticsDevice device(library, "", DevicePlacement{}, devices::SafetyLimits{});
  EXPECT_DOUBLE_EQ(device.limits().max_force, 2.5);       // the device's nominal maximum, below the default 3.3 N
  EXPECT_DOUBLE_EQ(device.limits().max_stiffness, 800.0);  // 0.8 N/mm
  // The tool moves from 10 mm off the far cap to 6 mm into it in 0.3 s, then holds.
  const double from[3] = {160.0, 0.0, 0.0}, to[3] = {144.0, 0.0, 0.0};
  control<void (*)(unsigned, const double*, const double*, double)>("fakehd_set_path")(device.handle(), from, to, 0.3);

  realtime::Engine engine(organ, {&device}, {});
  OpenHapticsServo servo(library, {&device}, engine);
  const auto begin = std::chrono::steady_clock::now();
  servo.start();
  // The deformation loop, here on the test's thread at 60 Hz, for 0.8 s.
  auto next = begin;
  while (std::chrono::steady_clock::now() - begin < std::chrono::milliseconds(800)) {
    engine.deformation_step(std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count());
    next += std::chrono::microseconds(16667);
    std::this_thread::sleep_until(next);
  }
  servo.stop();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();

  const auto ticks = control<std::uint64_t (*)()>("fakehd_ticks")();
  EXPECT_NEAR(static_cast<double>(ticks) / seconds, 1000.0, 300.0);  // wide: CI runs two test programs at once
  EXPECT_EQ(servo.ticks(), ticks);
  EXPECT_EQ(control<int (*)()>("fakehd_frame_errors")(), 0);  // forces only inside servo frames, output enabled
  const auto count = control<std::size_t (*)(unsigned)>("fakehd_force_count")(device.handle());
  EXPECT_EQ(count, ticks);
  auto force = [&](std::size_t i) {
    Eigen::Vector3d f;
    control<void (*)(unsigned, std::size_t, double*)>("fakehd_force")(device.handle(), i, f.data());
    return f;
  };
  double peak = 0.0;
  for (std::size_t i = 0; i < count; ++i) {
    ASSERT_TRUE(force(i).allFinite()) << i;
    peak = std::max(peak, force(i).norm());
  }
  EXPECT_LE(peak, 2.5 + 1e-12);
  EXPECT_EQ(engine.telemetry(0).contacts, 1u);
  // Held 6 mm in: the axial beam force EAδ/L, in newtons, pushing back along +x.
  const double expected = organ.model().material.young_modulus * M_PI * spec.radius * spec.radius * 0.006 / spec.length;
  const Eigen::Vector3d last = force(count - 1);
  EXPECT_NEAR(last[0], expected, 1e-3 * expected);
  EXPECT_NEAR(last[1], 0.0, 1e-6);
}

TEST(OpenHaptics, MissingLibraryIsAClearError) {
  try {
    HdLibrary library("/nonexistent/libHD.so");
    FAIL() << "loaded a library that does not exist";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot load the OpenHaptics HD library"), std::string::npos) << e.what();
  }
  try {
    HdLibrary library("libm.so.6");  // a library, but not the HD API
    FAIL() << "accepted a library without the HD API";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("hdInitDevice"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace organsim::devices
