// `organsim serve MODEL --igtl-port P`: the real-time engine driven over
// OpenIGTLink (3D Slicer, PLUS, robot controllers): tool poses in, the deformed
// organ and the tools' forces out (tools/igtlink/igtl_server.h, docs/slicer.md).
#include <atomic>
#include <chrono>
#include <csignal>
#include <iostream>
#include <memory>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line/command_line.h"
#include "igtlink/igtl_server.h"
#include "command_line/model_tuning.h"
#include "report_options.h"
#include "report/run_recorder.h"
#include "organsim/model/model_file.h"
#include "organsim/realtime/loop_runner.h"

namespace organsim::cli {
namespace {

struct ServeOptions {
  std::string model_path;
  igtlink::ServerOptions server;
  std::size_t tools = 2;
  std::string deformation = realtime::default_model().name;
  ModelTuning tuning;
  double seconds = 0.0;  // 0: until interrupted
  double max_force = devices::SafetyLimits{}.max_force;
  double max_stiffness = devices::SafetyLimits{}.max_stiffness;
  bool no_shaft = false;
  bool json = false;
  double force_rate = 60.0;  // Hz
  std::string report_dir;    // "": no training report
  report::ReportOptions report;
};

std::atomic<bool> stop_requested{false};
static_assert(std::atomic<bool>::is_always_lock_free, "set from a signal handler");
extern "C" void request_stop(int) { stop_requested.store(true, std::memory_order_relaxed); }

// SIGINT and SIGTERM end the run cleanly (summary printed) while it lasts.
class StopOnSignals {
 public:
  StopOnSignals() {
    stop_requested.store(false);
    struct sigaction action {};
    action.sa_handler = request_stop;
    sigemptyset(&action.sa_mask);
    ::sigaction(SIGINT, &action, &previous_int_);
    ::sigaction(SIGTERM, &action, &previous_term_);
  }
  ~StopOnSignals() {
    ::sigaction(SIGINT, &previous_int_, nullptr);
    ::sigaction(SIGTERM, &previous_term_, nullptr);
  }
  StopOnSignals(const StopOnSignals&) = delete;
  StopOnSignals& operator=(const StopOnSignals&) = delete;

