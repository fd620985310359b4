// `organsim poke MODEL --tool X,Y,Z/DX,DY,DZ [--tool …] [--model M] [--compare M]`:
// a static press: the force each tool feels for a prescribed displacement, and
// how the organ deforms, with any deformation model (and the difference from a
// second one).
#include <algorithm>
#include <cmath>
#include <iostream>
#include <optional>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line/command_line.h"
#include "organsim/mesh_io/mesh_io.h"
#include "organsim/model/model_file.h"
#include "plot/field_view.h"
#include "static_press/static_press.h"

namespace organsim::cli {
namespace {

struct PokeOptions {
  std::string model_path;
  std::vector<std::string> tools;
  bool json = false;
  std::string out_path;
  std::string png_path;  ///< a picture of the deformed tetrahedra, or empty
  std::string deformation = realtime::default_model().name;
  std::string compare;  ///< a second model to press the same way, or empty
  PressOptions press;
};

nlohmann::json triple(const Eigen::Vector3d& v) { return {v[0], v[1], v[2]}; }

/// The deformed tetrahedra coloured by the displacement's magnitude (mm),
/// seen from the front (along +y, LPS: from anterior), head up.
void draw_tetrahedra(const organ::Organ& organ, const PressResult& r, const std::vector<ToolSpec>& tools,
                     const PokeOptions& o, const std::string& path) {
  if (r.node_positions.empty())
    throw std::runtime_error("--png: the " + o.deformation +
                             " model moves only the surface here (the mass-spring model needs --volume-springs)");
  plot::FieldPanel panel;
  panel.title = o.deformation + choice_text(*realtime::find_model(o.deformation), o.press.tuning.models, ", ");
  const std::vector<model::Point3>& rest = organ.model().volume_vertices;
  double deepest = 0.0;
  for (const ToolSpec& t : tools) deepest = std::max(deepest, t.displacement_mm.norm());
  for (std::size_t n = 0; n < rest.size(); ++n) {
    const model::Point3& at = r.node_positions[n];
    panel.points.push_back({at[0] * 1e3, at[1] * 1e3, at[2] * 1e3});
    panel.point_values.push_back(1e3 * std::hypot(at[0] - rest[n][0], at[1] - rest[n][1], at[2] - rest[n][2]));
  }
  for (const model::Tetrahedron& t : organ.model().tetrahedra)
    panel.tetrahedra.push_back({static_cast<std::int32_t>(t[0]), static_cast<std::int32_t>(t[1]),
                                static_cast<std::int32_t>(t[2]), static_cast<std::int32_t>(t[3])});
  plot::FieldView view;
  view.scalar_title = "|u| (mm)";
  view.high = deepest > 0.0 ? deepest : 1.0;
  view.panel_width = 640;
  view.height = 560;
  plot::write_field_view_png({panel}, view, path);
}

int run_poke(const PokeOptions& o) {
  std::vector<ToolSpec> tools;
  for (const std::string& t : o.tools) tools.push_back(parse_tool(t));
  if (tools.size() > multibeam::kMaxTools)
    throw std::runtime_error(fmt::format("at most {} tools", multibeam::kMaxTools));
  if (!o.out_path.empty() && (o.out_path.size() < 4 || o.out_path.substr(o.out_path.size() - 4) != ".vtp"))
    throw std::runtime_error("--out " + o.out_path + ": the deformed surface is written as VTK PolyData; name it .vtp");
  if (!o.compare.empty() && o.compare == o.deformation)
    throw CLI::ValidationError("--compare", "compare with another model than --model " + o.deformation);

  std::vector<std::string> models{o.deformation};
  if (!o.compare.empty()) models.push_back(o.compare);
  model::OrganModel loaded = load_simulation_model("poke", o.model_path, models);
  warn_if_depth_curve_rescaled("poke", loaded, models, o.press.tuning);
  const std::vector<model::Triangle> file_triangles = loaded.surface_triangles;
  const organ::Organ organ(std::move(loaded));
  const realtime::RegisteredModel& entry = *realtime::find_model(o.deformation);
  const bool beam = entry.static_press == realtime::StaticPress::beam_tables;
  const bool fem = entry.static_press == realtime::StaticPress::equilibrium;  // they hold points of the boundary
  const PressResult r = press(o.deformation, organ, tools, o.press);
  const std::vector<model::Point3>& positions = r.positions;
  const Deformation shape = measure(organ, r);
  const double volume_change = (shape.deformed_volume - shape.rest_volume) / shape.rest_volume;
  std::optional<PressResult> other;
  Difference versus;
  if (!o.compare.empty()) {
    other = press(o.compare, organ, tools, o.press);
    versus = difference(r, *other);
  }

  if (!o.out_path.empty()) {
    // Back to the file's vertex numbering, so the output matches the model file.
    std::vector<model::Point3> in_file_order(positions.size());
    for (std::size_t v = 0; v < positions.size(); ++v) in_file_order[organ.file_vertex_index()[v]] = positions[v];
    mesh_io::write_surface_vtp({in_file_order, file_triangles}, o.out_path);
  }

  if (!o.png_path.empty()) draw_tetrahedra(organ, r, tools, o, o.png_path);

  if (o.json) {
    nlohmann::json j;
    j["model"] = o.model_path;
    j["deformation_model"] = o.deformation;
    j["setup"] = r.summary;
    j.update(parameter_values(entry, o.press.tuning.models));
    nlohmann::json list = nlohmann::json::array();
    for (std::uint32_t i = 0; i < tools.size(); ++i) {
      const ToolResult& t = r.tools[i];
      list.push_back({{"point_mm", triple(tools[i].point_mm)},
                      {"action_point_mm", triple(t.action_point * 1e3)},
                      {"snap_distance_mm", t.snap_distance * 1e3},
                      {"beam_length_mm", beam ? nlohmann::json(t.beam_length * 1e3) : nlohmann::json(nullptr)},
                      {"normal", triple(t.normal)},
                      {"displacement_mm", triple(tools[i].displacement_mm)},
                      {"force_n", triple(t.force)},
                      {"action_point_moved_mm", triple(t.action_moved * 1e3)},
                      {"force_magnitude_n", t.force.norm()},
                      {"slip_mm", triple(t.slip * 1e3)},
                      {"held_points", fem ? nlohmann::json(t.held_points) : nlohmann::json(nullptr)}});
    }
    j["tools"] = list;
    j["contact_points_left_out"] = fem ? nlohmann::json(r.contact_points_left_out) : nlohmann::json(nullptr);
    j["organ"] = {{"vertices", positions.size()},
                  {"max_displacement_mm", shape.max_displacement * 1e3},
                  {"max_displacement_vertex", organ.file_vertex_index()[shape.max_vertex]},
                  {"rest_volume_ml", shape.rest_volume * 1e6},
                  {"deformed_volume_ml", shape.deformed_volume * 1e6},
                  {"volume_change_percent", volume_change * 100.0},
                  {"volume_of", shape.volume_of_tetrahedra ? "tetrahedra" : "surface"}};
    j["seconds"] = {{"beam_per_tool", beam ? nlohmann::json(r.attach_seconds) : nlohmann::json(nullptr)},
                    {"attach_per_tool", r.attach_seconds},
                    {"force_per_tool", r.force_seconds},
                    {"deformation", r.deform_seconds},
                    {"setup", r.setup_seconds},
                    {"frames", r.frames}};
    if (other) {
      nlohmann::json forces = nlohmann::json::array();
      for (std::size_t i = 0; i < tools.size(); ++i)
        forces.push_back({{"force_n", triple(other->tools[i].force)}, {"force_difference_n", versus.force[i]}});
      j["compare"] = {{"deformation_model", o.compare},
                      {"setup", other->summary},
                      {"tools", forces},
                      {"surface_difference_rms_mm", versus.rms * 1e3},
                      {"surface_difference_max_mm", versus.max * 1e3},
                      {"max_displacement_mm", measure(organ, *other).max_displacement * 1e3}};
    }
    if (!o.out_path.empty()) j["deformed_surface"] = o.out_path;
    std::cout << j.dump() << '\n';
    return 0;
  }
  auto mm = [](const Eigen::Vector3d& v) { return fmt::format("({:.2f}, {:.2f}, {:.2f}) mm", v[0], v[1], v[2]); };
  std::cout << fmt::format("{:<14}{} ({} vertices; {}: {})\n", "model", o.model_path, positions.size(), o.deformation,
                           r.summary);
  for (std::uint32_t i = 0; i < tools.size(); ++i) {
    const ToolResult& t = r.tools[i];
    std::cout << fmt::format("{:<14}at {} -> action point {} (snapped {:.2f} mm){}\n", fmt::format("tool {}", i + 1),
                             mm(tools[i].point_mm), mm(t.action_point * 1e3), t.snap_distance * 1e3,
                             beam  ? fmt::format(", beam {:.1f} mm", t.beam_length * 1e3)
                             : fem ? std::string(", held boundary point")
                                   : std::string(", held node"));
    std::cout << fmt::format("{:<14}press {} -> action point moved {} ({:.2f} mm from the tool's target)\n", "",
                             mm(tools[i].displacement_mm), mm(t.action_moved * 1e3),
                             (t.action_moved * 1e3 - tools[i].displacement_mm).norm());
    std::cout << fmt::format("{:<14}press {} -> force on the tool ({:.4f}, {:.4f}, {:.4f}) N, |F| {:.4f} N\n", "",
                             mm(tools[i].displacement_mm), t.force[0], t.force[1], t.force[2], t.force.norm());
  }
  std::cout << fmt::format(
      "{:<14}max vertex displacement {:.2f} mm (vertex {}); volume of the {} {:.1f} -> {:.1f} mL ({:+.2f} %)\n",
      "organ", shape.max_displacement * 1e3, organ.file_vertex_index()[shape.max_vertex],
      shape.volume_of_tetrahedra ? "tetrahedra" : "surface", shape.rest_volume * 1e6, shape.deformed_volume * 1e6,
      volume_change * 100.0);
  if (beam)
    std::cout << fmt::format(
        "{:<14}beam {:.1f} us per tool, force {:.3f} us per tool, deformation {:.3f} ms "
        "(first frame of a contact, normals included)\n",
        "time", r.attach_seconds * 1e6, r.force_seconds * 1e6, r.deform_seconds * 1e3);
  else if (!fem)
    std::cout << fmt::format(
        "{:<14}attach {:.1f} us per tool, force {:.3f} us per tool, deformation {:.3f} ms per frame "
        "(normals included)\n",
        "time", r.attach_seconds * 1e6, r.force_seconds * 1e6, r.deform_seconds * 1e3);
  else
    std::cout << fmt::format(
        "{:<14}setup {:.3f} s (assembly and factorization at rest), attach {:.1f} ms per tool, "
        "Newton iteration {:.1f} ms (assembly, factorization, solve)\n",
        "time", r.setup_seconds, r.attach_seconds * 1e3, r.deform_seconds * 1e3);
  if (other) {
    std::cout << fmt::format("{:<14}{}: {}; max vertex displacement {:.2f} mm\n", "compare", o.compare, other->summary,
                             measure(organ, *other).max_displacement * 1e3);
    for (std::uint32_t i = 0; i < tools.size(); ++i) {
      const Eigen::Vector3d& f = other->tools[i].force;
      std::cout << fmt::format(
          "{:<14}tool {}: force ({:.4f}, {:.4f}, {:.4f}) N, |F| {:.4f} N; |F_{} - F_{}| {:.4f} N "
          "({:.0f} % of |F_{}|)\n",
          "", i + 1, f[0], f[1], f[2], f.norm(), o.deformation, o.compare, versus.force[i],
          100.0 * versus.force[i] / std::max(f.norm(), 1e-300), o.compare);
    }
    std::cout << fmt::format("{:<14}surfaces {} vs {}: vertex distance RMS {:.2f} mm, max {:.2f} mm\n", "",
                             o.deformation, o.compare, versus.rms * 1e3, versus.max * 1e3);
  }
  if (!o.out_path.empty()) std::cout << fmt::format("{:<14}{} (LPS, mm)\n", "deformed", o.out_path);
  return 0;
}

}  // namespace

Command add_poke_command(CLI::App& app) {
  auto o = std::make_shared<PokeOptions>();
  app.add_option("model", o->model_path, "Model file (.organ)")->required();
  add_press_options(app, o->tools, o->press);
  add_deformation_model_option(app, o->deformation);
  app.add_option("--compare", o->compare, "Press with this model too and print how its forces and surface differ")
      ->check(CLI::IsMember(deformation_model_names()));
  app.add_option("--out", o->out_path, "Write the deformed surface (.vtp, LPS, mm)");
  app.add_option("--png", o->png_path,
                 "Draw the deformed tetrahedra coloured by the displacement (needs an X display: xvfb-run -a)");
  app.add_flag("--json", o->json, "Print the result as one JSON object on stdout");
  return [o] { return run_poke(*o); };
}

}  // namespace organsim::cli
