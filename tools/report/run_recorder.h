// What a training report is built from, written into its directory while a
// session runs, streamed so that memory stays flat however long it lasts
// (docs/report.md):
//   ticks.csv     one row per force tick and tool: t_s, tool, the force sent
//                 (fx_n, fy_n, fz_n), the model's force before the safety
//                 rules (model_force_n), in_contact, the tip (x_mm, y_mm,
//                 z_mm, LPS), the indentation depth_mm and pose_valid;
//   frames.csv    one row per published deformation frame: t_s, volume_ml;
//   surface.csv   per surface vertex (the model file's order): the rest
//                 position (mm) and the peak indentation it reached (mm);
//   triangles.csv the surface's triangles (the model file's vertex numbers);
//   run.json      the session: model, the model file's SHA-256, date,
//                 duration, tools, loop health.
// Every file is written atomically (published complete when the run ends).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "organsim/io/atomic_file.h"
#include "organsim/organ/organ.h"
#include "organsim/realtime/engine.h"

namespace organsim::report {

/// Force-tick records kept per tool between two takes: 8 s at 1 kHz, far more
/// than a reader polling every frame lets build up.
constexpr std::size_t kTickRecordsPerTool = 8192;

class RunRecorder {
 public:
  /// Creates `directory`; throws std::runtime_error when it cannot be written.
  RunRecorder(const std::string& directory, const organ::Organ& organ, std::size_t tools);

  /// Moves every tick record the engine holds into ticks.csv (the reader's thread).
  void take_ticks(realtime::Engine& engine);
  /// The frame's volume, and each vertex's deepest indentation so far.
  void take_frame(const realtime::SurfaceFrame& frame);
  /// Writes what is left and run.json (`run` holds the session's description:
  /// model, duration_s, loop health, ...; the recorder adds the files' own
  /// counts), and publishes every file.
  void finish(realtime::Engine& engine, nlohmann::json run);

 private:
  std::string directory_;
  const organ::Organ& organ_;
  std::size_t tools_;
  std::unique_ptr<io::AtomicStream> ticks_, frames_;
  std::vector<double> peak_indentation_;  // m, per surface vertex (runtime order)
  std::vector<double> peak_strain_;       // per surface triangle: its edges' largest |length / rest − 1|
  std::size_t tick_count_ = 0, frame_count_ = 0;
  char line_[256];
};

/// SHA-256 (lowercase hex) of a file's bytes: what names the patient model in a
/// report without anything of the patient in it.
std::string file_sha256(const std::string& path);
/// What a command knows of the session it ran, for run.json.
struct SessionFacts {
  std::string deformation_model, model_path;
  std::string session_path;  ///< the session file, or "" when live tools moved (`live_tools` says which)
  std::string live_tools;
  std::string mode;
  double duration_s = 0.0;
  double device_max_force_n = 0.0;  ///< the device's force clamp, N
  bool real_time = true;            ///< the loops ran in real time: the machine's floor is probed after them
  nlohmann::json loop_health = nlohmann::json::object();  ///< the command's own loop counts
};

/// run.json's session description: the facts, the model and session files
/// named by their SHA-256 only, the date (UTC), the machine, and in
/// "loop_health" the engine's pose faults and refused contacts and, after a
/// real-time session, the machine's own floor for missed deadlines, probed
/// right away for as long as the session, at most 10 s
/// (realtime::measure_cpu_stalls).
nlohmann::json describe_session(const SessionFacts& facts, const realtime::Engine& engine);

}  // namespace organsim::report
