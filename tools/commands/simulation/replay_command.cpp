// `organsim replay MODEL SESSION`: a recorded multi-tool session through the
// real engine, with scripted devices: forces, contacts and loop timings.
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line/command_line.h"
#include "command_line/model_tuning.h"
#include "report_options.h"
#include "session_limits.h"
#include "report/run_recorder.h"
#include "organsim/devices/scripted_device.h"
#include "organsim/io/atomic_file.h"
#include "organsim/mesh_io/mesh_io.h"
#include "organsim/realtime/model_registry.h"
#include "organsim/realtime/session_playback.h"
#include "organsim/model/model_file.h"
#include "organsim/realtime/loop_runner.h"

namespace organsim::cli {
namespace {

namespace fs = std::filesystem;
using namespace organsim::devices;
using namespace organsim::realtime;

struct ReplayOptions {
  std::string model_path;
  std::string session_path;
  std::vector<std::string> models{realtime::default_model().name};
  ModelTuning tuning;
  std::string forces_path;
  std::string frames_dir;
  std::string report_dir;  // "": no training report
  report::ReportOptions report;
  bool fast = false;
  bool json = false;
  bool long_session = false;
  double repeat_for = 0.0;  // s; 0: play the session once
  double progress = 0.0;    // s between progress lines; 0: none
  double max_force = SafetyLimits{}.max_force;
  double max_stiffness = SafetyLimits{}.max_stiffness;
};

nlohmann::json timing_json(const Percentiles& p) {
  return {{"p50_ms", p.p50 * 1e3}, {"p99_ms", p.p99 * 1e3}, {"max_ms", p.max * 1e3}};
}

// Writes each published deformation frame as VTP (LPS, mm; the model file's
// vertex order) and a ParaView collection (.pvd) indexing them, written as the
// frames come (published complete by finish()) so that memory stays bounded.
class FrameWriter {
 public:
  FrameWriter(const std::string& directory, const organ::Organ& organ, std::vector<model::Triangle> triangles)
      : directory_(directory), organ_(organ), triangles_(std::move(triangles)) {
    if (directory_.empty()) return;
    fs::create_directories(directory_);
    index_ = std::make_unique<io::AtomicStream>((fs::path(directory_) / "frames.pvd").string());
    index_->append("<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"0.1\">\n  <Collection>\n");
  }
  void take(const SurfaceFrame& frame) {
    if (directory_.empty()) return;
    in_file_order_.resize(frame.positions.size());
    for (std::size_t v = 0; v < frame.positions.size(); ++v)
      in_file_order_[organ_.file_vertex_index()[v]] = frame.positions[v];
    const std::string name = fmt::format("frame_{:05d}.vtp", frame.frame);
    mesh_io::write_surface_vtp({in_file_order_, triangles_}, (fs::path(directory_) / name).string());
    index_->append(fmt::format("    <DataSet timestep=\"{:.6f}\" file=\"{}\"/>\n", frame.time, name));
    ++count_;
  }
  void finish() {
    if (directory_.empty()) return;
    index_->append("  </Collection>\n</VTKFile>\n");
    index_->commit();
  }
  std::size_t count() const { return count_; }

 private:
  std::string directory_;
  const organ::Organ& organ_;
  std::vector<model::Triangle> triangles_;
  std::vector<model::Point3> in_file_order_;
  std::unique_ptr<io::AtomicStream> index_;
  std::size_t count_ = 0;
};

// The forces the devices received, taken out of their rings while the loops
// run and appended to the CSV file (published complete at the end), one row
// per tool and tick in time order.
class ForceWriter {
 public:
  explicit ForceWriter(const std::string& path) {
    if (path.empty()) return;
    csv_ = std::make_unique<io::AtomicStream>(path);
    csv_->append("t_s,tool,fx_n,fy_n,fz_n,in_contact\n");
  }
  /// Writes the ticks every device has recorded; at the end (`all`), whatever is left.
  void take(const std::vector<std::unique_ptr<ScriptedDevice>>& devices, bool all = false) {
    if (!csv_) return;
    ForceRecord record;
    while (true) {
      bool any = false;
      for (const auto& device : devices) any = any || device->record_count() > 0;
      bool every = true;
      for (const auto& device : devices) every = every && device->record_count() > 0;
      if (!(every || (all && any))) return;
      for (std::size_t i = 0; i < devices.size(); ++i) {
        if (!devices[i]->take_record(record)) continue;
        const int length = std::snprintf(line_, sizeof line_, "%.6f,%zu,%.9g,%.9g,%.9g,%d\n", record.time, i + 1,
                                         record.force[0], record.force[1], record.force[2], record.in_contact ? 1 : 0);
        csv_->append(line_, static_cast<std::size_t>(length));
      }
    }
  }
  void finish() {
    if (csv_) csv_->commit();
  }

