// A stand-in for the OpenHaptics HD library (libHD.so) for tests: the same C
// entry points, a servo scheduler thread at 1 kHz, devices whose tip follows a
// straight path set by the test, and a record of every force commanded (with
// its frame's time and whether the frame reported an error).
// Positions are millimetres, forces newtons, as in the real library.
#include <array>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <thread>
#include <vector>

#include "hd_abi.h"

namespace {

using namespace organsim::devices::hd;

struct ForceSample {
  std::array<double, 3> newtons;
  double frame_time;  // s after the scheduler started, taken when the frame began
  bool frame_failed;  // hdGetError reported an error in this frame before the force was set
};

struct Device {
  std::array<double, 3> from{}, to{};
  double seconds = 1.0;
  bool force_output = false;
  bool in_frame = false;
  double frame_time = 0.0;
  bool frame_failed = false;
  std::atomic<unsigned> error{0};  // set by fakehd_fail: every hdGetError reports it, as for a lost device
  std::vector<ForceSample> forces;
  std::atomic<double> latest_force{0.0};  // |F| of the last force set, N: readable while the scheduler runs
  std::atomic<double> press_from{-1.0}, press_to{-1.0};  // s: the stylus's first button is down between them
};

constexpr int kDevices = 4;
constexpr double kMaxForce = 2.5;      // N: below organsim's default, so that the device's limit shows
constexpr double kMaxStiffness = 0.8;  // N/mm

Device devices[kDevices];
int opened = 0;
thread_local HHD current = 0;
std::atomic<bool> running{false};
std::thread scheduler;
HDSchedulerCallback callback = nullptr;
void* callback_data = nullptr;
std::atomic<std::uint64_t> ticks{0};
std::atomic<int> frame_errors{0};
std::chrono::steady_clock::time_point start;

double seconds_since_start() { return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(); }

// FAKEHD_FAIL="DEVICE:FROM_S:TO_S:CODE" (for tests of the organsim program):
// device DEVICE reports CODE from FROM_S to TO_S after the scheduler started.
unsigned scheduled_error(HHD device) {
  static const char* plan = std::getenv("FAKEHD_FAIL");
  if (plan == nullptr) return 0;
  unsigned which = 0, code = 0;
  double from = 0.0, to = 0.0;
  if (std::sscanf(plan, "%u:%lf:%lf:%u", &which, &from, &to, &code) != 4 || which != device) return 0;
  const double t = seconds_since_start();
  return running.load() && t >= from && t < to ? code : 0;
}

unsigned error_of(HHD device) {
  if (device >= kDevices) return 0;
  const unsigned set = devices[device].error.load();
  return set != 0 ? set : scheduled_error(device);
}

}  // namespace

extern "C" {

HHD hdInitDevice(const char*) {
  if (opened == kDevices) return kInvalidHandle;
  devices[opened].forces.reserve(100000);
  return static_cast<HHD>(opened++);
}
void hdDisableDevice(HHD) {}
void hdMakeCurrentDevice(HHD device) { current = device; }
void hdBeginFrame(HHD device) {
  Device& d = devices[device];
  d.in_frame = true;
  d.frame_time = seconds_since_start();
  d.frame_failed = false;
  current = device;
}
void hdEndFrame(HHD device) { devices[device].in_frame = false; }
void hdEnable(HDenum capability) {
  if (capability == kForceOutput) devices[current].force_output = true;
}

void hdGetDoublev(HDenum what, double* values) {
  const Device& d = devices[current];
  if (error_of(current) != 0) return;  // nothing read from a lost device
  switch (what) {
    case kCurrentPosition:
    case kCurrentTransform: {  // identity rotation (stylus along −z), translation
      const double t = seconds_since_start();
      const double s = t < 0.0 ? 0.0 : (t > d.seconds ? 1.0 : t / d.seconds);
      double* position = values;
      if (what == kCurrentTransform) {
        for (int k = 0; k < 16; ++k) values[k] = k % 5 == 0 ? 1.0 : 0.0;
        position = values + 12;
      }
      for (int k = 0; k < 3; ++k) position[k] = d.from[k] + s * (d.to[k] - d.from[k]);
      break;
    }
    case kNominalMaxForce: values[0] = kMaxForce; break;
    case kNominalMaxStiffness: values[0] = kMaxStiffness; break;
    default: break;
  }
}

void hdGetIntegerv(HDenum what, int* values) {
  const Device& d = devices[current];
  if (error_of(current) != 0 || what != kCurrentButtons) return;
  const double t = seconds_since_start();
  values[0] = t >= d.press_from.load() && t < d.press_to.load() ? kDeviceButton1 : 0;
}

void hdSetDoublev(HDenum what, const double* values) {
  Device& d = devices[current];
  if (what != kCurrentForce) return;
  if (!d.in_frame || !d.force_output) frame_errors.fetch_add(1);
  d.forces.push_back({{values[0], values[1], values[2]}, d.frame_time, d.frame_failed});
  d.latest_force.store(std::sqrt(values[0] * values[0] + values[1] * values[1] + values[2] * values[2]));
}

void hdStartScheduler() {
  if (running.exchange(true)) return;
  start = std::chrono::steady_clock::now();
  scheduler = std::thread([] {
    auto next = std::chrono::steady_clock::now();
    while (running.load()) {
      next += std::chrono::microseconds(1000);
      std::this_thread::sleep_until(next);
      if (callback != nullptr && callback(callback_data) == kCallbackDone) callback = nullptr;
      ticks.fetch_add(1);
    }
  });
}
void hdStopScheduler() {
  if (!running.exchange(false)) return;
  scheduler.join();
}
HDSchedulerHandle hdScheduleAsynchronous(HDSchedulerCallback function, void* data, unsigned short) {
  callback = function;
  callback_data = data;
  return 1;
}
void hdUnschedule(HDSchedulerHandle) { callback = nullptr; }
HDErrorInfo hdGetError() {
  const unsigned code = error_of(current);
  if (code != 0 && current < kDevices && devices[current].in_frame) devices[current].frame_failed = true;
  return {code, 0, code != 0 ? current : 0};
}

// --- test controls ---
void fakehd_set_path(HHD device, const double* from_mm, const double* to_mm, double seconds) {
  for (int k = 0; k < 3; ++k) {
    devices[device].from[k] = from_mm[k];
    devices[device].to[k] = to_mm[k];
  }
  devices[device].seconds = seconds;
}
// The stylus's first button is held down from `from_s` to `to_s` after the scheduler started.
void fakehd_press_button(HHD device, double from_s, double to_s) {
  devices[device].press_from.store(from_s);
  devices[device].press_to.store(to_s);
}
// The device fails (code ≠ 0: its pose freezes and every call reports the
// error, as a disconnected device does) or recovers (code 0).
void fakehd_fail(HHD device, unsigned code) { devices[device].error.store(code); }
std::uint64_t fakehd_ticks() { return ticks.load(); }
int fakehd_frame_errors() { return frame_errors.load(); }
std::size_t fakehd_force_count(HHD device) { return devices[device].forces.size(); }
// |F| of the last force the device was given (N); safe while the scheduler runs.
double fakehd_latest_force(HHD device) { return devices[device].latest_force.load(); }
void fakehd_force(HHD device, std::size_t i, double* newtons) {
  for (int k = 0; k < 3; ++k) newtons[k] = devices[device].forces[i].newtons[k];
}
double fakehd_force_frame_time(HHD device, std::size_t i) { return devices[device].forces[i].frame_time; }
int fakehd_force_frame_failed(HHD device, std::size_t i) { return devices[device].forces[i].frame_failed ? 1 : 0; }

}  // extern "C"
