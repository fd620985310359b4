// `organsim view MODEL`: the trainee's view. A replayed session, PHANToM /
// Touch devices, or tools moved with the mouse, deforming the organ in a
// laparoscopic-looking scene; screenshots and recordings for engineers. The
// scene, the interaction and the recording live in tools/viewer/; this file
// only picks the input mode and runs its loop.
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <stdexcept>
#include <thread>

#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <vtkInteractorStyleTrackballCamera.h>
#include <vtkNew.h>
#include <vtkRenderWindowInteractor.h>

#include "command_line/command_line.h"
#include "command_line/model_tuning.h"
#include "haptic_rig_options.h"
#include "report_options.h"
#include "report/run_recorder.h"
#include "session_limits.h"
#include "organsim/devices/streamed_tool.h"
#include "organsim/devices/scripted_device.h"
#include "organsim/model/model_file.h"
#include "organsim/realtime/loop_runner.h"
#include "organsim/realtime/session_playback.h"
#include "viewer/recording.h"
#include "viewer/scene.h"
#include "viewer/tool_style.h"

namespace organsim::cli {
namespace {

namespace fs = std::filesystem;
using namespace organsim::devices;
using namespace organsim::realtime;
using viewer::OrganScene;
using viewer::Recorder;

constexpr std::size_t kMouseTools = 4;

struct ViewOptions {
  std::string model_path;
  std::string session_path;
  bool long_session = false;
  std::string background_path;
  std::string texture_path;
  std::string screenshot_path;
  std::string record_path;
  bool offscreen = false;
  bool realtime = false;  // --realtime: a session on the engine's real-time loops, drawn as frames arrive
  bool hide_tools = false;
  bool show_supports = false;
  bool json = false;
  long frames = 0;  // 0: the whole session, or until the window closes
  double seconds = 600.0;
  bool phantom = false;
  std::string deformation = realtime::default_model().name;
  ModelTuning tuning;
  HapticRigOptions rig;
  std::string report_dir;  // "": no training report
  report::ReportOptions report;
  std::vector<int> size{960, 720};
};

/// What every input mode draws into and counts.
struct ViewRun {
  OrganScene& scene;
  Recorder& recorder;
  const ViewOptions& options;
  long frames = 0;
  nlohmann::json tools_json = nlohmann::json::array();  ///< the last drawn frame's tools, for scripts and tests
  std::unique_ptr<report::RunRecorder> report;          ///< --report
  nlohmann::json timing;                                ///< --realtime: the loops' and the drawing's timings

  /// The training report takes the frame drawn and the ticks since the last one.
  void record(Engine& engine, const SurfaceFrame& surface) {
    if (!report) return;
    report->take_frame(surface);
    report->take_ticks(engine);
  }
  /// Writes the training report of the session that ran `seconds` in `mode`.
  void finish_report(Engine& engine, const std::string& mode, double seconds, double max_force, nlohmann::json health) {
    if (!report) return;
    report::SessionFacts facts;
    facts.deformation_model = options.deformation;
    facts.model_path = options.model_path;
    facts.session_path = options.session_path;
    facts.live_tools = "live tools";
    facts.mode = mode;
    facts.duration_s = seconds;
    facts.device_max_force_n = max_force;
    facts.real_time = options.session_path.empty() || options.realtime;  // a session is stepped unless --realtime
    health["frames"] = frames;
    facts.loop_health = std::move(health);
    report->finish(engine, report::describe_session(facts, engine));
    for (const std::string& problem : report::write_report(options.report_dir, options.report)) warn("view", problem);
  }

