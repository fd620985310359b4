// `organsim poke MODEL --tool X,Y,Z/DX,DY,DZ [--tool …]`: a static multi-beam
// query: the force each tool feels for a prescribed press, and how the organ
// deforms.
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line.h"
#include "organsim/geometry/model_measures.h"
#include "organsim/mesh_io/mesh_io.h"
#include "organsim/model/model_file.h"
#include "organsim/multibeam/multibeam.h"

namespace organsim::cli {
namespace {

struct ToolSpec {
  std::string text;
  Eigen::Vector3d point_mm;
  Eigen::Vector3d displacement_mm;
};

struct PokeOptions {
  std::string model_path;
  std::vector<std::string> tools;
  std::string merge = "influence";
  std::string theory = "euler-bernoulli";
  double snap_distance_mm = 10.0;
  bool json = false;
  std::string out_path;
};

Eigen::Vector3d parse_triple(const std::string& text, const std::string& whole) {
  Eigen::Vector3d v;
  std::size_t start = 0;
  for (int k = 0; k < 3; ++k) {
    const std::size_t end = k < 2 ? text.find(',', start) : text.size();
    if (end == std::string::npos)
      throw std::runtime_error("--tool " + whole + ": expected X,Y,Z/DX,DY,DZ in millimetres");
    const std::string field = text.substr(start, end - start);
    char* stop = nullptr;
    v[k] = std::strtod(field.c_str(), &stop);
    if (field.empty() || stop != field.c_str() + field.size())
      throw std::runtime_error("--tool " + whole + ": '" + field + "' is not a number; expected X,Y,Z/DX,DY,DZ in mm");
    start = end + 1;
  }
  return v;
}

ToolSpec parse_tool(const std::string& text) {
  const std::size_t slash = text.find('/');
  if (slash == std::string::npos)
    throw std::runtime_error("--tool " + text + ": expected X,Y,Z/DX,DY,DZ (point / displacement, mm)");
  return {text, parse_triple(text.substr(0, slash), text), parse_triple(text.substr(slash + 1), text)};
}

nlohmann::json triple(const Eigen::Vector3d& v) { return {v[0], v[1], v[2]}; }

double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

int run_poke(const PokeOptions& o) {
  using namespace organsim::multibeam;
  std::vector<ToolSpec> tools;
  for (const std::string& t : o.tools) tools.push_back(parse_tool(t));
  if (tools.size() > kMaxTools) throw std::runtime_error(fmt::format("at most {} tools", kMaxTools));
  if (!o.out_path.empty() && (o.out_path.size() < 4 || o.out_path.substr(o.out_path.size() - 4) != ".vtp"))
    throw std::runtime_error("--out " + o.out_path + ": the deformed surface is written as VTK PolyData; name it .vtp");

  model::OrganModel loaded = load_simulation_model("poke", o.model_path);
  const std::vector<model::Triangle> file_triangles = loaded.surface_triangles;
  const BeamOrgan organ(std::move(loaded));
  const model::OrganModel& model = organ.model();

  MultiBeamOptions options;
  options.max_tools = static_cast<std::uint32_t>(tools.size());
  options.merge = o.merge == "sum" ? MergeRule::sum : MergeRule::influence;
  options.beam.theory = o.theory == "timoshenko" ? BeamTheory::timoshenko : BeamTheory::euler_bernoulli;
  options.snap_distance = o.snap_distance_mm * 1e-3;
  MultiBeam beams(organ, options);

  std::vector<Eigen::Vector3d> displacements(tools.size());
  const auto attach_start = std::chrono::steady_clock::now();
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    displacements[i] = tools[i].displacement_mm * 1e-3;
    const Status status = beams.attach(i, tools[i].point_mm * 1e-3);
    if (status != Status::ok) throw std::runtime_error(fmt::format("tool {} ({}): {}", i + 1, tools[i].text, describe(status)));
    if (!displacements[i].allFinite())
      throw std::runtime_error(fmt::format("tool {} ({}): {}", i + 1, tools[i].text, describe(Status::not_finite)));
  }
  const double attach_seconds = seconds_since(attach_start) / tools.size();

  std::vector<Eigen::Vector3d> forces(tools.size());
  constexpr int kForceRepeats = 1000;  // one call is too short to time alone
  const auto force_start = std::chrono::steady_clock::now();
  for (int r = 0; r < kForceRepeats; ++r)
    for (std::uint32_t i = 0; i < tools.size(); ++i) beams.force(i, displacements[i], forces[i]);
  const double force_seconds = seconds_since(force_start) / (kForceRepeats * tools.size());

  std::vector<model::Point3> positions(organ.vertex_count()), normals(organ.vertex_count());
  const auto deform_start = std::chrono::steady_clock::now();
  const Status deformed = beams.deform(displacements.data(), positions.data(), normals.data(), positions.size());
  const double deform_seconds = seconds_since(deform_start);
  if (deformed != Status::ok) throw std::runtime_error(describe(deformed));

  double max_displacement = 0.0;
  std::size_t max_vertex = 0;  // in the runtime's numbering; reported in the file's
  for (std::size_t v = 0; v < positions.size(); ++v) {
    const model::Point3& r = model.surface_vertices[v];
    const double d = std::hypot(positions[v][0] - r[0], positions[v][1] - r[1], positions[v][2] - r[2]);
    if (d > max_displacement) {
      max_displacement = d;
      max_vertex = v;
    }
  }
  const double rest_volume = geometry::enclosed_volume(model.surface_vertices, model.surface_triangles);
  const double deformed_volume = geometry::enclosed_volume(positions, model.surface_triangles);
  const double volume_change = (deformed_volume - rest_volume) / rest_volume;

