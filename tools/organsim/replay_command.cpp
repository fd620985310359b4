// `organsim replay MODEL SESSION`: a recorded multi-tool session through the
// real engine, with scripted devices: forces, contacts and loop timings.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line.h"
#include "model_tuning.h"
#include "organsim/devices/scripted_device.h"
#include "organsim/io/atomic_file.h"
#include "organsim/mesh_io/mesh_io.h"
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
  std::string merge = "influence";
  std::vector<std::string> models{"beam"};
  ModelTuning tuning;
  std::string forces_path;
  std::string frames_dir;
  bool fast = false;
  bool json = false;
  double max_force = SafetyLimits{}.max_force;
  double max_stiffness = SafetyLimits{}.max_stiffness;
};

// Writes each published deformation frame as VTP (LPS, mm; the model file's
// vertex order) and, at the end, a ParaView collection (.pvd) indexing them.
class FrameWriter {
 public:
  FrameWriter(const std::string& directory, const multibeam::BeamOrgan& organ, std::vector<model::Triangle> triangles)
      : directory_(directory), organ_(organ), triangles_(std::move(triangles)) {
    if (directory_.empty()) return;
    fs::create_directories(directory_);
  }
  void take(TripleBuffer<SurfaceFrame>& frames) {
    if (directory_.empty() || !frames.update()) return;
    const SurfaceFrame& frame = frames.read();
    std::vector<model::Point3> in_file_order(frame.positions.size());
    for (std::size_t v = 0; v < frame.positions.size(); ++v)
      in_file_order[organ_.file_vertex_index()[v]] = frame.positions[v];
    const std::string name = fmt::format("frame_{:05d}.vtp", frame.frame);
    mesh_io::write_surface_vtp({in_file_order, triangles_}, (fs::path(directory_) / name).string());
    index_.emplace_back(frame.time, name);
  }
  void finish() const {
    if (directory_.empty()) return;
    mesh_io::write_collection_pvd(index_, (fs::path(directory_) / "frames.pvd").string());
  }
  std::size_t count() const { return index_.size(); }

 private:
  std::string directory_;
  const multibeam::BeamOrgan& organ_;
  std::vector<model::Triangle> triangles_;
  std::vector<mesh_io::TimeStep> index_;
};

nlohmann::json timing_json(const Percentiles& p) {
  return {{"p50_ms", p.p50 * 1e3}, {"p99_ms", p.p99 * 1e3}, {"max_ms", p.max * 1e3}};
}

/// One model's run of the session.
struct ModelRun {
  std::string name;
  std::vector<std::unique_ptr<ScriptedDevice>> devices;  ///< with the forces they received
  std::vector<ToolTelemetry> telemetry;
  std::vector<std::uint64_t> clamped, watchdog, non_finite;  ///< force-safety ticks per tool
  RunTimings timings;
  std::uint64_t refused = 0, instabilities = 0;
};

ModelRun run_model(const ReplayOptions& o, const std::string& name, const multibeam::BeamOrgan& organ,
                   const Session& session, FrameWriter& frames) {
  SafetyLimits limits;
  limits.max_force = o.max_force;
  limits.max_stiffness = o.max_stiffness;
  EngineOptions options;
  parse_model_kind(name, options.model);
  apply_model_tuning(o.tuning, options.fem, options.springs);
  options.beams.merge = o.merge == "sum" ? multibeam::MergeRule::sum : multibeam::MergeRule::influence;
  const auto records = static_cast<std::size_t>(session.duration / options.force_period) + 16;
  ModelRun run;
  run.name = name;
  std::vector<HapticDevice*> device_pointers;
  for (const Trajectory& t : session.tools) {
    run.devices.push_back(std::make_unique<ScriptedDevice>(t, limits, records));
    device_pointers.push_back(run.devices.back().get());
  }
  Engine engine(organ, device_pointers, options);
  run.timings = o.fast ? run_fast(engine, session.duration, [&] { frames.take(engine.surfaces()); })
                       : run_realtime(engine, session.duration, [&] {
                           frames.take(engine.surfaces());
                           return true;
                         });
  if (!run.timings.priority_warning.empty() && !o.fast) warn("replay", run.timings.priority_warning);
  for (std::size_t i = 0; i < run.devices.size(); ++i) {
    run.telemetry.push_back(engine.telemetry(i));
    run.clamped.push_back(engine.safety(i).clamp_count());
    run.watchdog.push_back(engine.safety(i).stalled_count());
    run.non_finite.push_back(engine.safety(i).non_finite_count());
  }
  run.refused = engine.refused_contacts();
  run.instabilities = engine.model().instabilities();
  if (run.instabilities > 0 && options.model == ModelKind::springs)
    warn("replay", fmt::format("the {} model diverged {} time(s) and was reset to rest; use a smaller time step", name,
                               run.instabilities));
  else if (run.instabilities > 0)
    warn("replay", fmt::format("the {} model kept the organ's shape in {} frame(s): even a sixteenth of the iteration "
                               "would have inverted a tetrahedron (the tool pressed deeper than the material and mesh "
                               "can follow)",
                               name, run.instabilities));
  return run;
}

