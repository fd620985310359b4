// `organsim compare MODEL --tool X,Y,Z/DX,DY,DZ [--tool …] [--models …]
// [--reference psh] [--json] [--out DIR]`: every deformation model under the
// same presses, each measured against a reference model (the paper 004 Table 5
// measure: nodal displacement differences normalized by the bounding box).
#include <algorithm>
#include <filesystem>
#include <iostream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line.h"
#include "organsim/mesh_io/mesh_io.h"
#include "organsim/model/model_file.h"
#include "static_press.h"

namespace organsim::cli {
namespace {

struct CompareOptions {
  std::string model_path;
  std::vector<std::string> tools;
  std::vector<std::string> models = deformation_model_names();
  std::string reference = "psh";
  bool json = false;
  std::string out_dir;
  PressOptions press;
};

/// A model against the reference, on the surface vertices: |Δu| over the
/// bounding box's diagonal (mean, max) and |Δu_axis| over its extent along
/// that axis (mean), as fractions (0.01 = 1 %).
struct Versus {
  double mean = 0.0, max = 0.0;
  Eigen::Vector3d per_axis = Eigen::Vector3d::Zero();
};

Eigen::Vector3d point(const model::Point3& p) { return {p[0], p[1], p[2]}; }

Versus versus(const std::vector<model::Point3>& positions, const std::vector<model::Point3>& reference,
              const Eigen::Vector3d& extent) {
  Versus v;
  const double diagonal = extent.norm();
  for (std::size_t i = 0; i < positions.size(); ++i) {
    // The rest positions are shared, so the displacements' difference is the positions'.
    const Eigen::Vector3d delta = point(positions[i]) - point(reference[i]);
    v.mean += delta.norm() / diagonal;
    v.max = std::max(v.max, delta.norm() / diagonal);
    v.per_axis += delta.cwiseAbs().cwiseQuotient(extent);
  }
  const double n = static_cast<double>(std::max<std::size_t>(positions.size(), 1));
  v.mean /= n;
  v.per_axis /= n;
  return v;
}

Eigen::Vector3d bounding_box_extent(const std::vector<model::Point3>& points) {
  Eigen::Vector3d low = Eigen::Vector3d::Constant(1e300), high = -low;
  for (const model::Point3& p : points) {
    low = low.cwiseMin(point(p));
    high = high.cwiseMax(point(p));
  }
  return high - low;
}

/// The model's deformed surface in the file's vertex numbering (LPS, mm) with
/// its displacement and its difference from the reference (mm) per vertex.
void write_model_vtu(const multibeam::BeamOrgan& organ, const std::vector<model::Triangle>& file_triangles,
                     const PressResult& r, const PressResult& reference, const std::string& path) {
  mesh_io::FieldMesh mesh;
  mesh.units = "mm";
  mesh.space = "LPS";
  const std::size_t n = r.positions.size();
  mesh.points.resize(n);
  mesh_io::DataArray displacement{"displacement", 3, std::vector<double>(3 * n)};
  mesh_io::DataArray difference{"difference", 3, std::vector<double>(3 * n)};
  for (std::size_t v = 0; v < n; ++v) {
    const std::size_t f = organ.file_vertex_index()[v];
    const Eigen::Vector3d at = point(r.positions[v]);
    const Eigen::Vector3d moved = at - point(organ.model().surface_vertices[v]);
    const Eigen::Vector3d apart = at - point(reference.positions[v]);
    for (int k = 0; k < 3; ++k) {
      mesh.points[f][k] = at[k] * 1e3;
      displacement.values[3 * f + k] = moved[k] * 1e3;
      difference.values[3 * f + k] = apart[k] * 1e3;
    }
  }
  for (const model::Triangle& t : file_triangles) mesh.triangles.push_back({t[0], t[1], t[2]});
  mesh.point_data = {displacement, difference};
  mesh_io::write_field_vtu(mesh, path);
}

int run_compare(CompareOptions o) {
  std::vector<ToolSpec> tools;
  for (const std::string& t : o.tools) tools.push_back(parse_tool(t));
  if (tools.size() > multibeam::kMaxTools) throw std::runtime_error(fmt::format("at most {} tools", multibeam::kMaxTools));
  // The reference is pressed (and listed) even when --models leaves it out.
  std::vector<std::string> models;
  for (const std::string& m : o.models)
    if (std::find(models.begin(), models.end(), m) == models.end()) models.push_back(m);
  if (std::find(models.begin(), models.end(), o.reference) == models.end()) models.insert(models.begin(), o.reference);
  if (!o.out_dir.empty()) std::filesystem::create_directories(o.out_dir);

  model::OrganModel loaded = load_simulation_model("compare", o.model_path);
  const std::vector<model::Triangle> file_triangles = loaded.surface_triangles;
  const multibeam::BeamOrgan organ(std::move(loaded));
  o.press.command = "compare";
  for (std::size_t i = 0; i < tools.size(); ++i) snap_to_surface(organ, tools[i], i, o.press);  // before any press
  std::vector<PressResult> results;
  for (const std::string& m : models) {
    note("compare", "pressing with " + m);
    results.push_back(press(m, organ, tools, o.press));
  }
  const auto found = std::find(models.begin(), models.end(), o.reference);
  const PressResult& reference = results[static_cast<std::size_t>(found - models.begin())];
  const Eigen::Vector3d extent = bounding_box_extent(organ.model().surface_vertices);

  nlohmann::json j;
  j["reference"] = o.reference;
  j["model"] = o.model_path;
  j["compared_on"] = "surface vertices";
  j["models"] = nlohmann::json::object();
  std::cout.setf(std::ios::fixed);
  if (!o.json) {
    std::cout << fmt::format("{:<14}{} ({} surface vertices; bounding box {:.1f} x {:.1f} x {:.1f} mm)\n", "organ",
                             o.model_path, organ.vertex_count(), extent[0] * 1e3, extent[1] * 1e3, extent[2] * 1e3);
    for (std::size_t i = 0; i < tools.size(); ++i)
      std::cout << fmt::format("{:<14}{}\n", fmt::format("tool {}", i + 1), tools[i].text);
    std::cout << fmt::format("\nagainst {}: surface vertices' displacement differences as % of the bounding box\n\n",
                             o.reference);
    std::string head = fmt::format("| {:<12} | {:>7} | {:>7} | {:>27} |", "model", "mean", "max", "mean x / y / z");
    for (std::size_t i = 0; i < tools.size(); ++i) head += fmt::format(" {:>14} |", fmt::format("tool {} |F| (N)", i + 1));
    head += fmt::format(" {:>9} | {:>10} | {:>15} |", "volume", "frame (ms)", "force tick (us)");
    std::cout << head << '\n';
  }
  for (std::size_t m = 0; m < models.size(); ++m) {
    const PressResult& r = results[m];
    const Versus d = versus(r.positions, reference.positions, extent);
    const Deformation shape = measure(organ, r.positions);
    const double volume_change = 100.0 * (shape.deformed_volume - shape.rest_volume) / shape.rest_volume;
    nlohmann::json forces = nlohmann::json::array();
    for (const ToolResult& t : r.tools) forces.push_back({t.force[0], t.force[1], t.force[2]});
    j["models"][models[m]] = {{"mean_difference", d.mean},
                              {"max_difference", d.max},
                              {"mean_difference_per_axis", {d.per_axis[0], d.per_axis[1], d.per_axis[2]}},
                              {"forces_n", forces},
                              {"volume_change_percent", volume_change},
                              {"frame_time_ms", r.frame_seconds * 1e3},
                              {"force_tick_us", r.force_seconds * 1e6},
                              {"max_displacement_mm", shape.max_displacement * 1e3},
                              {"static_iteration_ms", r.deform_seconds * 1e3},
                              {"setup", r.summary}};
    if (!o.out_dir.empty()) {
      const std::string path = (std::filesystem::path(o.out_dir) / (models[m] + ".vtu")).string();
      write_model_vtu(organ, file_triangles, r, reference, path);
      j["models"][models[m]]["file"] = path;
    }
    if (o.json) continue;
    std::string row = fmt::format("| {:<12} | {:>6.2f}% | {:>6.2f}% | {:>6.2f}% / {:>6.2f}% / {:>6.2f}% |", models[m],
                                  100 * d.mean, 100 * d.max, 100 * d.per_axis[0], 100 * d.per_axis[1],
                                  100 * d.per_axis[2]);
    for (const ToolResult& t : r.tools) row += fmt::format(" {:>14.4f} |", t.force.norm());
    row += fmt::format(" {:>+8.3f}% | {:>10.3f} | {:>15.3f} |", volume_change, r.frame_seconds * 1e3,
                       r.force_seconds * 1e6);
    std::cout << row << '\n';
  }
  if (o.json) {
    std::cout << j.dump() << '\n';
    return 0;
  }
  std::cout << "\nframe: what the real-time engine computes per 60 Hz frame at the pressed state: the multi-beam\n"
               "deformation, the mass-spring model's 1/60 s of steps, one FEM iteration with the kept factor; force\n"
               "tick: the force law the 1 kHz loop evaluates per tool. Setups:\n";
  for (std::size_t m = 0; m < models.size(); ++m) std::cout << fmt::format("{:<14}{}\n", models[m], results[m].summary);
  if (!o.out_dir.empty())
    std::cout << fmt::format("{:<14}{}/<model>.vtu (deformed surface, displacement and difference, LPS mm)\n", "written",
                             o.out_dir);
  return 0;
}

}  // namespace

Command add_compare_command(CLI::App& app) {
  auto o = std::make_shared<CompareOptions>();
  app.add_option("model", o->model_path, "Model file (.organ)")->required();
  add_press_options(app, o->tools, o->press);
  app.add_option("--models", o->models, "The models to press, comma-separated")
      ->delimiter(',')
      ->check(CLI::IsMember(deformation_model_names()))
      ->capture_default_str();
  app.add_option("--reference", o->reference, "The model the others are measured against")
      ->check(CLI::IsMember(deformation_model_names()))
      ->capture_default_str();
  app.add_option("--out", o->out_dir, "Write each model's deformed surface as DIR/<model>.vtu (ParaView)");
  app.add_flag("--json", o->json, "Print the comparison as one JSON object on stdout");
  return [o] { return run_compare(*o); };
}

}  // namespace organsim::cli