 private:
  std::unique_ptr<io::AtomicStream> csv_;
  char line_[160];
};

// Resident memory of this process (MiB), from /proc/self/statm.
double resident_mib() {
  std::ifstream statm("/proc/self/statm");
  std::size_t size = 0, resident = 0;
  statm >> size >> resident;
  return static_cast<double>(resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

// A line every `interval` seconds of wall time while a model runs: elapsed
// time, resident memory and the loops' statistics over the interval (stderr;
// JSON with --json), for long runs and soaks (tools/scripts/soak.sh).
class ProgressReporter {
 public:
  ProgressReporter(double interval, const std::string& model, bool json)
      : interval_(interval), model_(model), json_(json), start_(std::chrono::steady_clock::now()), next_(interval) {}
  void poll(const RunTimings& timings) {
    if (interval_ <= 0.0) return;
    const double elapsed = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    if (elapsed < next_) return;
    next_ += interval_;
    const DurationHistogram period = timings.force_periods.since(last_.force_periods);
    const DurationHistogram compute = timings.force_computes.since(last_.force_computes);
    const DurationHistogram frames = timings.deformation_computes.since(last_.deformation_computes);
    last_ = timings;
    const double memory = resident_mib();
    if (json_) {
      std::cerr << nlohmann::json{{"progress_s", elapsed},
                                  {"model", model_},
                                  {"resident_mib", memory},
                                  {"force_ticks", compute.count()},
                                  {"force_period", timing_json(period.percentiles())},
                                  {"force_compute", timing_json(compute.percentiles())},
                                  {"deadline_misses", period.above_threshold()},
                                  {"frames", frames.count()},
                                  {"deformation_compute", timing_json(frames.percentiles())}}
                       .dump()
                << std::endl;
      return;
    }
    std::cerr << fmt::format(
                     "replay: {:.0f} s, {}: resident {:.1f} MiB; force loop {} ticks, period p50 {:.3f} ms, p99 {:.3f} "
                     "ms, max {:.3f} ms, {} misses; {} frames, compute p99 {:.2f} ms",
                     elapsed, model_, memory, compute.count(), period.quantile(0.5) * 1e3, period.quantile(0.99) * 1e3,
                     period.max() * 1e3, period.above_threshold(), frames.count(), frames.quantile(0.99) * 1e3)
              << std::endl;
  }

 private:
  double interval_;
  std::string model_;
  bool json_;
  std::chrono::steady_clock::time_point start_;
  double next_;
  RunTimings last_;
};

/// One model's run of the session.
struct ModelRun {
  std::string name;
  std::unique_ptr<SessionPlayback> playback;  ///< its devices hold the forces they received
  std::vector<ToolTelemetry> telemetry;
  std::vector<std::uint64_t> clamped, watchdog, non_finite;  ///< force-safety ticks per tool
  RunTimings timings;
  std::uint64_t refused = 0, instabilities = 0;
  double setup_seconds = 0.0;    ///< building the engine: the model's set-up (FEM: ordering, factorization)
  double resident_mib = 0.0;     ///< this process's resident memory after the set-up (--json)
  double estimated_frame = 0.0;  ///< s, the model's own estimate from its set-up (0: none)

  const std::vector<std::unique_ptr<ScriptedDevice>>& devices() const { return playback->devices(); }
};

// Records each device's ring holds: 8 s of force ticks, far more than the
// writer lets accumulate between two takes (2 ms in real time, one frame fast).
constexpr std::size_t kRingRecords = 8192;

EngineOptions engine_options(const ReplayOptions& o, const std::string& name) {
  EngineOptions options;
  options.model = name;
  if (!o.report_dir.empty()) options.tick_records = report::kTickRecordsPerTool;
  apply_model_tuning(o.tuning, options);
  return options;
}

/// Says what the model's undone frames mean, when there were any.
void warn_instabilities(const std::string& name, std::uint64_t instabilities) {
  if (instabilities == 0) return;
  if (!realtime::find_model(name)->fem_material)
    warn("replay", fmt::format("the {} model diverged {} time(s) and was reset to rest; use a smaller time step", name,
                               instabilities));
  else
    warn("replay",
         fmt::format("the {} model kept the organ's shape in {} frame(s): its iteration would have inverted "
                     "a tetrahedron even at a sixteenth of its step (a tool pressed deeper than the material "
                     "and mesh can follow), or thrown the organ out of balance (a tangent made at a state far "
                     "from this one, as when the tools let go of a pressed organ; the next tangent moves it "
                     "again)",
                     name, instabilities));
}

/// Where a model's training report goes: DIR, or DIR/<model> when several models play.
std::string report_directory(const ReplayOptions& o, const std::string& name) {
  return o.models.size() > 1 ? (fs::path(o.report_dir) / name).string() : o.report_dir;
}

/// run.json's session description for the training report.
nlohmann::json run_description(const ReplayOptions& o, const ModelRun& run, double duration) {
  const Percentiles period = run.timings.force_periods.percentiles();
  const auto timing = [&](double seconds) { return o.fast ? nlohmann::json(nullptr) : nlohmann::json(seconds * 1e3); };
  report::SessionFacts facts;
  facts.deformation_model = run.name;
  facts.model_path = o.model_path;
  facts.session_path = o.session_path;
  facts.mode = o.fast ? "fast" : "realtime";
  facts.duration_s = duration;
  facts.device_max_force_n = o.max_force;
  facts.real_time = !o.fast;
  facts.loop_health = {{"force_ticks", run.timings.force_computes.count()},
                       {"period_p50_ms", timing(period.p50)},
                       {"period_p99_ms", timing(period.p99)},
                       {"period_max_ms", timing(period.max)},
                       {"frames", run.timings.deformation_computes.count()}};
  if (!o.fast) {  // stepped in session time (--fast), nothing can be late
    facts.loop_health["force_deadline_misses"] = run.timings.force_deadline_misses;
    facts.loop_health["frames_dropped"] = run.timings.deformation_frames_dropped;
  }
  return report::describe_session(facts, run.playback->engine());
}

ModelRun run_model(const ReplayOptions& o, const std::string& name, const organ::Organ& organ, const Session& session,
                   FrameWriter& frames, ForceWriter& forces) {
  PlaybackOptions playback;
  playback.limits.max_force = o.max_force;
  playback.limits.max_stiffness = o.max_stiffness;
  playback.records_per_tool = kRingRecords;
  playback.repeat_period = o.repeat_for > 0.0 ? session.duration : 0.0;
  ModelRun run;
  run.name = name;
  const auto setup_start = std::chrono::steady_clock::now();
  run.playback = std::make_unique<SessionPlayback>(organ, session, engine_options(o, name), playback);
  run.setup_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - setup_start).count();
  run.resident_mib = resident_mib();
  const Engine& engine = run.playback->engine();
  run.estimated_frame = engine.model().estimated_frame_seconds();
  if (!o.fast) warn_if_frames_overrun("replay", engine);
  const double duration = o.repeat_for > 0.0 ? o.repeat_for : session.duration;
  ProgressReporter progress(o.progress, name, o.json);
  std::unique_ptr<report::RunRecorder> recorder;
  if (!o.report_dir.empty())
    recorder = std::make_unique<report::RunRecorder>(report_directory(o, name), organ, session.tools.size());
  auto take = [&](const RunTimings& so_far) {
    TripleBuffer<SurfaceFrame>& surfaces = run.playback->engine().surfaces();
    if (surfaces.update()) {
      frames.take(surfaces.read());
      if (recorder) recorder->take_frame(surfaces.read());
    }
    if (recorder) recorder->take_ticks(run.playback->engine());
    forces.take(run.devices());
    progress.poll(so_far);
  };
  if (o.fast)
    run.timings = run.playback->run_fast(duration, take);
  else
    run.timings = run.playback->run_realtime(duration, [&](const RunTimings& so_far) {
      take(so_far);
      return true;
    });
  forces.take(run.devices(), true);
  if (!run.timings.priority_warning.empty() && !o.fast) warn("replay", run.timings.priority_warning);
  for (std::size_t i = 0; i < run.devices().size(); ++i) {
    run.telemetry.push_back(engine.telemetry(i));
    run.clamped.push_back(engine.safety(i).clamp_count());
    run.watchdog.push_back(engine.safety(i).stalled_count());
    run.non_finite.push_back(engine.safety(i).non_finite_count());
  }
  run.refused = engine.refused_contacts();
  run.instabilities = engine.model().instabilities();
  warn_instabilities(name, run.instabilities);
  if (recorder) {
    recorder->finish(run.playback->engine(), run_description(o, run, duration));
    for (const std::string& problem : report::write_report(report_directory(o, name), o.report))
      warn("replay", problem);
  }
  return run;
}

void print_json(const ReplayOptions& o, const Session& session, const ModelRun& run, const FrameWriter& frames) {
  const RunTimings& timings = run.timings;
  const Percentiles period = timings.force_periods.percentiles(), compute = timings.force_computes.percentiles();
  nlohmann::json j;
  j["model"] = o.model_path;
  j["session"] = o.session_path;
  j["mode"] = o.fast ? "fast" : "realtime";
  j.update(parameter_values(*realtime::find_model(run.name), o.tuning.models));
  j["duration_s"] = o.repeat_for > 0.0 ? o.repeat_for : session.duration;
  j["wall_s"] = timings.wall_seconds;
  nlohmann::json tools = nlohmann::json::array();
  for (std::size_t i = 0; i < run.devices().size(); ++i)
    tools.push_back({{"tool", i + 1},
                     {"contacts", run.telemetry[i].contacts},
                     {"peak_force_n", run.telemetry[i].peak_force},
                     {"grasps", run.telemetry[i].grasps},
                     {"grasp_slips", run.telemetry[i].grasp_slips},
                     {"peak_pull_n", run.telemetry[i].peak_pull},
                     {"clamped_ticks", run.clamped[i]},
                     {"watchdog_ticks", run.watchdog[i]},
                     {"non_finite_forces", run.non_finite[i]}});
  j["tools"] = tools;
  j["force_loop"] = {{"ticks", timings.force_computes.count()},
                     {"period", o.fast ? nlohmann::json(nullptr) : timing_json(period)},
                     {"compute", timing_json(compute)},
                     {"deadline_misses", timings.force_deadline_misses},
                     {"realtime_priority", timings.realtime_priority}};
  j["deformation_loop"] = {{"frames", timings.deformation_computes.count()},
                           {"dropped", timings.deformation_frames_dropped},
                           {"compute", timing_json(timings.deformation_computes.percentiles())},
                           {"contact_frames", timings.contact_computes.count()},
                           {"contact_compute", timing_json(timings.contact_computes.percentiles())}};
  j["setup"] = {{"seconds", run.setup_seconds},
                {"resident_mib", run.resident_mib},
                {"estimated_frame_ms",
                 run.estimated_frame > 0.0 ? nlohmann::json(run.estimated_frame * 1e3) : nlohmann::json(nullptr)}};
  j["refused_contacts"] = run.refused;
  j["deformation_model"] = run.name;
  j["instabilities"] = run.instabilities;
  if (!o.forces_path.empty()) j["forces_csv"] = o.forces_path;
  if (!o.frames_dir.empty()) j["frames"] = {{"directory", o.frames_dir}, {"count", frames.count()}};
  if (!o.report_dir.empty()) j["report"] = (fs::path(report_directory(o, run.name)) / "index.html").string();
  std::cout << j.dump() << '\n';
}

/// The text report: one column per model.
void print_text(const ReplayOptions& o, const Session& session, const std::vector<ModelRun>& runs,
                const FrameWriter& frames) {
  const bool single = runs.size() == 1;
  std::string names;
  for (const ModelRun& run : runs) names += (names.empty() ? "" : ", ") + run.name;
  std::cout << fmt::format(
      "{:<16}{} with {} ({} model{}, {} tools, {:.2f} s, {} mode{})\n", "replay", o.session_path, o.model_path, names,
      single ? "" : "s", session.tools.size(), o.repeat_for > 0.0 ? o.repeat_for : session.duration,
      o.fast ? "fast" : "real-time",
      single ? choice_text(*realtime::find_model(runs.front().name), o.tuning.models, ", ") : std::string());
  auto row = [&](const std::string& label, auto&& cell) {
    std::string line = fmt::format("{:<16}", label);
    for (std::size_t m = 0; m < runs.size(); ++m) {
      const std::string text = cell(runs[m]);
      line += single ? text : fmt::format("{:<52}", runs[m].name + ": " + text + "  ");
    }
    while (!line.empty() && line.back() == ' ') line.pop_back();
    std::cout << line << '\n';
  };
  for (std::size_t i = 0; i < session.tools.size(); ++i)
    row(fmt::format("tool {}", i + 1), [&](const ModelRun& run) {
      const ToolTelemetry& t = run.telemetry[i];
      const std::string grasps =
          t.grasps > 0 ? fmt::format(", {} grasp(s) pulling up to {:.3f} N{}", t.grasps, t.peak_pull,
                                     t.grasp_slips > 0 ? fmt::format(", {} slipped", t.grasp_slips) : std::string())
                       : std::string();
      return fmt::format("{} contact(s), peak force {:.3f} N{}{}", t.contacts, t.peak_force, grasps,
                         run.clamped[i] > 0
                             ? fmt::format(" (clamped to {:.2f} N in {} ticks)", o.max_force, run.clamped[i])
                             : std::string());
    });
  row("force loop", [&](const ModelRun& run) {
    const Percentiles compute = run.timings.force_computes.percentiles();
    if (o.fast || !single)
      return fmt::format("{} ticks, compute p50 {:.2f} us, p99 {:.2f} us{}", run.timings.force_computes.count(),
                         compute.p50 * 1e6, compute.p99 * 1e6,
                         single ? fmt::format(", max {:.2f} us", compute.max * 1e6) : std::string());
    const Percentiles period = run.timings.force_periods.percentiles();
    return fmt::format(
        "{} ticks, period p50 {:.3f} ms, p99 {:.3f} ms, max {:.3f} ms; compute p50 {:.2f} us, p99 {:.2f} us, "
        "max {:.2f} us; {} deadline misses (> 2 ms){}",
        run.timings.force_computes.count(), period.p50 * 1e3, period.p99 * 1e3, period.max * 1e3, compute.p50 * 1e6,
        compute.p99 * 1e6, compute.max * 1e6, run.timings.force_deadline_misses,
        run.timings.realtime_priority ? ", real-time priority" : "");
  });
  if (!o.fast && !single)
    row("force period", [&](const ModelRun& run) {
      const Percentiles period = run.timings.force_periods.percentiles();
      return fmt::format("p50 {:.3f}, p99 {:.3f}, max {:.3f} ms; {} misses", period.p50 * 1e3, period.p99 * 1e3,
                         period.max * 1e3, run.timings.force_deadline_misses);
    });
  row("deformation", [&](const ModelRun& run) {
    const Percentiles deform = run.timings.deformation_computes.percentiles();
    return fmt::format("{} frames, compute p50 {:.3f} ms, p99 {:.3f} ms", run.timings.deformation_computes.count(),
                       deform.p50 * 1e3, deform.p99 * 1e3);
  });
  row("set-up", [&](const ModelRun& run) {
    return fmt::format("{:.2f} s{}", run.setup_seconds,
                       run.estimated_frame > 0.0 ? fmt::format(", frame estimate {:.1f} ms", run.estimated_frame * 1e3)
                                                 : std::string());
  });
  if (!o.forces_path.empty()) std::cout << fmt::format("{:<16}{}\n", "forces", o.forces_path);
  if (!o.frames_dir.empty())
    std::cout << fmt::format("{:<16}{} frames in {} (frames.pvd for ParaView)\n", "surfaces", frames.count(),
                             o.frames_dir);
  for (const ModelRun& run : runs)
    if (!o.report_dir.empty())
      std::cout << fmt::format("{:<16}{}/index.html (metrics.json beside it)\n", "report",
                               report_directory(o, run.name));
}

int run_replay(const ReplayOptions& o) {
  if (o.models.size() > 1 && (o.json || !o.forces_path.empty() || !o.frames_dir.empty()))
    throw CLI::ValidationError("--model", "--json, --forces and --frames take one model; give one --model");
  if (!o.frames_dir.empty() && fs::exists(o.frames_dir) && !fs::is_directory(o.frames_dir))
    throw std::runtime_error("--frames " + o.frames_dir + " is a file; give a directory");
  if (!o.report_dir.empty() && fs::exists(o.report_dir) && !fs::is_directory(o.report_dir))
    throw std::runtime_error("--report " + o.report_dir + " is a file; give a directory");
  if (o.repeat_for > SessionLimits{}.max_duration && !o.long_session)
    throw CLI::ValidationError("--repeat-for", "longer than a day; pass --long-session to run it on purpose");
  model::OrganModel loaded = load_simulation_model("replay", o.model_path, o.models);
  const Session session = read_session(o.session_path, session_limits(loaded, o.long_session));
  if (o.repeat_for > 0.0 && !(session.duration > 0.0))
    throw CLI::ValidationError("--repeat-for", "the session lasts 0 s; it needs samples at two times to repeat");
  warn_if_depth_curve_rescaled("replay", loaded, o.models, o.tuning, &session);
  const std::vector<model::Triangle> file_triangles = loaded.surface_triangles;
  const organ::Organ organ(std::move(loaded));

  FrameWriter frames(o.frames_dir, organ, file_triangles);
  ForceWriter forces(o.forces_path);
  std::vector<ModelRun> runs;
  for (const std::string& name : o.models) runs.push_back(run_model(o, name, organ, session, frames, forces));
  frames.finish();
  forces.finish();
  if (o.json)
    print_json(o, session, runs.front(), frames);
  else
    print_text(o, session, runs, frames);
  return 0;
}

}  // namespace

Command add_replay_command(CLI::App& app) {
  auto o = std::make_shared<ReplayOptions>();
  app.add_option("model", o->model_path, "Model file (.organ)")->required();
  app.add_option("session", o->session_path, "Session file: recorded tool trajectories (docs/session-format.md)")
      ->required();
  app.add_option("--model", o->models,
                 deformation_model_help() +
                     "; a comma-separated list replays the session through each and reports them side by side")
      ->delimiter(',')
      ->check(CLI::IsMember(deformation_model_names()))
      ->capture_default_str();
  add_model_tuning_options(app, o->tuning);
  add_grasp_option(app, o->tuning);
  app.add_option("--forces", o->forces_path,
                 "Write every force sent to the devices (CSV: t_s,tool,fx_n,fy_n,fz_n,in_contact)");
  app.add_option("--frames", o->frames_dir,
                 "Write the deformed surface of every frame (VTP + frames.pvd) into this directory");
  app.add_option("--report", o->report_dir,
                 "Write a training report into this directory: index.html (one self-contained page), metrics.json and "
                 "the run's raw data, which `organsim report DIR` rebuilds it from; with several models one per "
                 "model in DIR/<model> (docs/report.md)");
  add_report_options(app, o->report);
  app.add_flag("--fast", o->fast, "Step the loops deterministically as fast as possible (bit-identical forces)");
  app.add_flag("--json", o->json, "Print the summary as one JSON object on stdout (and progress lines as JSON)");
  app.add_option("--repeat-for", o->repeat_for, "Play the session over and over for this long, s (soak tests)")
      ->check(kPositive);
  app.add_option("--progress", o->progress,
                 "Every this many seconds, print resident memory and the loops' statistics to stderr")
      ->check(kPositive);
  app.add_flag("--long-session", o->long_session, "Allow sessions (or --repeat-for) longer than 24 h");
  app.add_option("--max-force", o->max_force, "Device force limit, N")->check(kPositive)->capture_default_str();
  app.add_option("--max-stiffness", o->max_stiffness, "Device stiffness limit, N/m")
      ->check(kPositive)
      ->capture_default_str();
  return [o] { return run_replay(*o); };
}

}  // namespace organsim::cli