 private:
  struct sigaction previous_int_ {};
  struct sigaction previous_term_ {};
};

nlohmann::json milliseconds(const realtime::Percentiles& p) {
  return {{"p50_ms", p.p50 * 1e3}, {"p99_ms", p.p99 * 1e3}, {"max_ms", p.max * 1e3}};
}

int run_serve(const ServeOptions& o) {
  model::OrganModel loaded = load_simulation_model("serve", o.model_path, {o.deformation});
  warn_if_depth_curve_rescaled("serve", loaded, {o.deformation}, o.tuning);
  std::vector<model::Triangle> file_triangles = loaded.surface_triangles;
  const organ::Organ organ(std::move(loaded));

  devices::SafetyLimits limits;
  limits.max_force = o.max_force;
  limits.max_stiffness = o.max_stiffness;
  std::vector<std::unique_ptr<devices::StreamedTool>> tools;
  std::vector<devices::HapticDevice*> devices;
  std::vector<devices::StreamedTool*> streamed;
  for (std::size_t k = 0; k < o.tools; ++k) {
    tools.push_back(std::make_unique<devices::StreamedTool>(limits));
    devices.push_back(tools.back().get());
    streamed.push_back(tools.back().get());
  }
  realtime::EngineOptions options;
  options.model = o.deformation;
  apply_model_tuning(o.tuning, options);
  if (!o.report_dir.empty()) options.tick_records = report::kTickRecordsPerTool;
  realtime::Engine engine(organ, devices, options);
  warn_if_frames_overrun("serve", engine);
  std::unique_ptr<report::RunRecorder> recorder;
  if (!o.report_dir.empty()) recorder = std::make_unique<report::RunRecorder>(o.report_dir, organ, o.tools);

  igtlink::ServerOptions server_options = o.server;
  server_options.shaft_from_rotation = !o.no_shaft;
  server_options.force_period = 1.0 / o.force_rate;
  server_options.force_tick_period = engine.options().force_period;
  igtlink::IgtlServer server(
      server_options, organ, std::move(file_triangles), streamed, engine.surfaces(),
      [](const std::string& message) { warn("serve", message); },
      [](const std::string& message) { note("serve", message); });
  note("serve", fmt::format("{} ({} model, {} tool(s)) on {}:{} ({} frame): TRANSFORM tool1…tool{} in, POLYDATA organ "
                            "at {:.0f} Hz and TRANSFORM toolK_force out at {:.0f} Hz; {}",
                            o.model_path, o.deformation, o.tools, o.server.bind_address, server.port(),
                            o.server.ras ? "RAS" : "LPS model", o.tools, 1.0 / o.server.frame_period, o.force_rate,
                            o.seconds > 0.0 ? fmt::format("for {:g} s", o.seconds) : std::string("Ctrl-C stops")));

  if (recorder) server.observe_frames([&](const realtime::SurfaceFrame& frame) { recorder->take_frame(frame); });
  const StopOnSignals signals;
  const auto begin = std::chrono::steady_clock::now();
  const double duration = o.seconds > 0.0 ? o.seconds : 1e9;
  // With forces sent between frames (--force-rate above the frame rate),
  // polled just before each force tick and just after it: a pose that arrived
  // since the last poll reaches the next tick, and the force that tick
  // computed leaves at once (docs/performance.md#the-openigtlink-service); at
  // a real-time priority between the force loop's and the deformation loop's,
  // so that neither a frame nor the clients' own threads, which share the core
  // the force loop leaves, hold a pose or a force back. Otherwise every 2 ms
  // (or a quarter of the force period) as an ordinary thread: a frame's
  // surface and the training report's recording then never run above the
  // deformation loop.
  realtime::PollOptions polling;
  polling.period = std::min(2e-3, 0.25 * server_options.force_period);
  if (server_options.force_period < server_options.frame_period) {
    polling.around_force_ticks = true;
    polling.priority = 75;
  }
  const realtime::RunTimings timings = realtime::run_realtime(
      engine, duration,
      [&](const realtime::RunTimings&) {
        server.step(std::chrono::duration<double>(std::chrono::steady_clock::now() - begin).count());
        if (recorder) recorder->take_ticks(engine);
        return !stop_requested.load(std::memory_order_relaxed);
      },
      polling);
  if (!timings.priority_warning.empty()) warn("serve", timings.priority_warning);
  const realtime::Percentiles period = timings.force_periods.percentiles();
  if (recorder) {
    report::SessionFacts facts;
    facts.deformation_model = o.deformation;
    facts.model_path = o.model_path;
    facts.live_tools = "tools streamed over OpenIGTLink";
    facts.mode = "serve (OpenIGTLink)";
    facts.duration_s = timings.wall_seconds;
    facts.device_max_force_n = o.max_force;
    facts.loop_health = {{"force_ticks", timings.force_computes.count()},
                         {"period_p50_ms", period.p50 * 1e3},
                         {"period_p99_ms", period.p99 * 1e3},
                         {"period_max_ms", period.max * 1e3},
                         {"force_deadline_misses", timings.force_deadline_misses},
                         {"frames", timings.deformation_computes.count()},
                         {"frames_dropped", timings.deformation_frames_dropped}};
    recorder->finish(engine, report::describe_session(facts, engine));
    for (const std::string& problem : report::write_report(o.report_dir, o.report)) warn("serve", problem);
  }

  const igtlink::ServerCounters& c = server.counters();
  if (o.json) {
    nlohmann::json dropped;
    for (std::size_t p = 0; p < igtlink::kProblemKinds; ++p)
      dropped[igtlink::name(static_cast<igtlink::Problem>(p))] = c.dropped[p];
    nlohmann::json tools_json = nlohmann::json::array();
    for (std::size_t k = 0; k < o.tools; ++k)
      tools_json.push_back({{"tool", k + 1},
                            {"contacts", engine.telemetry(k).contacts},
                            {"peak_force_n", engine.telemetry(k).peak_force},
                            {"grasps", engine.telemetry(k).grasps},
                            {"grasp_slips", engine.telemetry(k).grasp_slips},
                            {"peak_pull_n", engine.telemetry(k).peak_pull},
                            {"pose_faults", engine.telemetry(k).pose_faults}});
    std::cout << nlohmann::json{{"model", o.model_path},
                                {"port", server.port()},
                                {"seconds", timings.wall_seconds},
                                {"clients_accepted", c.clients_accepted},
                                {"clients_refused", c.clients_refused},
                                {"poses", c.poses},
                                {"jaw_changes", c.jaw_changes},
                                {"frames_sent", c.frames},
                                {"surfaces_sent", c.surfaces},
                                {"frames_missed", c.frames_missed},
                                {"force_updates", c.force_updates},
                                {"bytes_sent", c.bytes_sent},
                                {"dropped", dropped},
                                {"report", recorder ? nlohmann::json(o.report_dir + "/index.html") : nlohmann::json()},
                                {"tools", tools_json},
                                {"force_loop",
                                 {{"ticks", timings.force_computes.count()},
                                  {"period", milliseconds(period)},
                                  {"deadline_misses", timings.force_deadline_misses}}},
                                {"deformation_loop",
                                 {{"frames", timings.deformation_computes.count()},
                                  {"dropped", timings.deformation_frames_dropped},
                                  {"compute", milliseconds(timings.deformation_computes.percentiles())}}}}
                     .dump()
              << '\n';
    return 0;
  }
  std::string dropped;
  for (std::size_t p = 0; p < igtlink::kProblemKinds; ++p)
    if (c.dropped[p] > 0)
      dropped += fmt::format("{}{} {}", dropped.empty() ? "" : ", ", c.dropped[p],
                             igtlink::name(static_cast<igtlink::Problem>(p)));
  std::cout << fmt::format(
      "{:<14}{:.1f} s on port {}: {} client(s), {} poses in, {} frames out ({} with the surface, "
      "{} missed by slow clients), {:.1f} MB sent\n",
      "serve", timings.wall_seconds, server.port(), c.clients_accepted, c.poses, c.frames, c.surfaces, c.frames_missed,
      static_cast<double>(c.bytes_sent) / 1e6);
  std::cout << fmt::format("{:<14}{}\n", "dropped", dropped.empty() ? std::string("none") : dropped);
  for (std::size_t k = 0; k < o.tools; ++k)
    std::cout << fmt::format("{:<14}{} contact(s), peak force {:.3f} N\n", fmt::format("tool {}", k + 1),
                             engine.telemetry(k).contacts, engine.telemetry(k).peak_force);
  std::cout << fmt::format(
      "{:<14}{} ticks, period p50 {:.3f} ms, p99 {:.3f} ms, max {:.3f} ms; {} deadline misses "
      "(> 2 ms)\n",
      "force loop", timings.force_computes.count(), period.p50 * 1e3, period.p99 * 1e3, period.max * 1e3,
      timings.force_deadline_misses);
  const realtime::Percentiles frames = timings.deformation_computes.percentiles();
  std::cout << fmt::format("{:<14}{} frames, compute p50 {:.3f} ms, p99 {:.3f} ms\n", "deformation",
                           timings.deformation_computes.count(), frames.p50 * 1e3, frames.p99 * 1e3);
  return 0;
}

}  // namespace

Command add_serve_command(CLI::App& app) {
  auto o = std::make_shared<ServeOptions>();
  app.add_option("model", o->model_path, "Model file (.organ)")->required();
  app.add_option("--igtl-port", o->server.port, "OpenIGTLink port to listen on (0 picks a free one and says which)")
      ->check(CLI::Range(0, 65535))
      ->capture_default_str();
  app.add_option("--bind", o->server.bind_address,
                 "Address to listen on: 127.0.0.1 (this machine) or 0.0.0.0 (every network it is on)")
      ->check(CLI::ValidIPV4)
      ->capture_default_str();
  app.add_option("--tools", o->tools, "Tools served: TRANSFORM messages tool1 … toolN move them")
      ->check(CLI::Range(std::size_t{1}, std::size_t{realtime::kMaxTools}))
      ->capture_default_str();
  add_deformation_model_option(app, o->deformation);
  add_model_tuning_options(app, o->tuning);
  add_grasp_option(app, o->tuning);
  app.add_option("--force-rate", o->force_rate,
                 "How often each tool's force is sent, Hz: 60 (with every frame) up to 1000 (robots and haptic "
                 "clients)")
      ->check(CLI::Range(60.0, 1000.0))
      ->capture_default_str();
  app.add_flag("--ras", o->server.ras,
               "Clients speak RAS (3D Slicer's frame): x and y change sign on the way in and out");
  app.add_flag("--no-shaft", o->no_shaft,
               "Poses give the tip only (the rotation is ignored: contacts are found from the tip's path)");
  app.add_option("--seconds", o->seconds, "Stop after this long (default: run until Ctrl-C or SIGTERM)")
      ->check(kPositive);
  app.add_option("--max-force", o->max_force, "Force limit per tool, N")->check(kPositive)->capture_default_str();
  app.add_option("--max-stiffness", o->max_stiffness, "Stiffness limit per tool, N/m")
      ->check(kPositive)
      ->capture_default_str();
  app.add_flag("--json", o->json, "Print the summary as one JSON object on stdout");
  app.add_option("--report", o->report_dir,
                 "Write a training report of the session into this directory (index.html, metrics.json, raw data; "
                 "docs/report.md)");
  add_report_options(app, o->report);
  return [o] { return run_serve(*o); };
}

}  // namespace organsim::cli
