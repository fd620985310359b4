#include "organsim/openhaptics/openhaptics.h"

#include <dlfcn.h>
#include <time.h>

#include <algorithm>
#include <stdexcept>
#include <type_traits>

#include "hd_abi.h"

namespace organsim::devices {
namespace {

using namespace hd;

double monotonic_seconds() {
  timespec t;
  clock_gettime(CLOCK_MONOTONIC, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

}  // namespace

struct HdLibrary::Api {
  HHD (*init_device)(const char*);
  void (*disable_device)(HHD);
  void (*make_current_device)(HHD);
  void (*begin_frame)(HHD);
  void (*end_frame)(HHD);
  void (*get_doublev)(HDenum, double*);
  void (*get_integerv)(HDenum, int*);
  void (*set_doublev)(HDenum, const double*);
  void (*enable)(HDenum);
  void (*start_scheduler)();
  void (*stop_scheduler)();
  HDSchedulerHandle (*schedule_asynchronous)(HDSchedulerCallback, void*, unsigned short);
  void (*unschedule)(HDSchedulerHandle);
  HDErrorInfo (*get_error)();
};

HdLibrary::HdLibrary(const std::string& path) : api_(std::make_unique<Api>()) {
  handle_ = dlopen(path.c_str(), RTLD_NOW | RTLD_LOCAL);
  if (handle_ == nullptr)
    throw std::runtime_error("cannot load the OpenHaptics HD library " + path + " (" + dlerror() +
                             "); install OpenHaptics / the Touch device driver, or give its path");
  auto resolve = [&](auto& function, const char* name) {
    void* symbol = dlsym(handle_, name);
    if (symbol == nullptr) {
      dlclose(handle_);
      handle_ = nullptr;
      throw std::runtime_error(path + " has no " + name + "; it is not an OpenHaptics HD library");
    }
    function = reinterpret_cast<std::remove_reference_t<decltype(function)>>(symbol);
  };
  resolve(api_->init_device, "hdInitDevice");
  resolve(api_->disable_device, "hdDisableDevice");
  resolve(api_->make_current_device, "hdMakeCurrentDevice");
  resolve(api_->begin_frame, "hdBeginFrame");
  resolve(api_->end_frame, "hdEndFrame");
  resolve(api_->get_doublev, "hdGetDoublev");
  resolve(api_->get_integerv, "hdGetIntegerv");
  resolve(api_->set_doublev, "hdSetDoublev");
  resolve(api_->enable, "hdEnable");
  resolve(api_->start_scheduler, "hdStartScheduler");
  resolve(api_->stop_scheduler, "hdStopScheduler");
  resolve(api_->schedule_asynchronous, "hdScheduleAsynchronous");
  resolve(api_->unschedule, "hdUnschedule");
  resolve(api_->get_error, "hdGetError");
}

HdLibrary::~HdLibrary() {
  if (handle_ != nullptr) dlclose(handle_);
}

OpenHapticsDevice::OpenHapticsDevice(const HdLibrary& library, const std::string& name,
                                     const DevicePlacement& placement, const SafetyLimits& limits)
    : library_(library), placement_(placement), limits_(limits) {
  const HdLibrary::Api& hd = library.api();
  handle_ = hd.init_device(name.empty() ? nullptr : name.c_str());
  const HDErrorInfo error = hd.get_error();
  if (handle_ != kInvalidHandle && error.errorCode != 0) hd.disable_device(handle_);
  if (handle_ == kInvalidHandle || error.errorCode != 0)
    throw std::runtime_error("cannot open the haptic device " + (name.empty() ? std::string("(default)") : name) +
                             " (HD error " + std::to_string(error.errorCode) +
                             "); check that it is connected and configured (Touch Setup)");
  hd.make_current_device(handle_);
  double max_force = 0.0, max_stiffness = 0.0;
  hd.get_doublev(kNominalMaxForce, &max_force);
  hd.get_doublev(kNominalMaxStiffness, &max_stiffness);
  if (max_force > 0.0) limits_.max_force = std::min(limits_.max_force, max_force);
  if (max_stiffness > 0.0) limits_.max_stiffness = std::min(limits_.max_stiffness, max_stiffness * 1e3);  // N/mm → N/m
  // A model displacement is `scale` times the hand's, and forces are not
  // scaled: the hand feels scale × K, so K is limited to the device's limit / scale.
  limits_.max_stiffness /= placement_.scale;
  hd.enable(kForceOutput);
}

OpenHapticsDevice::~OpenHapticsDevice() { library_.api().disable_device(handle_); }

bool OpenHapticsDevice::read_pose(double, ToolPose& pose) noexcept {
  const HdLibrary::Api& hd = library_.api();
  double transform[16] = {1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  hd.make_current_device(handle_);
  hd.get_doublev(kCurrentTransform, transform);
  int buttons = 0;
  hd.get_integerv(kCurrentButtons, &buttons);
  error_this_tick_ = false;
  if (note_error()) {
    seen_.write_slot().valid = false;
    seen_.publish();
    return false;
  }
  const Eigen::Vector3d device(transform[12] * 1e-3, transform[13] * 1e-3, transform[14] * 1e-3);
  const Eigen::Vector3d stylus_z(transform[8], transform[9], transform[10]);
  pose.tip = placement_.offset + placement_.scale * (placement_.rotation * device);
  pose.shaft =
      stylus_z.norm() > 0.0 ? Eigen::Vector3d(placement_.rotation * stylus_z.normalized()) : Eigen::Vector3d::Zero();
  // Held down, the stylus's front button closes a grasper's jaws (docs/realtime.md#grasping).
  pose.jaws_closed = (buttons & kDeviceButton1) != 0;
  const bool valid = pose.tip.allFinite() && pose.shaft.allFinite();
  seen_.write_slot() = {valid, pose};
  seen_.publish();
  return valid;
}

bool OpenHapticsDevice::last_pose(ToolPose& pose) {
  seen_.update();
  pose = seen_.read().pose;
  return seen_.read().valid;
}

Eigen::Vector3d OpenHapticsDevice::last_force() {
  sent_.update();
  return sent_.read();
}

void OpenHapticsDevice::write_force(double, const Eigen::Vector3d& force, bool) noexcept {
  sent_.write_slot() = force;
  sent_.publish();
  // Forces are not scaled with the workspace: newtons in the model are newtons on the hand.
  const Eigen::Vector3d device = placement_.rotation.transpose() * force;
  const double newtons[3] = {device[0], device[1], device[2]};
  const HdLibrary::Api& hd = library_.api();
  hd.make_current_device(handle_);
  hd.set_doublev(kCurrentForce, newtons);
  note_error();
}

// Reads the HD error stack; counts the tick once, however many errors it held.
bool OpenHapticsDevice::note_error() noexcept {
  const HDErrorInfo error = library_.api().get_error();
  if (error.errorCode == 0) return false;
  last_error_.store(error.errorCode, std::memory_order_relaxed);
  if (!error_this_tick_)
    error_ticks_.store(error_ticks_.load(std::memory_order_relaxed) + 1, std::memory_order_relaxed);
  error_this_tick_ = true;
  return true;
}

OpenHapticsServo::OpenHapticsServo(const HdLibrary& library, std::vector<OpenHapticsDevice*> devices, ForceLoop& loop)
    : library_(library), devices_(std::move(devices)), loop_(loop) {}

OpenHapticsServo::~OpenHapticsServo() { stop(); }

void OpenHapticsServo::start() {
  if (running_) return;
  const HdLibrary::Api& hd = library_.api();
  start_time_ = monotonic_seconds();
  schedule_ = hd.schedule_asynchronous(&OpenHapticsServo::tick, this, kMaxSchedulerPriority);
  hd.start_scheduler();
  const HDErrorInfo error = hd.get_error();
  if (error.errorCode != 0) {
    hd.stop_scheduler();
    hd.unschedule(schedule_);
    throw std::runtime_error("the HD servo scheduler did not start (HD error " + std::to_string(error.errorCode) + ")");
  }
  running_ = true;
}

void OpenHapticsServo::stop() noexcept {
  if (!running_) return;
  const HdLibrary::Api& hd = library_.api();
  hd.stop_scheduler();
  hd.unschedule(schedule_);
  running_ = false;
}

std::uint64_t OpenHapticsServo::ticks() const noexcept { return ticks_.load(std::memory_order_relaxed); }

unsigned int OpenHapticsServo::tick(void* self) noexcept {
  auto& servo = *static_cast<OpenHapticsServo*>(self);
  const HdLibrary::Api& hd = servo.library_.api();
  for (OpenHapticsDevice* d : servo.devices_) hd.begin_frame(d->handle());
  servo.loop_.force_tick(monotonic_seconds() - servo.start_time_);
  for (OpenHapticsDevice* d : servo.devices_) hd.end_frame(d->handle());
  servo.ticks_.fetch_add(1, std::memory_order_relaxed);
  return kCallbackContinue;
}

}  // namespace organsim::devices
