// The OpenHaptics backend end to end against the stand-in HD library: loaded at
// run time, its servo scheduler drives the force loop at 1 kHz, device limits
// and units are respected, and the forces are the beam's.
#include <dlfcn.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include <gtest/gtest.h>

#include "organsim/openhaptics/openhaptics.h"
#include "organsim/realtime/engine.h"
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
  const organ::Organ organ(testing::make_cylinder_model(spec));

  OpenHapticsDevice device(library, "", DevicePlacement{}, devices::SafetyLimits{});
  EXPECT_DOUBLE_EQ(device.limits().max_force, 2.5);        // the device's nominal maximum, below the default 3.3 N
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

// Held down, the stylus's first button closes a grasper's jaws: pressed once
// the tool is in the organ, it grasps; a tool whose button is never pressed
// only pushes.
TEST(OpenHaptics, TheStylusButtonClosesTheJaws) {
  const HdLibrary library(FAKE_HD_LIBRARY);
  const testing::CylinderSpec spec;  // far cap at x = 150 mm, clamped at x = 0
  const organ::Organ organ(testing::make_cylinder_model(spec));
  for (const bool press : {true, false}) {
    OpenHapticsDevice device(library, "", DevicePlacement{}, devices::SafetyLimits{});
    const double from[3] = {160.0, 0.0, 0.0}, to[3] = {146.0, 0.0, 0.0};  // 4 mm into the far cap by 0.3 s
    control<void (*)(unsigned, const double*, const double*, double)>("fakehd_set_path")(device.handle(), from, to,
                                                                                         0.3);
    if (press) control<void (*)(unsigned, double, double)>("fakehd_press_button")(device.handle(), 0.45, 100.0);
    realtime::Engine engine(organ, {&device}, {});
    OpenHapticsServo servo(library, {&device}, engine);
    const auto begin = std::chrono::steady_clock::now();
    servo.start();
    auto next = begin;
    while (std::chrono::steady_clock::now() - begin < std::chrono::milliseconds(700)) {
      engine.deformation_step(std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count());
      next += std::chrono::microseconds(16667);
      std::this_thread::sleep_until(next);
    }
    servo.stop();
    EXPECT_EQ(engine.telemetry(0).contacts, 1u) << press;
    EXPECT_EQ(engine.telemetry(0).grasps, press ? 1u : 0u);
  }
}

