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

// A device reports errors mid-session (a lost USB/FireWire link): its force
// fades from what the hand felt to zero over ramp_down_time, never jumping up,
// the other device keeps its force, the event is counted, and after the device
// comes back its force returns through the onset ramp.
TEST(OpenHaptics, ADeviceThatFailsMidSessionFadesItsForceWhileTheOtherGoesOn) {
  const HdLibrary library(FAKE_HD_LIBRARY);
  const multibeam::BeamOrgan organ(testing::make_cylinder_model({}));
  OpenHapticsDevice lost(library, "", DevicePlacement{}, devices::SafetyLimits{});
  OpenHapticsDevice steady(library, "", DevicePlacement{}, devices::SafetyLimits{});
  // Both press in within 0.2 s and hold: the far cap along −x, the side along −y.
  const double cap_from[3] = {160.0, 0.0, 0.0}, cap_to[3] = {146.0, 0.0, 0.0};
  const double side_from[3] = {80.0, 40.0, 0.0}, side_to[3] = {80.0, 27.0, 0.0};
  const auto set_path = control<void (*)(unsigned, const double*, const double*, double)>("fakehd_set_path");
  set_path(lost.handle(), cap_from, cap_to, 0.2);
  set_path(steady.handle(), side_from, side_to, 0.2);
  const auto fail = control<void (*)(unsigned, unsigned)>("fakehd_fail");
  const auto force_count = control<std::size_t (*)(unsigned)>("fakehd_force_count");
  auto force = [&](const OpenHapticsDevice& d, std::size_t i) {
    Eigen::Vector3d f;
    control<void (*)(unsigned, std::size_t, double*)>("fakehd_force")(d.handle(), i, f.data());
    return f.norm();
  };

  realtime::Engine engine(organ, {&lost, &steady}, {});
  OpenHapticsServo servo(library, {&lost, &steady}, engine);
  const auto begin = std::chrono::steady_clock::now();
  std::size_t failed_at = 0, recovered_at = 0;
  servo.start();
  auto next = begin;
  while (true) {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
    if (t > 1.6) break;
    if (failed_at == 0 && t > 0.6) {
      failed_at = force_count(lost.handle());
      fail(lost.handle(), 0x0302);  // HD_COMM_ERROR
    }
    if (recovered_at == 0 && t > 1.0) {
      recovered_at = force_count(lost.handle());
      fail(lost.handle(), 0);
    }
    engine.deformation_step(t);
    next += std::chrono::microseconds(16667);
    std::this_thread::sleep_until(next);
  }
  servo.stop();

  const double held = force(lost, failed_at - 1);
  ASSERT_GT(held, 0.3);  // pressing when it failed
  // While failed (0.4 s, longer than the 0.2 s ramp): never above the held
  // force, non-increasing, zero by the end of the ramp (plus the servo's jitter).
  double previous = held;
  std::size_t zero_from = recovered_at;
  for (std::size_t i = failed_at; i < recovered_at; ++i) {
    EXPECT_LE(force(lost, i), previous + 1e-12) << i;
    previous = force(lost, i);
    if (previous == 0.0 && zero_from == recovered_at) zero_from = i;
  }
  EXPECT_EQ(previous, 0.0);
  EXPECT_GT(zero_from - failed_at, 100u);  // faded, not dropped: more than 0.1 s of ticks
  EXPECT_LT(zero_from - failed_at, 300u);
  EXPECT_GT(force(lost, failed_at + 20), 0.5 * held);  // 20 ms in: most of it still there
  // The other device kept pressing, its force steady (the lost tool's contact,
  // still held in the deformation model, changes it only a little).
  const double steady_held = force(steady, failed_at - 1);
  ASSERT_GT(steady_held, 0.05);
  for (std::size_t i = failed_at; i < recovered_at; ++i)
    ASSERT_NEAR(force(steady, i), steady_held, 0.2 * steady_held) << i;
  // Reported: error ticks and the code on the device, one fault on the engine's telemetry.
  EXPECT_GT(lost.error_ticks(), 300u);
  EXPECT_EQ(lost.last_error(), 0x0302u);
  EXPECT_EQ(steady.error_ticks(), 0u);
  EXPECT_EQ(engine.telemetry(0).pose_faults, 1u);
  EXPECT_EQ(engine.telemetry(1).pose_faults, 0u);
  // Back: the force returns, rising no faster than the onset rate (40 N/s).
  const std::size_t end = force_count(lost.handle());
  EXPECT_GT(force(lost, end - 1), 0.5 * held);
  for (std::size_t i = recovered_at + 1; i < end; ++i)
    ASSERT_LE(force(lost, i) - force(lost, i - 1), 40.0 * 0.004) << i;  // ≤ 4 ms of onset per tick, with jitter
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
