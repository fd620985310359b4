#include "run_recorder.h"

#include <openssl/evp.h>

#include <algorithm>
#include <cmath>
#include <chrono>
#include <ctime>
#include <thread>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <stdexcept>

#include <fmt/format.h>

#include "organsim/geometry/model_measures.h"
#include "organsim/realtime/cpu_stalls.h"

namespace organsim::report {
namespace {

namespace fs = std::filesystem;

constexpr double kMillimetresPerMetre = 1e3;

/// m³ enclosed by the surface at `positions` (the organ's runtime order, as its triangles).
double enclosed_volume(const organ::Organ& organ, const std::vector<model::Point3>& positions) {
  double six_volume = 0.0;
  for (const model::Triangle& t : organ.model().surface_triangles) {
    const model::Point3& a = positions[t[0]];
    const model::Point3& b = positions[t[1]];
    const model::Point3& c = positions[t[2]];
    six_volume +=
        a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) + a[2] * (b[0] * c[1] - b[1] * c[0]);
  }
  return six_volume / 6.0;
}

std::string machine_description() {
  std::ifstream cpuinfo("/proc/cpuinfo");
  std::string line, model = "unknown CPU";
  while (std::getline(cpuinfo, line))
    if (line.rfind("model name", 0) == 0) {
      model = line.substr(line.find(':') + 2);
      break;
    }
  return fmt::format("{}, {} logical cores", model, std::thread::hardware_concurrency());
}

nlohmann::json machine_floor(double session_seconds) {
  const realtime::CpuStalls stalls = realtime::measure_cpu_stalls(std::clamp(session_seconds, 0.0, 10.0));
  return {{"probe_s", stalls.seconds},
          {"stalls_over_2ms", stalls.gaps_over_2ms},
          {"late_wakes_over_2ms", stalls.late_over_2ms},
          {"largest_stall_ms", stalls.largest_gap * 1e3},
          {"realtime_priority", stalls.realtime_priority}};
}

std::string utc_date_now() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm utc{};
  gmtime_r(&now, &utc);
  char date[32];
  std::strftime(date, sizeof date, "%Y-%m-%dT%H:%M:%SZ", &utc);
  return date;
}

}  // namespace

RunRecorder::RunRecorder(const std::string& directory, const organ::Organ& organ, std::size_t tools)
    : directory_(directory),
      organ_(organ),
      tools_(tools),
      peak_indentation_(organ.vertex_count(), 0.0),
      peak_strain_(organ.model().surface_triangles.size(), 0.0) {
  std::error_code error;
  fs::create_directories(directory_, error);
  if (error || !fs::is_directory(directory_))
    throw std::runtime_error(fmt::format("--report {}: cannot create the directory ({}); give a writable folder",
                                         directory_, error ? error.message() : "it is a file"));
  ticks_ = std::make_unique<io::AtomicStream>((fs::path(directory_) / "ticks.csv").string());
  ticks_->append(
      "t_s,tool,fx_n,fy_n,fz_n,model_force_n,in_contact,x_mm,y_mm,z_mm,depth_mm,pose_valid,jaws_closed,grasped,"
      "grasp_slipped\n");
  frames_ = std::make_unique<io::AtomicStream>((fs::path(directory_) / "frames.csv").string());
  frames_->append("t_s,volume_ml\n");
}

void RunRecorder::take_ticks(realtime::Engine& engine) {
  realtime::TickRecord r;
  for (std::size_t tool = 0; tool < tools_; ++tool)
    while (engine.take_tick_record(tool, r)) {
      const Eigen::Vector3d tip = r.tip * kMillimetresPerMetre;
      const int length =
          std::snprintf(line_, sizeof line_, "%.6f,%zu,%.9g,%.9g,%.9g,%.9g,%d,%.6f,%.6f,%.6f,%.5f,%d,%d,%d,%d\n",
                        r.time, tool + 1, r.sent_force[0], r.sent_force[1], r.sent_force[2], r.model_force.norm(),
                        r.in_contact ? 1 : 0, tip[0], tip[1], tip[2], r.depth * kMillimetresPerMetre,
                        r.pose_valid ? 1 : 0, r.jaws_closed ? 1 : 0, r.grasped ? 1 : 0, r.grasp_slipped ? 1 : 0);
      ticks_->append(line_, static_cast<std::size_t>(length));
      ++tick_count_;
    }
}