// A device reports errors mid-session (a lost USB/FireWire link): its force
// fades from what the hand felt to zero over ramp_down_time, never jumping up,
// the other device keeps its force, the event is counted, and after the device
// comes back its force returns through the onset ramp. The fade and the onset
// are judged against each frame's time, not its index: the VM may hold the
// servo thread back for milliseconds, and the scheduler then catches up.
TEST(OpenHaptics, ADeviceThatFailsMidSessionFadesItsForceWhileTheOtherGoesOn) {
  const HdLibrary library(FAKE_HD_LIBRARY);
  const organ::Organ organ(testing::make_cylinder_model({}));
  // The simulation watchdog (a deformation loop silent for stall_timeout) has
  // its own tests; here it must not fade the force when the test's thread is
  // held back, so that what fades is the device fault alone.
  devices::SafetyLimits limits;
  limits.stall_timeout = 10.0;
  OpenHapticsDevice lost(library, "", DevicePlacement{}, limits);
  OpenHapticsDevice steady(library, "", DevicePlacement{}, limits);
  // Both press in within 0.2 s and hold: the far cap along −x, the side along −y.
  const double cap_from[3] = {160.0, 0.0, 0.0}, cap_to[3] = {146.0, 0.0, 0.0};
  const double side_from[3] = {80.0, 40.0, 0.0}, side_to[3] = {80.0, 27.0, 0.0};
  const auto set_path = control<void (*)(unsigned, const double*, const double*, double)>("fakehd_set_path");
  set_path(lost.handle(), cap_from, cap_to, 0.2);
  set_path(steady.handle(), side_from, side_to, 0.2);
  const auto fail = control<void (*)(unsigned, unsigned)>("fakehd_fail");
  const auto force_count = control<std::size_t (*)(unsigned)>("fakehd_force_count");
  const auto frame_time = control<double (*)(unsigned, std::size_t)>("fakehd_force_frame_time");
  const auto frame_failed = control<int (*)(unsigned, std::size_t)>("fakehd_force_frame_failed");
  auto force = [&](const OpenHapticsDevice& d, std::size_t i) {
    Eigen::Vector3d f;
    control<void (*)(unsigned, std::size_t, double*)>("fakehd_force")(d.handle(), i, f.data());
    return f.norm();
  };

  const auto latest_force = control<double (*)(unsigned)>("fakehd_latest_force");

  realtime::Engine engine(organ, {&lost, &steady}, {});
  OpenHapticsServo servo(library, {&lost, &steady}, engine);
  const auto begin = std::chrono::steady_clock::now();
  // The fault comes once both tools have held their press for 0.15 s (on a
  // loaded machine a contact may begin late), lasts 0.4 s, and the run goes
  // on 0.6 s after it.
  constexpr double kHolding = 0.05, kHeldFor = 0.15, kFaultFor = 0.4, kAfter = 0.6, kGiveUp = 5.0;
  double holding_since = -1.0, failed_at = -1.0, recovered_at_time = -1.0;
  servo.start();
  auto next = begin;
  while (true) {
    const double t = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
    if (t > kGiveUp || (recovered_at_time >= 0.0 && t > recovered_at_time + kAfter)) break;
    const bool holding = latest_force(lost.handle()) > kHolding && latest_force(steady.handle()) > kHolding;
    if (!holding)
      holding_since = -1.0;
    else if (holding_since < 0.0)
      holding_since = t;
    if (failed_at < 0.0 && t > 0.6 && holding_since >= 0.0 && t > holding_since + kHeldFor) {
      fail(lost.handle(), 0x0302);  // HD_COMM_ERROR
      failed_at = t;
    }
    if (failed_at >= 0.0 && recovered_at_time < 0.0 && t > failed_at + kFaultFor) {
      fail(lost.handle(), 0);
      recovered_at_time = t;
    }
    engine.deformation_step(t);
    next += std::chrono::microseconds(16667);
    std::this_thread::sleep_until(next);
  }
  servo.stop();
  ASSERT_GE(recovered_at_time, 0.0) << "the two tools never both held their press";

  // The frames in which the device reported the error: one run of them.
  const std::size_t end = force_count(lost.handle());
  std::size_t first_failed = end, failed_frames = 0;
  for (std::size_t i = 0; i < end; ++i) {
    if (frame_failed(lost.handle(), i) == 0) continue;
    first_failed = std::min(first_failed, i);
    ++failed_frames;
  }
  ASSERT_GT(failed_frames, 0u);
  ASSERT_GT(first_failed, 0u);
  const std::size_t recovered_at = first_failed + failed_frames;
  for (std::size_t i = first_failed; i < recovered_at; ++i) ASSERT_EQ(frame_failed(lost.handle(), i), 1) << i;
  const double fault_start = frame_time(lost.handle(), first_failed);
  constexpr double kRamp = devices::SafetyLimits{}.ramp_down_time;                     // s
  ASSERT_GT(frame_time(lost.handle(), recovered_at - 1) - fault_start, kRamp + 0.05);  // failed longer than the ramp

  const double held = force(lost, first_failed - 1);
  ASSERT_GT(held, 0.3);  // pressing when it failed
  // While failed: never above the held force, non-increasing, following the
  // linear fade in time (within 5 ms of it: the frame's stamp and the engine's
  // clock are read microseconds apart), zero after the ramp.
  double previous = held;
  for (std::size_t i = first_failed; i < recovered_at; ++i) {
    const double since = frame_time(lost.handle(), i) - fault_start;
    const double fade = std::clamp(1.0 - since / kRamp, 0.0, 1.0);
    EXPECT_LE(force(lost, i), previous + 1e-12) << i;
    EXPECT_NEAR(force(lost, i), fade * held, held * 0.005 / kRamp) << i << " at " << since << " s";
    if (since > kRamp + 0.005) {
      EXPECT_EQ(force(lost, i), 0.0) << i << " at " << since << " s";
    }
    previous = force(lost, i);
  }
  EXPECT_EQ(previous, 0.0);
  // The other device kept pressing, its force steady (the lost tool's contact,
  // still held in the deformation model, changes it only a little).
  const double steady_held = force(steady, first_failed - 1);
  ASSERT_GT(steady_held, 0.05);
  for (std::size_t i = first_failed; i < recovered_at; ++i)
    ASSERT_NEAR(force(steady, i), steady_held, 0.2 * steady_held) << i;
  // Reported: error ticks and the code on the device, one fault on the engine's
  // telemetry. An error that arrives between a tick's pose and its force is
  // counted in that tick too, without failing its pose.
  EXPECT_GE(lost.error_ticks(), failed_frames);
  EXPECT_LE(lost.error_ticks(), failed_frames + 1);
  EXPECT_EQ(lost.last_error(), 0x0302u);
  EXPECT_EQ(steady.error_ticks(), 0u);
  EXPECT_EQ(engine.telemetry(0).pose_faults, 1u);
  EXPECT_EQ(engine.telemetry(1).pose_faults, 0u);
  // Back: the force returns, rising no faster than the onset rate (40 N/s)
  // over the time between frames (plus 1 ms: stamp and clock differ slightly).
  constexpr double kOnsetRate = devices::SafetyLimits{}.onset_rate;  // N/s
  ASSERT_LT(recovered_at, end);
  EXPECT_GT(force(lost, end - 1), 0.5 * held);
  for (std::size_t i = recovered_at; i < end; ++i) {
    const double dt = frame_time(lost.handle(), i) - frame_time(lost.handle(), i - 1);
    ASSERT_LE(force(lost, i) - force(lost, i - 1), kOnsetRate * (dt + 0.001)) << i;
  }
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