  bool frame_limit_reached() const { return options.frames > 0 && frames >= options.frames; }
  /// Finishes a drawn frame: background, render, record.
  void draw() {
    scene.next_background_frame();
    scene.render();
    ++frames;
    if (recorder.active()) recorder.add(scene.capture());
  }
};

std::string overlay(const std::vector<Eigen::Vector3d>& forces, const std::vector<bool>& present, double force_hz,
                    double frame_hz, bool mouse) {
  std::string text;
  for (std::size_t i = 0; i < forces.size(); ++i)
    if (present[i]) text += fmt::format("tool {}: {:.3f} N\n", i + 1, forces[i].norm());
  text += fmt::format("force loop {:.0f} Hz, deformation {:.0f} Hz", force_hz, frame_hz);
  if (mouse)
    text +=
        "\nn: new tool at the mouse   shift+drag: move it   shift+wheel or +/-: depth   g: jaws   tab: next   "
        "x: remove";
  return text;
}

EngineOptions engine_options(const ViewOptions& o) {
  EngineOptions options;
  options.model = o.deformation;
  apply_model_tuning(o.tuning, options);
  if (!o.report_dir.empty()) options.tick_records = report::kTickRecordsPerTool;
  return options;
}

/// A recorded session with scripted tools, in the session's own time, stepped
/// like `replay --fast`; drawn at every deformation frame, paced to the wall
/// clock when a window is shown.
void view_session(const organ::Organ& organ, const Session& session, ViewRun& run) {
  const ViewOptions& o = run.options;
  PlaybackOptions playback_options;
  playback_options.records_per_tool = 16;  // the view reads poses, not the recorded forces
  SessionPlayback playback(organ, session, engine_options(o), playback_options);
  Engine& engine = playback.engine();
  warn_if_frames_overrun("view", engine);
  const auto& scripted = playback.devices();
  const double frame_period = engine.options().deformation_period;
  const auto wall_start = std::chrono::steady_clock::now();
  std::vector<Eigen::Vector3d> forces(scripted.size());
  const std::vector<bool> present(scripted.size(), true);
  bool stop = false;
  const RunTimings timings = playback.run_fast(session.duration, [&](const RunTimings&) {
    if (stop) return;
    engine.surfaces().update();
    const SurfaceFrame& surface = engine.surfaces().read();
    const double time = surface.time;
    run.scene.show_surface(surface);
    run.record(engine, surface);
    run.tools_json = nlohmann::json::array();
    for (std::size_t i = 0; i < scripted.size(); ++i) {
      ToolPose pose;
      scripted[i]->read_pose(time, pose);
      forces[i] = engine.telemetry(i).last_force;
      run.scene.show_tool(i, !o.hide_tools, pose, forces[i], engine.telemetry(i).in_contact);
      const Eigen::Vector2d pixel = run.scene.project(pose.tip);
      run.tools_json.push_back({{"tool", i + 1},
                                {"contacts", engine.telemetry(i).contacts},
                                {"grasps", engine.telemetry(i).grasps},
                                {"jaws_closed", pose.jaws_closed},
                                {"tip_px", {pixel[0], pixel[1]}},
                                {"force_n", forces[i].norm()},
                                {"held_vertices", run.scene.held_vertices(i)}});
    }
    if (!o.hide_tools)
      run.scene.show_text(overlay(forces, present, 1.0 / engine.options().force_period, 1.0 / frame_period, false));
    run.draw();
    if (!o.offscreen) std::this_thread::sleep_until(wall_start + std::chrono::duration<double>(time));
    stop = run.frame_limit_reached();
  });
  run.finish_report(engine, "view (a recorded session, scripted tools)", engine.surfaces().read().time,
                    playback_options.limits.max_force, {{"force_ticks", timings.force_computes.count()}});
}

/// A recorded session in real time, as a trainee's station runs it: the
/// force loop (1 kHz) and the deformation loop (60 Hz) on their own threads,
/// as `replay` runs them, and each new surface drawn on this thread as it
/// arrives. Measures the whole chain: the loops' periods, the frames dropped
/// and the time each drawing takes.
void view_session_realtime(const organ::Organ& organ, const Session& session, ViewRun& run) {
  const ViewOptions& o = run.options;
  PlaybackOptions playback_options;
  playback_options.records_per_tool = 4096;  // drained at every poll
  SessionPlayback playback(organ, session, engine_options(o), playback_options);
  Engine& engine = playback.engine();
  engine.set_reproducible(false);  // real time: a frame never waits for the FEM tangent worker
  warn_if_frames_overrun("view", engine);
  const auto& scripted = playback.devices();
  std::vector<Eigen::Vector3d> forces(scripted.size(), Eigen::Vector3d::Zero());
  std::vector<ToolPose> poses(scripted.size());  // as last drawn
  const std::vector<bool> present(scripted.size(), true);
  DurationHistogram drawing;  // s from a new surface to the frame drawn
  const auto start = std::chrono::steady_clock::now();
  const RunTimings timings = playback.run_realtime(session.duration, [&](const RunTimings& so_far) {
    ForceRecord latest;
    for (std::size_t i = 0; i < scripted.size(); ++i)
      while (scripted[i]->take_record(latest)) forces[i] = latest.force;
    if (run.frame_limit_reached()) return false;
    if (!engine.surfaces().update()) return true;
    const auto began = std::chrono::steady_clock::now();
    const SurfaceFrame& surface = engine.surfaces().read();
    run.scene.show_surface(surface);
    run.record(engine, surface);
    for (std::size_t i = 0; i < scripted.size(); ++i) {
      scripted[i]->read_pose(surface.time, poses[i]);
      run.scene.show_tool(i, !o.hide_tools, poses[i], forces[i], forces[i].norm() > 0.0);
    }
    const double elapsed = std::chrono::duration<double>(began - start).count();
    if (!o.hide_tools)
      run.scene.show_text(overlay(forces, present,
                                  static_cast<double>(so_far.force_computes.count()) / std::max(elapsed, 1e-3),
                                  surface.frame / std::max(elapsed, 1e-3), false));
    run.draw();
    drawing.record(std::chrono::duration<double>(std::chrono::steady_clock::now() - began).count());
    return true;
  });
  // The loops have stopped: their telemetry may be read.
  run.tools_json = nlohmann::json::array();
  for (std::size_t i = 0; i < scripted.size(); ++i) {
    const Eigen::Vector2d pixel = run.scene.project(poses[i].tip);
    run.tools_json.push_back({{"tool", i + 1},
                              {"contacts", engine.telemetry(i).contacts},
                              {"grasps", engine.telemetry(i).grasps},
                              {"jaws_closed", poses[i].jaws_closed},
                              {"tip_px", {pixel[0], pixel[1]}},
                              {"force_n", forces[i].norm()},
                              {"held_vertices", run.scene.held_vertices(i)}});
  }
  const Percentiles period = timings.force_periods.percentiles();
  const Percentiles frame = timings.deformation_computes.percentiles();
  const Percentiles draw = drawing.percentiles();
  run.timing = {
      {"seconds", timings.wall_seconds},
      {"force_ticks", timings.force_computes.count()},
      {"force_period_p50_ms", period.p50 * 1e3},
      {"force_period_p99_ms", period.p99 * 1e3},
      {"force_period_max_ms", period.max * 1e3},
      {"force_deadline_misses", timings.force_deadline_misses},
      {"realtime_priority", timings.realtime_priority},
      {"deformation_frames", timings.deformation_computes.count()},
      {"deformation_p50_ms", frame.p50 * 1e3},
      {"deformation_p99_ms", frame.p99 * 1e3},
      {"frames_dropped", timings.deformation_frames_dropped},
      {"frames_drawn", drawing.count()},
      {"frames_drawn_per_second", static_cast<double>(drawing.count()) / std::max(timings.wall_seconds, 1e-9)},
      {"draw_p50_ms", draw.p50 * 1e3},
      {"draw_p99_ms", draw.p99 * 1e3},
      {"draw_max_ms", draw.max * 1e3}};
  run.finish_report(engine, "view (a recorded session in real time)", timings.wall_seconds,
                    playback_options.limits.max_force, run.timing);
}

/// PHANToM / Touch devices: the HD servo runs the force loop; the deformation
/// loop and the drawing run here at 60 Hz.
void view_phantom(const organ::Organ& organ, const HapticRig& rig, ViewRun& run) {
  const ViewOptions& o = run.options;
  const std::vector<HapticDevice*> pointers = rig.tools();
  Engine engine(organ, pointers, engine_options(o));
  engine.set_reproducible(false);  // real time: a frame never waits for the FEM tangent worker
  warn_if_frames_overrun("view", engine);
  OpenHapticsServo servo(*rig.library, rig.servo_devices(), engine);
  vtkNew<vtkRenderWindowInteractor> interactor;
  vtkNew<vtkInteractorStyleTrackballCamera> style;
  interactor->SetInteractorStyle(style);
  interactor->SetRenderWindow(run.scene.window());
  interactor->Initialize();
  const auto start = std::chrono::steady_clock::now();
  auto next = start;
  servo.start();
  std::vector<Eigen::Vector3d> forces(pointers.size());
  const std::vector<bool> present(pointers.size(), true);
  while (!interactor->GetDone() && !run.frame_limit_reached() &&
         std::chrono::steady_clock::now() - start < std::chrono::duration<double>(o.seconds)) {
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    engine.deformation_step(elapsed);
    engine.surfaces().update();
    run.scene.show_surface(engine.surfaces().read());
    run.record(engine, engine.surfaces().read());
    for (std::size_t i = 0; i < pointers.size(); ++i) {
      ToolPose pose;
      // Drawing only: the device reports the pose the servo last read.
      const bool seen = rig.devices[i]->last_pose(pose);
      forces[i] = rig.devices[i]->last_force();
      run.scene.show_tool(i, seen && !o.hide_tools, pose, forces[i], forces[i].norm() > 0.0);
    }
    if (!o.hide_tools)
      run.scene.show_text(overlay(forces, present, servo.ticks() / std::max(elapsed, 1e-3),
                                  run.frames / std::max(elapsed, 1e-3), false));
    run.draw();
    interactor->ProcessEvents();
    next += std::chrono::microseconds(16667);
    std::this_thread::sleep_until(next);
  }
  servo.stop();
  run.finish_report(engine, "view (PHANToM / Touch devices)",
                    std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(),
                    rig.devices.front()->limits().max_force, {{"force_ticks", servo.ticks()}});
}

/// Mouse and keyboard tools, with the engine's loops on their threads in real time.
void view_mouse(const organ::Organ& organ, ViewRun& run) {
  const ViewOptions& o = run.options;
  std::vector<StreamedTool> tools(kMouseTools);
  std::vector<HapticDevice*> pointers;
  for (StreamedTool& t : tools) pointers.push_back(&t);
  Engine engine(organ, pointers, engine_options(o));
  engine.set_reproducible(false);  // real time: a frame never waits for the FEM tangent worker
  warn_if_frames_overrun("view", engine);
  vtkNew<vtkRenderWindowInteractor> interactor;
  vtkNew<viewer::ToolStyle> style;
  style->attach(tools, run.scene);
  interactor->SetInteractorStyle(style);
  interactor->SetRenderWindow(run.scene.window());
  interactor->Initialize();
  std::vector<Eigen::Vector3d> forces(kMouseTools);
  const auto start = std::chrono::steady_clock::now();
  const RunTimings timings = run_realtime(engine, o.seconds, [&](const RunTimings&) {
    interactor->ProcessEvents();
    if (interactor->GetDone() || run.frame_limit_reached()) return false;
    if (!engine.surfaces().update()) return true;
    run.scene.show_surface(engine.surfaces().read());
    run.record(engine, engine.surfaces().read());
    for (std::size_t i = 0; i < kMouseTools; ++i) {
      bool touching = false;
      forces[i] = tools[i].last_force(touching);
      run.scene.show_tool(i, style->present()[i] && !o.hide_tools, style->poses()[i], forces[i], touching);
    }
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (!o.hide_tools)
      run.scene.show_text(overlay(forces, style->present(), tools[0].ticks() / std::max(elapsed, 1e-3),
                                  engine.surfaces().read().frame / std::max(elapsed, 1e-3), true));
    run.draw();
    return true;
  });
  const Percentiles period = timings.force_periods.percentiles();
  run.finish_report(engine, "view (mouse tools)", timings.wall_seconds, tools.front().limits().max_force,
                    {{"force_ticks", timings.force_computes.count()},
                     {"period_p50_ms", period.p50 * 1e3},
                     {"period_p99_ms", period.p99 * 1e3},
                     {"period_max_ms", period.max * 1e3},
                     {"force_deadline_misses", timings.force_deadline_misses},
                     {"frames_dropped", timings.deformation_frames_dropped}});
}

void print_summary(const ViewRun& run, const std::vector<std::string>& warnings) {
  const ViewOptions& o = run.options;
  if (o.json) {
    nlohmann::json j{{"model", o.model_path},
                     {"frames", run.frames},
                     {"tools", run.tools_json},
                     {"warnings", warnings},
                     {"size", {o.size[0], o.size[1]}}};
    if (!o.screenshot_path.empty()) j["screenshot"] = o.screenshot_path;
    if (!o.record_path.empty()) j["record"] = {{"path", o.record_path}, {"frames", run.recorder.count()}};
    if (run.report) j["report"] = o.report_dir + "/index.html";
    if (!run.timing.is_null()) j["timing"] = run.timing;
    if (o.show_supports) j["supported_vertices"] = run.scene.supported_vertices();
    std::cout << j.dump() << '\n';
  } else {
    std::cout << fmt::format(
        "{:<12}{} frames drawn{}{}\n", "view", run.frames,
        o.screenshot_path.empty() ? "" : ", screenshot " + o.screenshot_path,
        o.record_path.empty() ? "" : fmt::format(", recording {} ({} frames)", o.record_path, run.recorder.count()));
    if (!run.timing.is_null()) {
      const nlohmann::json& t = run.timing;
      std::cout << fmt::format(
          "{:<12}force loop: {} ticks, period p50 {:.3f} ms, p99 {:.3f} ms, max {:.2f} ms, {} over 2 ms{}\n", "timing",
          t["force_ticks"].get<std::uint64_t>(), t["force_period_p50_ms"].get<double>(),
          t["force_period_p99_ms"].get<double>(), t["force_period_max_ms"].get<double>(),
          t["force_deadline_misses"].get<std::uint64_t>(),
          t["realtime_priority"].get<bool>() ? "" : " (without real-time priority)");
      std::cout << fmt::format(
          "{:<12}deformation: {} frames, p50 {:.2f} ms, p99 {:.2f} ms, {} dropped; drawing: {} frames, {:.1f} per "
          "second, p50 {:.2f} ms, p99 {:.2f} ms, max {:.1f} ms\n",
          "", t["deformation_frames"].get<std::uint64_t>(), t["deformation_p50_ms"].get<double>(),
          t["deformation_p99_ms"].get<double>(), t["frames_dropped"].get<std::uint64_t>(),
          t["frames_drawn"].get<std::uint64_t>(), t["frames_drawn_per_second"].get<double>(),
          t["draw_p50_ms"].get<double>(), t["draw_p99_ms"].get<double>(), t["draw_max_ms"].get<double>());
    }
  }
}

int run_view(const ViewOptions& o) {
  if (o.size.size() != 2 || o.size[0] < 64 || o.size[1] < 64)
    throw std::runtime_error("--size takes WIDTH,HEIGHT of at least 64,64");
  if (!o.screenshot_path.empty() && fs::path(o.screenshot_path).extension() != ".png")
    throw std::runtime_error("--screenshot " + o.screenshot_path + ": screenshots are PNG files; name it .png");
  if (o.phantom && !o.session_path.empty())
    throw std::runtime_error("--phantom and --session are exclusive; choose one");
  if (o.realtime && o.session_path.empty())
    throw CLI::ValidationError("--realtime",
                               "plays a --session in real time; give one (mouse and PHANToM tools "
                               "always run in real time)");
  model::OrganModel loaded = load_simulation_model("view", o.model_path, {o.deformation});
  const organ::Organ organ(std::move(loaded));

  std::vector<std::string> warnings;
  viewer::SceneOptions scene_options;
  scene_options.width = o.size[0];
  scene_options.height = o.size[1];
  scene_options.offscreen = o.offscreen;
  scene_options.show_supports = o.show_supports;
  if (!o.texture_path.empty()) scene_options.texture = viewer::read_image(o.texture_path);
  if (!o.background_path.empty()) {
    try {
      scene_options.background = std::make_unique<viewer::Background>(o.background_path);
    } catch (const std::exception& e) {
      warnings.push_back(std::string(e.what()) + "; starting without a background");
      warn("view", warnings.back());
    }
  }

  Session session;
  if (!o.session_path.empty()) session = read_session(o.session_path, session_limits(organ.model(), o.long_session));
  warn_if_depth_curve_rescaled("view", organ.model(), {o.deformation}, o.tuning,
                               o.session_path.empty() ? nullptr : &session);
  HapticRig rig;
  if (o.phantom) rig = open_haptic_rig(o.rig, organ.model());
  const std::size_t tool_count = !o.session_path.empty() ? session.tools.size()
                                 : o.phantom             ? rig.devices.size()
                                                         : kMouseTools;
  OrganScene scene(organ, tool_count, std::move(scene_options));
  Recorder recorder(o.record_path, cv::Size(o.size[0], o.size[1]));
  ViewRun run{scene,
              recorder,
              o,
              0,
              nlohmann::json::array(),
              o.report_dir.empty() ? nullptr : std::make_unique<report::RunRecorder>(o.report_dir, organ, tool_count),
              nlohmann::json()};
  if (!o.session_path.empty() && o.realtime)
    view_session_realtime(organ, session, run);
  else if (!o.session_path.empty())
    view_session(organ, session, run);
  else if (o.phantom)
    view_phantom(organ, rig, run);
  else
    view_mouse(organ, run);

  recorder.finish();
  if (!o.screenshot_path.empty()) {
    scene.render();
    viewer::write_png(scene.capture(), o.screenshot_path);
  }
  print_summary(run, warnings);
  return 0;
}

}  // namespace

Command add_view_command(CLI::App& app) {
  auto o = std::make_shared<ViewOptions>();
  app.add_option("model", o->model_path, "Model file (.organ)")->required();
  app.add_option("--session", o->session_path, "Replay a session file with scripted tools (default: mouse tools)");
  app.add_flag("--long-session", o->long_session, "Allow sessions longer than 24 h");
  app.add_option("--background", o->background_path, "Laparoscopic background: an image or a video (looped)");
  app.add_option("--texture", o->texture_path, "Organ texture image (default: a procedural liver texture)");
  app.add_option("--screenshot", o->screenshot_path, "Write a PNG of the last frame");
  app.add_option("--record", o->record_path, "Record every frame into a Motion-JPEG AVI");
  app.add_flag("--offscreen", o->offscreen, "Render without a window (works under Xvfb)");
  app.add_flag("--realtime", o->realtime,
               "With --session: run the engine's real-time loops (1 kHz force, 60 Hz deformation, on their own "
               "threads) and draw each new frame as it arrives, then print the loops' and the drawing's timings "
               "(default: the session stepped in its own time, as replay --fast)");
  app.add_option("--report", o->report_dir,
                 "Write a training report of the session into this directory (index.html, metrics.json, raw data; "
                 "docs/report.md)");
  add_report_options(app, o->report);
  app.add_option("--frames", o->frames, "Stop after this many frames")->check(kNonNegative);
  app.add_option("--seconds", o->seconds, "With mouse tools: stop after this long")
      ->check(kPositive)
      ->capture_default_str();
  app.add_option("--size", o->size, "Window size WIDTH,HEIGHT in pixels")
      ->delimiter(',')
      ->expected(2)
      ->capture_default_str();
  app.add_flag("--hide-tools", o->hide_tools, "Draw the organ alone: no instruments, arrows or text");
  app.add_flag("--show-supports", o->show_supports,
               "Mark the supports the bake found: blue where the organ rests on a neighbour, orange where it is "
               "attached (docs/supports.md)");
  app.add_flag("--json", o->json, "Print a summary as one JSON object on stdout");
  app.add_flag("--phantom", o->phantom, "Tools are PHANToM / Touch devices (OpenHaptics, loaded at run time)");
  add_deformation_model_option(app, o->deformation);
  add_model_tuning_options(app, o->tuning);
  add_grasp_option(app, o->tuning);
  add_haptic_rig_options(app, o->rig);
  return [o] { return run_view(*o); };
}

}  // namespace organsim::cli