  if (!o.out_path.empty()) {
    // Back to the file's vertex numbering, so the output matches the model file.
    std::vector<model::Point3> in_file_order(positions.size());
    for (std::size_t v = 0; v < positions.size(); ++v) in_file_order[organ.file_vertex_index()[v]] = positions[v];
    mesh_io::write_surface_vtp({in_file_order, file_triangles}, o.out_path);
  }

  if (o.json) {
    nlohmann::json j;
    j["model"] = o.model_path;
    j["merge"] = o.merge;
    j["theory"] = o.theory;
    nlohmann::json list = nlohmann::json::array();
    for (std::uint32_t i = 0; i < tools.size(); ++i) {
      const ToolBeam& b = beams.beam(i);
      list.push_back({{"point_mm", triple(tools[i].point_mm)},
                      {"action_point_mm", triple(b.action.position * 1e3)},
                      {"snap_distance_mm", b.action.distance * 1e3},
                      {"beam_length_mm", b.length * 1e3},
                      {"normal", triple(geometry::triangle_normal(model, b.action.triangle))},
                      {"displacement_mm", triple(tools[i].displacement_mm)},
                      {"force_n", triple(forces[i])},
                      {"force_magnitude_n", forces[i].norm()}});
    }
    j["tools"] = list;
    j["organ"] = {{"vertices", positions.size()},
                  {"max_displacement_mm", max_displacement * 1e3},
                  {"max_displacement_vertex", organ.file_vertex_index()[max_vertex]},
                  {"rest_volume_ml", rest_volume * 1e6},
                  {"deformed_volume_ml", deformed_volume * 1e6},
                  {"volume_change_percent", volume_change * 100.0}};
    j["seconds"] = {{"beam_per_tool", attach_seconds}, {"force_per_tool", force_seconds}, {"deformation", deform_seconds}};
    if (!o.out_path.empty()) j["deformed_surface"] = o.out_path;
    std::cout << j.dump() << '\n';
    return 0;
  }
  auto mm = [](const Eigen::Vector3d& v) { return fmt::format("({:.2f}, {:.2f}, {:.2f}) mm", v[0], v[1], v[2]); };
  std::cout << fmt::format("{:<14}{} ({} vertices, {} stations per beam; E {:g} Pa, nu {:g}; {}, {} merge)\n", "model",
                           o.model_path, positions.size(), organ.stations(), model.material.young_modulus,
                           model.material.poisson_ratio, o.theory, o.merge);
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    const ToolBeam& b = beams.beam(i);
    std::cout << fmt::format("{:<14}at {} -> action point {} (snapped {:.2f} mm), beam {:.1f} mm\n",
                             fmt::format("tool {}", i + 1), mm(tools[i].point_mm), mm(b.action.position * 1e3),
                             b.action.distance * 1e3, b.length * 1e3);
    std::cout << fmt::format("{:<14}press {} -> force on the tool ({:.4f}, {:.4f}, {:.4f}) N, |F| {:.4f} N\n", "",
                             mm(tools[i].displacement_mm), forces[i][0], forces[i][1], forces[i][2], forces[i].norm());
  }
  std::cout << fmt::format("{:<14}max vertex displacement {:.2f} mm (vertex {}); volume {:.1f} -> {:.1f} mL ({:+.2f} %)\n",
                           "organ", max_displacement * 1e3, organ.file_vertex_index()[max_vertex], rest_volume * 1e6,
                           deformed_volume * 1e6,
                           volume_change * 100.0);
  std::cout << fmt::format("{:<14}beam {:.1f} us per tool, force {:.3f} us per tool, deformation {:.3f} ms "
                           "(first frame of a contact, normals included)\n",
                           "time", attach_seconds * 1e6, force_seconds * 1e6, deform_seconds * 1e3);
  if (!o.out_path.empty()) std::cout << fmt::format("{:<14}{} (LPS, mm)\n", "deformed", o.out_path);
  return 0;
}

}  // namespace

Command add_poke_command(CLI::App& app) {
  auto o = std::make_shared<PokeOptions>();
  app.add_option("model", o->model_path, "Model file (.organ)")->required();
  app.add_option("--tool", o->tools,
                 "A tool: X,Y,Z/DX,DY,DZ, a point on or near the surface and its prescribed displacement "
                 "(model frame, mm); repeat for more tools")
      ->required()
      ->allow_extra_args(false);
  app.add_option("--merge", o->merge, "How beams combine: influence (eq. 7) or sum (eq. 5)")
      ->check(CLI::IsMember({"influence", "sum"}))
      ->capture_default_str();
  app.add_option("--theory", o->theory, "Beam theory: euler-bernoulli or timoshenko")
      ->check(CLI::IsMember({"euler-bernoulli", "timoshenko"}))
      ->capture_default_str();
  app.add_option("--snap-distance", o->snap_distance_mm, "Farthest a tool point may be from the surface, mm")
      ->check(kNonNegative)
      ->capture_default_str();
  app.add_option("--out", o->out_path, "Write the deformed surface (.vtp, LPS, mm)");
  app.add_flag("--json", o->json, "Print the result as one JSON object on stdout");
  return [o] { return run_poke(*o); };
}

}  // namespace organsim::cli