void write_forces_csv(const ModelRun& run, const std::string& path) {
  std::ostringstream csv;
  csv << "t_s,tool,fx_n,fy_n,fz_n,in_contact\n";
  for (std::size_t i = 0; i < run.devices.size(); ++i)
    for (std::size_t r = 0; r < run.devices[i]->record_count(); ++r) {
      const ForceRecord& f = run.devices[i]->record(r);
      csv << fmt::format("{:.6f},{},{:.9g},{:.9g},{:.9g},{}\n", f.time, i + 1, f.force[0], f.force[1], f.force[2],
                         f.in_contact ? 1 : 0);
    }
  io::write_file_atomically(path, csv.str());
}

void print_json(const ReplayOptions& o, const Session& session, const ModelRun& run, const FrameWriter& frames) {
  const RunTimings& timings = run.timings;
  const Percentiles period = percentiles(timings.force_periods), compute = percentiles(timings.force_computes);
  nlohmann::json j;
  j["model"] = o.model_path;
  j["session"] = o.session_path;
  j["mode"] = o.fast ? "fast" : "realtime";
  j["merge"] = o.merge;
  j["duration_s"] = session.duration;
  j["wall_s"] = timings.wall_seconds;
  nlohmann::json tools = nlohmann::json::array();
  for (std::size_t i = 0; i < run.devices.size(); ++i)
    tools.push_back({{"tool", i + 1},
                     {"contacts", run.telemetry[i].contacts},
                     {"peak_force_n", run.telemetry[i].peak_force},
                     {"clamped_ticks", run.clamped[i]},
                     {"watchdog_ticks", run.watchdog[i]},
                     {"non_finite_forces", run.non_finite[i]}});
  j["tools"] = tools;
  j["force_loop"] = {{"ticks", timings.force_computes.size()},
                     {"period", o.fast ? nlohmann::json(nullptr) : timing_json(period)},
                     {"compute", timing_json(compute)},
                     {"deadline_misses", timings.force_deadline_misses},
                     {"realtime_priority", timings.realtime_priority}};
  j["deformation_loop"] = {{"frames", timings.deformation_computes.size()},
                           {"compute", timing_json(percentiles(timings.deformation_computes))}};
  j["refused_contacts"] = run.refused;
  j["deformation_model"] = run.name;
  j["instabilities"] = run.instabilities;
  if (!o.forces_path.empty()) j["forces_csv"] = o.forces_path;
  if (!o.frames_dir.empty()) j["frames"] = {{"directory", o.frames_dir}, {"count", frames.count()}};
  std::cout << j.dump() << '\n';
}

