// `organsim touch MODEL`: feel the organ with PHANToM / Touch devices
// (OpenHaptics, loaded at run time), without the viewer.
#include <chrono>
#include <cstdio>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line/command_line.h"
#include "command_line/model_tuning.h"
#include "haptic_rig_options.h"
#include "report_options.h"
#include "report/run_recorder.h"
#include "organsim/model/model_file.h"
#include "organsim/realtime/engine.h"

namespace organsim::cli {
namespace {

struct TouchOptions {
  std::string model_path;
  devices::HapticRigOptions rig;
  double seconds = 60.0;
  std::string deformation = realtime::default_model().name;
  ModelTuning tuning;
  bool json = false;
  std::string report_dir;  // "": no training report
  report::ReportOptions report;
};

// Says once when a device starts reporting HD errors (its force fades to zero
// in the servo loop) and once when it is back; called at the frame rate.
void report_device_faults(const std::vector<std::unique_ptr<devices::OpenHapticsDevice>>& owned, double now,
                          std::vector<std::uint64_t>& errors_seen, std::vector<bool>& failing) {
  for (std::size_t i = 0; i < owned.size(); ++i) {
    const std::uint64_t errors = owned[i]->error_ticks();
    if (errors > errors_seen[i] && !failing[i])
      warn("touch", fmt::format("device {} reported HD error 0x{:04x} at {:.2f} s; its force fades to zero and the "
                                "other devices go on",
                                i + 1, owned[i]->last_error(), now));
    else if (errors == errors_seen[i] && failing[i])
      note("touch", fmt::format("device {} is back at {:.2f} s", i + 1, now));
    failing[i] = errors > errors_seen[i];
    errors_seen[i] = errors;
  }
}

int run_touch(const TouchOptions& o) {
  model::OrganModel loaded = load_simulation_model("touch", o.model_path, {o.deformation});
  warn_if_depth_curve_rescaled("touch", loaded, {o.deformation}, o.tuning);
  const organ::Organ organ(std::move(loaded));
  const devices::HapticRig rig = devices::open_haptic_rig(o.rig, organ.model());
  const auto& owned = rig.devices;
  const std::vector<devices::HapticDevice*> tools = rig.tools();
  realtime::EngineOptions options;
  options.model = o.deformation;
  apply_model_tuning(o.tuning, options);
  if (!o.report_dir.empty()) options.tick_records = report::kTickRecordsPerTool;
  realtime::Engine engine(organ, tools, options);
  std::unique_ptr<report::RunRecorder> recorder;
  if (!o.report_dir.empty()) recorder = std::make_unique<report::RunRecorder>(o.report_dir, organ, tools.size());
  engine.set_reproducible(false);  // real time: a frame never waits for the FEM tangent worker
  warn_if_frames_overrun("touch", engine);
  devices::OpenHapticsServo servo(*rig.library, rig.servo_devices(), engine);
  note("touch", fmt::format("{} device(s) on {} for {:g} s; the force loop runs in the HD servo scheduler",
                            owned.size(), o.model_path, o.seconds));
  const auto begin = std::chrono::steady_clock::now();
  servo.start();
  auto next = begin;
  std::uint64_t frames = 0;
  std::vector<std::uint64_t> errors_seen(owned.size(), 0);
  std::vector<bool> failing(owned.size(), false);
  while (std::chrono::steady_clock::now() - begin < std::chrono::duration<double>(o.seconds)) {
    const double now = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
    engine.deformation_step(now);
    ++frames;
    if (recorder) {
      if (engine.surfaces().update()) recorder->take_frame(engine.surfaces().read());
      recorder->take_ticks(engine);
    }
    report_device_faults(owned, now, errors_seen, failing);
    next += std::chrono::microseconds(16667);
    std::this_thread::sleep_until(next);
  }
  servo.stop();
  const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count();
  if (recorder) {
    report::SessionFacts facts;
    facts.deformation_model = o.deformation;
    facts.model_path = o.model_path;
    facts.live_tools = "live devices";
    facts.mode = "touch (OpenHaptics servo loop)";
    facts.duration_s = seconds;
    facts.device_max_force_n = owned.front()->limits().max_force;
    facts.loop_health = {{"force_ticks", servo.ticks()}, {"frames", frames}};
    recorder->finish(engine, report::describe_session(facts, engine));
    for (const std::string& problem : report::write_report(o.report_dir, o.report)) warn("touch", problem);
  }

  if (o.json) {
    nlohmann::json tools_json = nlohmann::json::array();
    for (std::size_t i = 0; i < owned.size(); ++i)
      tools_json.push_back({{"tool", i + 1},
                            {"contacts", engine.telemetry(i).contacts},
                            {"peak_force_n", engine.telemetry(i).peak_force},
                            {"max_force_n", owned[i]->limits().max_force},
                            {"hd_error_ticks", owned[i]->error_ticks()},
                            {"last_hd_error", owned[i]->last_error()},
                            {"pose_faults", engine.telemetry(i).pose_faults}});
    std::cout << nlohmann::json{{"model", o.model_path},
                                {"seconds", seconds},
                                {"servo_ticks", servo.ticks()},
                                {"servo_rate_hz", servo.ticks() / seconds},
                                {"deformation_frames", frames},
                                {"report", recorder ? nlohmann::json(o.report_dir + "/index.html") : nlohmann::json()},
                                {"tools", tools_json}}
                     .dump()
              << '\n';
    return 0;
  }
  std::cout << fmt::format("{:<14}{:.1f} s, servo {:.0f} Hz ({} ticks), {} deformation frames\n", "touch", seconds,
                           servo.ticks() / seconds, servo.ticks(), frames);
  if (recorder) std::cout << fmt::format("{:<14}{}/index.html (metrics.json beside it)\n", "report", o.report_dir);
  for (std::size_t i = 0; i < owned.size(); ++i)
    std::cout << fmt::format(
        "{:<14}{} contact(s), peak force {:.3f} N (device limit {:.2f} N){}\n", fmt::format("device {}", i + 1),
        engine.telemetry(i).contacts, engine.telemetry(i).peak_force, owned[i]->limits().max_force,
        owned[i]->error_ticks() == 0
            ? std::string()
            : fmt::format("; HD errors in {} servo ticks (last 0x{:04x}), {} time(s) without a pose",
                          owned[i]->error_ticks(), owned[i]->last_error(), engine.telemetry(i).pose_faults));
  return 0;
}

}  // namespace

Command add_touch_command(CLI::App& app) {
  auto o = std::make_shared<TouchOptions>();
  app.add_option("model", o->model_path, "Model file (.organ)")->required();
  add_deformation_model_option(app, o->deformation);
  add_model_tuning_options(app, o->tuning);
  add_grasp_option(app, o->tuning);
  add_haptic_rig_options(app, o->rig);
  app.add_option("--seconds", o->seconds, "How long to run")->check(kPositive)->capture_default_str();
  app.add_flag("--json", o->json, "Print the summary as one JSON object on stdout");
  app.add_option("--report", o->report_dir,
                 "Write a training report of the session into this directory (index.html, metrics.json, raw data; "
                 "docs/report.md)");
  add_report_options(app, o->report);
  return [o] { return run_touch(*o); };
}

}  // namespace organsim::cli
