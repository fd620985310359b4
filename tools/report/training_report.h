// The training report: what a trainee did to the organ, from the raw data a
// RunRecorder left in a directory, as metrics.json and one self-contained web
// page, index.html (docs/report.md).
#pragma once

#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

namespace organsim::report {

/// The force limit's default, N: above the 1.75 N mean grip force surgeons
/// used in porcine laparoscopic hepatectomy, where histological damage grew
/// with the force (Minim Invasive Ther Allied Technol 2022;31:28–33), and
/// below the device's 3.3 N clamp, so that going past it is seen.
constexpr double kDefaultForceLimit = 2.0;

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
  std::vector<LimitEvent> events;
  std::vector<GraspEvent> grasps;
  Curve force, model_force, depth, speed;  ///< N (largest per bucket), N, mm, mm/s (mean)
};

struct RunMetrics {
  nlohmann::json run;  ///< run.json as the recorder wrote it
  double duration_s = 0.0, force_limit_n = kDefaultForceLimit, bucket_s = 0.0;
  std::vector<ToolMetrics> tools;
  Curve volume_change_percent;  ///< of the enclosed volume at rest
  double largest_volume_change_percent = 0.0;
};

/// Reads the directory's raw data; throws std::runtime_error naming the file
/// and what is wrong with it.
RunMetrics compute_metrics(const std::string& directory, double force_limit_n);

/// metrics.json's document: {"duration_s", "force_limit_n", "tools": [{"tool",
/// "peak_force_n", "time_in_contact_s", "time_above_limit_s",
/// "events_above_limit", "path_length_mm", ...}], ...}.
nlohmann::json metrics_json(const RunMetrics& metrics);

struct ReportOptions {
  double force_limit_n = kDefaultForceLimit;
  std::string reference_run;  ///< another run's report directory to compare with ("" none)
};

/// Writes `directory`/metrics.json and `directory`/index.html (atomically)
/// from its raw data. The organ's pictures are rendered off screen with VTK
/// (an X display is needed: xvfb-run -a); without one the page says so.
/// Returns a line per picture that could not be drawn.
std::vector<std::string> write_report(const std::string& directory, const ReportOptions& options);

}  // namespace organsim::report