/// The text report: one column per model.
void print_text(const ReplayOptions& o, const Session& session, const std::vector<ModelRun>& runs,
                const FrameWriter& frames) {
  const bool single = runs.size() == 1;
  std::string names;
  for (const ModelRun& run : runs) names += (names.empty() ? "" : ", ") + run.name;
  std::cout << fmt::format("{:<16}{} with {} ({} model{}, {} tools, {:.2f} s, {} mode{})\n", "replay", o.session_path,
                           o.model_path, names, single ? "" : "s", session.tools.size(), session.duration,
                           o.fast ? "fast" : "real-time",
                           runs.front().name == "beam" || !single ? ", " + o.merge + " merge" : std::string());
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
      return fmt::format("{} contact(s), peak force {:.3f} N{}", run.telemetry[i].contacts, run.telemetry[i].peak_force,
                         run.clamped[i] > 0 ? fmt::format(" (clamped to {:.2f} N in {} ticks)", o.max_force, run.clamped[i])
                                            : std::string());
    });
  row("force loop", [&](const ModelRun& run) {
    const Percentiles compute = percentiles(run.timings.force_computes);
    if (o.fast || !single)
      return fmt::format("{} ticks, compute p50 {:.2f} us, p99 {:.2f} us{}", run.timings.force_computes.size(),
                         compute.p50 * 1e6, compute.p99 * 1e6,
                         single ? fmt::format(", max {:.2f} us", compute.max * 1e6) : std::string());
    const Percentiles period = percentiles(run.timings.force_periods);
    return fmt::format(
        "{} ticks, period p50 {:.3f} ms, p99 {:.3f} ms, max {:.3f} ms; compute p50 {:.2f} us, p99 {:.2f} us, "
        "max {:.2f} us; {} deadline misses (> 2 ms){}",
        run.timings.force_computes.size(), period.p50 * 1e3, period.p99 * 1e3, period.max * 1e3, compute.p50 * 1e6,
        compute.p99 * 1e6, compute.max * 1e6, run.timings.force_deadline_misses,
        run.timings.realtime_priority ? ", real-time priority" : "");
  });
  if (!o.fast && !single)
    row("force period", [&](const ModelRun& run) {
      const Percentiles period = percentiles(run.timings.force_periods);
      return fmt::format("p50 {:.3f}, p99 {:.3f}, max {:.3f} ms; {} misses", period.p50 * 1e3, period.p99 * 1e3,
                         period.max * 1e3, run.timings.force_deadline_misses);
    });
  row("deformation", [&](const ModelRun& run) {
    const Percentiles deform = percentiles(run.timings.deformation_computes);
    return fmt::format("{} frames, compute p50 {:.3f} ms, p99 {:.3f} ms", run.timings.deformation_computes.size(),
                       deform.p50 * 1e3, deform.p99 * 1e3);
  });
  if (!o.forces_path.empty()) std::cout << fmt::format("{:<16}{}\n", "forces", o.forces_path);
  if (!o.frames_dir.empty())
    std::cout << fmt::format("{:<16}{} frames in {} (frames.pvd for ParaView)\n", "surfaces", frames.count(), o.frames_dir);
}

int run_replay(const ReplayOptions& o) {
  if (o.models.size() > 1 && (o.json || !o.forces_path.empty() || !o.frames_dir.empty()))
    throw CLI::ValidationError("--model", "--json, --forces and --frames take one model; give one --model");
  if (!o.frames_dir.empty() && fs::exists(o.frames_dir) && !fs::is_directory(o.frames_dir))
    throw std::runtime_error("--frames " + o.frames_dir + " is a file; give a directory");
  model::OrganModel loaded = load_simulation_model("replay", o.model_path);
  const Session session = read_session(o.session_path);
  const std::vector<model::Triangle> file_triangles = loaded.surface_triangles;
  const multibeam::BeamOrgan organ(std::move(loaded));

  FrameWriter frames(o.frames_dir, organ, file_triangles);
  std::vector<ModelRun> runs;
  for (const std::string& name : o.models) runs.push_back(run_model(o, name, organ, session, frames));
  frames.finish();
  if (!o.forces_path.empty()) write_forces_csv(runs.front(), o.forces_path);
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
                 "Deformation model: beam (multi-beam), springs (mass-spring), or FEM: linear, corotational, stvk, psh; "
                 "a list (beam,springs,psh) replays the session through each and reports them side by side")
      ->delimiter(',')
      ->check(CLI::IsMember(deformation_model_names()))
      ->capture_default_str();
  add_model_tuning_options(app, o->tuning);
  app.add_option("--merge", o->merge, "How beams combine: influence (eq. 7) or sum (eq. 5)")
      ->check(CLI::IsMember({"influence", "sum"}))
      ->capture_default_str();
  app.add_option("--forces", o->forces_path, "Write every force sent to the devices (CSV: t_s,tool,fx_n,fy_n,fz_n,in_contact)");
  app.add_option("--frames", o->frames_dir, "Write the deformed surface of every frame (VTP + frames.pvd) into this directory");
  app.add_flag("--fast", o->fast, "Step the loops deterministically as fast as possible (bit-identical forces)");
  app.add_flag("--json", o->json, "Print the summary as one JSON object on stdout");
  app.add_option("--max-force", o->max_force, "Device force limit, N")->check(kPositive)->capture_default_str();
  app.add_option("--max-stiffness", o->max_stiffness, "Device stiffness limit, N/m")
      ->check(kPositive)
      ->capture_default_str();
  return [o] { return run_replay(*o); };
}

}  // namespace organsim::cli