void RunRecorder::take_frame(const realtime::SurfaceFrame& frame) {
  const auto& rest = organ_.model().surface_vertices;
  const auto& normals = organ_.rest_normals();
  for (std::size_t v = 0; v < frame.positions.size() && v < rest.size(); ++v) {
    // Indentation: how far the vertex moved in along its rest inward normal.
    double inward = 0.0;
    for (int k = 0; k < 3; ++k) inward -= (frame.positions[v][k] - rest[v][k]) * normals[v][k];
    peak_indentation_[v] = std::max(peak_indentation_[v], inward);
  }
  // The surface's stretch: each triangle's edges against their rest lengths.
  const auto& triangles = organ_.model().surface_triangles;
  if (frame.positions.size() == rest.size())
    for (std::size_t f = 0; f < triangles.size(); ++f)
      for (int e = 0; e < 3; ++e) {
        const double stretch =
            geometry::edge_stretch(rest, frame.positions, triangles[f][e], triangles[f][(e + 1) % 3]);
        peak_strain_[f] = std::max(peak_strain_[f], std::abs(stretch - 1.0));
      }
  const int length =
      std::snprintf(line_, sizeof line_, "%.6f,%.6f\n", frame.time, enclosed_volume(organ_, frame.positions) * 1e6);
  frames_->append(line_, static_cast<std::size_t>(length));
  ++frame_count_;
}

void RunRecorder::finish(realtime::Engine& engine, nlohmann::json run) {
  take_ticks(engine);
  std::vector<std::size_t> dropped;
  for (std::size_t tool = 0; tool < tools_; ++tool) dropped.push_back(engine.dropped_tick_records(tool));
  ticks_->commit();
  frames_->commit();

  const std::vector<std::uint32_t>& file_index = organ_.file_vertex_index();
  const auto& rest = organ_.model().surface_vertices;
  std::vector<std::size_t> runtime_of(file_index.size());
  for (std::size_t v = 0; v < file_index.size(); ++v) runtime_of[file_index[v]] = v;
  std::string surface = "x_mm,y_mm,z_mm,peak_indentation_mm\n";
  for (std::size_t f = 0; f < runtime_of.size(); ++f) {
    const std::size_t v = runtime_of[f];
    surface += fmt::format("{:.4f},{:.4f},{:.4f},{:.5f}\n", rest[v][0] * 1e3, rest[v][1] * 1e3, rest[v][2] * 1e3,
                           peak_indentation_[v] * 1e3);
  }
  io::write_file_atomically((fs::path(directory_) / "surface.csv").string(), surface);
  std::string triangles = "a,b,c,peak_strain\n";
  const auto& faces = organ_.model().surface_triangles;
  for (std::size_t f = 0; f < faces.size(); ++f)
    triangles += fmt::format("{},{},{},{:.5f}\n", file_index[faces[f][0]], file_index[faces[f][1]],
                             file_index[faces[f][2]], peak_strain_[f]);
  io::write_file_atomically((fs::path(directory_) / "triangles.csv").string(), triangles);

  run["tools"] = tools_;
  run["rest_volume_ml"] = enclosed_volume(organ_, organ_.model().surface_vertices) * 1e6;
  run["tick_rows"] = tick_count_;
  run["frames_recorded"] = frame_count_;
  run["tick_records_dropped"] = dropped;
  io::write_file_atomically((fs::path(directory_) / "run.json").string(), run.dump(2) + "\n");
}

std::string file_sha256(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(fmt::format("{}: cannot read it to name it in the report", path));
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> context(EVP_MD_CTX_new(), &EVP_MD_CTX_free);
  if (!context || EVP_DigestInit_ex(context.get(), EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("SHA-256 is not available from OpenSSL");
  std::vector<char> chunk(1 << 16);
  while (in) {
    in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
    EVP_DigestUpdate(context.get(), chunk.data(), static_cast<std::size_t>(in.gcount()));
  }
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  EVP_DigestFinal_ex(context.get(), digest, &length);
  std::string hex;
  for (unsigned int i = 0; i < length; ++i) hex += fmt::format("{:02x}", digest[i]);
  return hex;
}

nlohmann::json describe_session(const SessionFacts& facts, const realtime::Engine& engine) {
  nlohmann::json health = facts.loop_health;
  std::uint64_t pose_faults = 0;
  for (std::size_t i = 0; i < engine.tool_count(); ++i) pose_faults += engine.telemetry(i).pose_faults;
  health["pose_faults"] = pose_faults;
  health["refused_contacts"] = engine.refused_contacts();
  health["machine_floor"] = facts.real_time ? machine_floor(facts.duration_s) : nlohmann::json();
  return {
      {"deformation_model", facts.deformation_model},
      {"model_sha256", file_sha256(facts.model_path)},
      {"session_sha256", facts.session_path.empty() ? "none: " + facts.live_tools : file_sha256(facts.session_path)},
      {"date", utc_date_now()},
      {"duration_s", facts.duration_s},
      {"mode", facts.mode},
      {"device_max_force_n", facts.device_max_force_n},
      {"machine", machine_description()},
      {"loop_health", health}};
}

}  // namespace organsim::report
