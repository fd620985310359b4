// The training report: what a trainee did to the organ, from the raw data a
// RunRecorder left in a directory, as metrics.json and one self-contained web
// page, index.html (docs/report.md).
#pragma once

#include <map>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace organsim::report {

/// The force limit's default, N: above the 1.75 N mean grip force surgeons
/// used in porcine laparoscopic hepatectomy, where histological damage grew
/// with the force (Minim Invasive Ther Allied Technol 2022;31:28–33), and
/// below the device's 3.3 N clamp, so that going past it is seen.
constexpr double kDefaultForceLimit = 2.0;

/// s between the tip samples the motion measures are taken from (jerk, idle
/// time): coarser than the force ticks, whose millisecond differences would
/// turn a pose's rounding into jerk.
constexpr double kMotionSample = 0.01;
/// mm/s: a tip slower than this is idle.
constexpr double kIdleSpeed = 5.0;

/// The surface strain above which the organ's surface counts as damaged: an
/// edge of the surface stretched or compressed by more than this fraction of
/// its rest length (an engineering choice, not a measured tissue limit: well
/// past the few percent of an ordinary press, where a capsule would begin to
/// tear; docs/report.md#skill-measures).
constexpr double kDefaultStrainLimit = 0.3;

/// One maximal run of force ticks whose model force (before the device's
/// clamp) was above the limit.
struct LimitEvent {
  double start_s = 0.0, duration_s = 0.0;
  double peak_force_n = 0.0;                           ///< the model's, before the clamp
  Eigen::Vector3d where_mm = Eigen::Vector3d::Zero();  ///< the tip at the peak, LPS
};

/// One grasp: the ticks from the jaws taking hold of the organ to their
/// letting go, or to the tissue slipping out of them (docs/realtime.md#grasping).
struct GraspEvent {
  double start_s = 0.0, duration_s = 0.0;
  double peak_force_n = 0.0;                           ///< the model's largest force while held, N
  Eigen::Vector3d where_mm = Eigen::Vector3d::Zero();  ///< the tip where the jaws closed, LPS
  bool slipped = false;                                ///< pulled beyond the holding limit
};

/// A curve over the session in equal time buckets (memory stays flat).
struct Curve {
  std::vector<double> values;  ///< per bucket; NaN where nothing fell in it
};

struct ToolMetrics {
  int tool = 0;                          ///< 1-based
  double peak_force_n = 0.0;             ///< largest force sent to the device
  double mean_force_in_contact_n = 0.0;  ///< of the forces sent while in contact
  double peak_model_force_n = 0.0;       ///< largest force the model computed
  double time_in_contact_s = 0.0, time_above_limit_s = 0.0;
  double path_length_mm = 0.0, peak_depth_mm = 0.0, mean_speed_mm_s = 0.0;
  std::uint64_t ticks = 0, invalid_pose_ticks = 0;
  /// Skill measures (docs/report.md#skill-measures), from the tip sampled
  /// every kMotionSample s: the shortest path through the same places in the
  /// same order (the start, each contact's onset, the end) over the path
  /// travelled (1: straight from place to place); the mean squared jerk of the
  /// tip, mm²/s⁶ (0 when fewer than four samples in a row); the time the tip
  /// moved slower than kIdleSpeed, s.
  double economy_of_motion = 1.0;
  double mean_squared_jerk = 0.0;
  double idle_time_s = 0.0;
  std::vector<LimitEvent> events;
  std::vector<GraspEvent> grasps;
  std::vector<std::pair<double, double>> contacts;  ///< s: each contact's start and end
  Curve force, model_force, depth, speed;           ///< N (largest per bucket), N, mm, mm/s (mean)
};

struct RunMetrics {
  nlohmann::json run;  ///< run.json as the recorder wrote it
  double duration_s = 0.0, force_limit_n = kDefaultForceLimit, bucket_s = 0.0;
  std::vector<ToolMetrics> tools;
  Curve volume_change_percent;  ///< of the enclosed volume at rest
  double largest_volume_change_percent = 0.0;
  double strain_limit = kDefaultStrainLimit;
  double largest_strain = 0.0;    ///< the surface's largest edge strain, |length / rest − 1|
  double damaged_area_mm2 = 0.0;  ///< rest area of the triangles strained beyond strain_limit
};

/// Reads the directory's raw data; throws std::runtime_error naming the file
/// and what is wrong with it.
RunMetrics compute_metrics(const std::string& directory, double force_limit_n,
                           double strain_limit = kDefaultStrainLimit);

/// metrics.json's document: {"duration_s", "force_limit_n", "tools": [{"tool",
/// "peak_force_n", "time_in_contact_s", "time_above_limit_s",
/// "events_above_limit", "path_length_mm", ...}], ...}.
nlohmann::json metrics_json(const RunMetrics& metrics);

/// One skill measure of a run, as the expert bands and the learning curve
/// name it (docs/report.md#skill-measures).
struct Measure {
  std::string key;    ///< the expert bands' key: "path_length_mm", …
  std::string label;  ///< "path length of the tip"
  std::string unit;   ///< "mm", or "" for a ratio or a count
  int tool = 0;       ///< 1-based; 0: the run as a whole
  double value = 0.0;
};

/// The run's measures (task time, the surface strained beyond the limit, the
/// largest strain), then each tool's (time in contact, path length, economy of
/// motion, mean squared jerk, idle time, peak model force, time above the
/// force limit, grasp slips).
std::vector<Measure> skill_measures(const RunMetrics& metrics);

/// The range of a measure that experts' runs fall in.
struct Band {
  double low = 0.0, high = 0.0;
};

/// Reads expert bands, a JSON object {"KEY": [LOW, HIGH], …} keyed as
/// skill_measures() names them (a per-tool measure's band holds for each
/// tool); throws std::runtime_error naming the file and what is wrong with it
/// (not JSON, an unknown key, not two numbers, LOW > HIGH).
std::map<std::string, Band> read_expert_bands(const std::string& path);

struct ReportOptions {
  double force_limit_n = kDefaultForceLimit;
  double strain_limit = kDefaultStrainLimit;
  std::string expert_bands;   ///< a JSON file of expert bands ("" none): each measure judged against its band
  std::string reference_run;  ///< another run's report directory to compare with ("" none)
};

/// Writes `directory`/metrics.json and `directory`/index.html (atomically)
/// from its raw data: a plain summary first, then each tool's charts and
/// tables, the organ's pictures (drawn without a display, surface_picture.h)
/// and, last, the engineering detail (hashes, loop health). Returns a line per
/// picture that could not be drawn.
std::vector<std::string> write_report(const std::string& directory, const ReportOptions& options);

/// The learning curve: one page, `output` (written atomically), with each skill
/// measure over the attempts (the report directories in the order given, each
/// rebuilt from its raw data with `options`' limits), the expert band shaded
/// where `options` gives bands, and a table of every attempt's measures.
/// Throws std::runtime_error naming a directory that holds no recorded run.
void write_history(const std::vector<std::string>& directories, const ReportOptions& options,
                   const std::string& output);

}  // namespace organsim::report
