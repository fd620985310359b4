// `organsim compare MODEL --tool X,Y,Z/DX,DY,DZ [--tool …] [--models …]
// [--reference psh] [--json] [--out DIR]`: every deformation model under the
// same presses, each measured against a reference model (Ogata et al.'s Table 5
// measure: nodal displacement differences normalized by the bounding box).
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line/command_line.h"
#include "organsim/mesh_io/mesh_io.h"
#include "organsim/model/model_file.h"
#include "organsim/realtime/model_registry.h"
#include "plot/line_plot.h"
#include "static_press/static_press.h"

namespace organsim::cli {
namespace {

struct CompareOptions {
  std::string model_path;
  std::vector<std::string> tools;
  std::vector<std::string> models = deformation_model_names();
  std::string reference = realtime::reference_model().name;
  bool models_given = false;  // --models on the command line
  bool json = false;
  std::string out_dir;
  int sweep = 4;
  PressOptions press;
};

Eigen::Vector3d point(const model::Point3& p) { return {p[0], p[1], p[2]}; }

/// Displacement and difference from the reference (mm) at `positions` whose
/// rest places are `rest` (m); LPS mm.
void add_fields(mesh_io::FieldMesh& mesh, const std::vector<model::Point3>& rest,
                const std::vector<model::Point3>& positions, const std::vector<model::Point3>& reference,
                const std::vector<std::uint32_t>* order) {
  const std::size_t n = positions.size();
  mesh.units = "mm";
  mesh.space = "LPS";
  mesh.points.resize(n);
  mesh_io::DataArray displacement{"displacement", 3, std::vector<double>(3 * n)};
  mesh_io::DataArray difference{"difference", 3, std::vector<double>(3 * n)};
  for (std::size_t v = 0; v < n; ++v) {
    const std::size_t f = order ? (*order)[v] : v;
    const Eigen::Vector3d at = point(positions[v]);
    const Eigen::Vector3d moved = at - point(rest[v]);
    const Eigen::Vector3d apart = at - point(reference[v]);
    for (int k = 0; k < 3; ++k) {
      mesh.points[f][k] = at[k] * 1e3;
      displacement.values[3 * f + k] = moved[k] * 1e3;
      difference.values[3 * f + k] = apart[k] * 1e3;
    }
  }
  mesh.point_data = {displacement, difference};
}

/// The model's deformed surface in the file's vertex numbering and, when the
/// model and the reference moved the tetrahedral nodes, its deformed
/// tetrahedra, each with displacement and difference from the reference (mm).
std::vector<std::string> write_model_files(const organ::Organ& organ,
                                           const std::vector<model::Triangle>& file_triangles, const PressResult& r,
                                           const PressResult& reference, const std::string& stem) {
  mesh_io::FieldMesh surface;
  add_fields(surface, organ.model().surface_vertices, r.positions, reference.positions, &organ.file_vertex_index());
  for (const model::Triangle& t : file_triangles) surface.triangles.push_back({t[0], t[1], t[2]});
  mesh_io::write_field_vtu(surface, stem + ".vtu");
  std::vector<std::string> written{stem + ".vtu"};
  if (r.node_positions.empty() || reference.node_positions.empty()) return written;
  mesh_io::FieldMesh volume;
  add_fields(volume, organ.model().volume_vertices, r.node_positions, reference.node_positions, nullptr);
  for (const model::Tetrahedron& t : organ.model().tetrahedra) volume.tetrahedra.push_back({t[0], t[1], t[2], t[3]});
  mesh_io::write_field_vtu(volume, stem + "_tetrahedra.vtu");
  written.push_back(stem + "_tetrahedra.vtu");
  return written;
}

/// differences.png (mean and max per model) and force_depth.png (each tool's
/// |F| against the press depth, `sweep` depths up to the given presses).
std::vector<std::string> write_plots(const CompareOptions& o, const organ::Organ& organ,
                                     const std::vector<ToolSpec>& tools, const std::vector<std::string>& models,
                                     const std::vector<PressResult>& results, const std::vector<Comparison>& versus) {
  if (const char* display = std::getenv("DISPLAY"); display == nullptr || *display == '\0') {
    warn("compare", "no X display: the PNG plots were not drawn (run under xvfb-run -a for them)");
    return {};
  }
  const std::filesystem::path dir(o.out_dir);
  plot::BarSeries mean{"mean", {}}, max{"max", {}};
  for (const Comparison& c : versus) {
    mean.values.push_back(100.0 * c.measure.mean);
    max.values.push_back(100.0 * c.measure.max);
  }
  plot::write_bar_chart_png(models, {mean, max}, "Nodal displacement difference from " + o.reference,
                            "% of the bounding box diagonal", (dir / "differences.png").string());

  std::vector<plot::Series> curves;
  for (std::size_t m = 0; m < models.size(); ++m)
    for (std::size_t i = 0; i < tools.size(); ++i)
      curves.push_back({tools.size() > 1 ? fmt::format("{} tool {}", models[m], i + 1) : models[m], {0.0}, {0.0}});
  for (int step = 1; step <= o.sweep; ++step) {
    const double fraction = static_cast<double>(step) / o.sweep;
    std::vector<ToolSpec> shallower = tools;
    for (ToolSpec& t : shallower) t.displacement_mm *= fraction;
    for (std::size_t m = 0; m < models.size(); ++m) {
      const PressResult r = step == o.sweep ? results[m] : press(models[m], organ, shallower, o.press);
      for (std::size_t i = 0; i < tools.size(); ++i) {
        curves[m * tools.size() + i].x.push_back(shallower[i].displacement_mm.norm());
        curves[m * tools.size() + i].y.push_back(r.tools[i].force.norm());
      }
    }
  }
  plot::write_line_plot_png(curves, "Force against press depth", "press depth (mm)", "|F| on the tool (N)",
                            (dir / "force_depth.png").string());
  return {(dir / "differences.png").string(), (dir / "force_depth.png").string()};
}

int run_compare(CompareOptions o) {
  std::vector<ToolSpec> tools;
  for (const std::string& t : o.tools) tools.push_back(parse_tool(t));
  if (tools.size() > multibeam::kMaxTools)
    throw std::runtime_error(fmt::format("at most {} tools", multibeam::kMaxTools));
  // The reference is pressed (and listed) even when --models leaves it out.
  std::vector<std::string> models;
  for (const std::string& m : o.models)
    if (std::find(models.begin(), models.end(), m) == models.end()) models.push_back(m);
  if (std::find(models.begin(), models.end(), o.reference) == models.end()) models.insert(models.begin(), o.reference);
  if (!o.out_dir.empty()) std::filesystem::create_directories(o.out_dir);

  // Without --models: every model the file can run (one baked with
  // --no-beam-tables runs all but the multi-beam model).
  model::OrganModel loaded =
      load_simulation_model("compare", o.model_path, o.models_given ? models : std::vector{o.reference});
  if (!o.models_given)
    models.erase(std::remove_if(models.begin(), models.end(),
                                [&](const std::string& m) {
                                  const std::string why = realtime::unsuitable_model(*realtime::find_model(m), loaded);
                                  if (!why.empty()) note("compare", "not pressing with " + m + ": " + why);
                                  return !why.empty();
                                }),
                 models.end());
  warn_if_depth_curve_rescaled("compare", loaded, models, o.press.tuning);
  const std::vector<model::Triangle> file_triangles = loaded.surface_triangles;
  const organ::Organ organ(std::move(loaded));
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
  std::vector<Comparison> versus;
  for (const PressResult& r : results) versus.push_back(compare_presses(r, reference, extent));

  nlohmann::json j;
  j["reference"] = o.reference;
  j["model"] = o.model_path;
  j["models"] = nlohmann::json::object();
  std::cout.setf(std::ios::fixed);
  if (!o.json) {
    std::cout << fmt::format(
        "{:<14}{} ({} surface vertices, {} tetrahedral nodes; bounding box {:.1f} x {:.1f} x {:.1f} mm)\n", "organ",
        o.model_path, organ.vertex_count(), organ.model().volume_vertices.size(), extent[0] * 1e3, extent[1] * 1e3,
        extent[2] * 1e3);
    for (std::size_t i = 0; i < tools.size(); ++i)
      std::cout << fmt::format("{:<14}{}\n", fmt::format("tool {}", i + 1), tools[i].text);
    std::cout << fmt::format(
        "\nagainst {}: nodal displacement differences as % of the bounding box (on: the tetrahedral "
        "nodes, or the surface vertices for a model that moves only those). mean, max: |du| over "
        "its diagonal; mean x / y / z: |du_k| over its extent along k; paper: Ogata et al.'s "
        "Table 5 measure, the three per-axis means' average and the largest single component\n\n",
        o.reference);
    std::string head = fmt::format("| {:<12} | {:<7} | {:>7} | {:>7} | {:>27} | {:>17} | {:>12} |", "model", "on",
                                   "mean", "max", "mean x / y / z", "paper mean / max", "surface mean");
    for (std::size_t i = 0; i < tools.size(); ++i)
      head += fmt::format(" {:>14} |", fmt::format("tool {} |F| (N)", i + 1));
    head += fmt::format(" {:>7} |", "force x");
    head += fmt::format(" {:>9} | {:>10} | {:>15} |", "volume", "frame (ms)", "force tick (us)");
    std::cout << head << '\n';
  }
  for (std::size_t m = 0; m < models.size(); ++m) {
    const PressResult& r = results[m];
    const fem::DisplacementDifference& d = versus[m].measure;
    const Deformation shape = measure(organ, r);
    const double volume_change = 100.0 * (shape.deformed_volume - shape.rest_volume) / shape.rest_volume;
    const double factor = force_factor(r, reference);
    nlohmann::json forces = nlohmann::json::array();
    for (const ToolResult& t : r.tools) forces.push_back({t.force[0], t.force[1], t.force[2]});
    j["models"][models[m]] = {{"mean_difference", d.mean},
                              {"max_difference", d.max},
                              {"mean_difference_per_axis", {d.axis_mean[0], d.axis_mean[1], d.axis_mean[2]}},
                              {"max_difference_per_axis", {d.axis_max[0], d.axis_max[1], d.axis_max[2]}},
                              {"paper_mean_difference", d.paper_mean()},
                              {"paper_max_difference", d.paper_max()},
                              {"compared_on", versus[m].on_nodes ? "tetrahedral nodes" : "surface vertices"},
                              {"surface_mean_difference", versus[m].surface.mean},
                              {"surface_max_difference", versus[m].surface.max},
                              {"forces_n", forces},
                              {"force_factor", std::isfinite(factor) ? nlohmann::json(factor) : nlohmann::json()},
                              {"volume_change_percent", volume_change},
                              {"volume_of", shape.volume_of_tetrahedra ? "tetrahedra" : "surface"},
                              {"frame_time_ms", r.frame_seconds * 1e3},
                              {"force_tick_us", r.force_seconds * 1e6},
                              {"max_displacement_mm", shape.max_displacement * 1e3},
                              {"static_iteration_ms", r.deform_seconds * 1e3},
                              {"setup", r.summary}};
    if (!o.out_dir.empty())
      j["models"][models[m]]["files"] = write_model_files(organ, file_triangles, r, reference,
                                                          (std::filesystem::path(o.out_dir) / models[m]).string());
    if (o.json) continue;
    std::string row = fmt::format(
        "| {:<12} | {:<7} | {:>6.2f}% | {:>6.2f}% | {:>6.2f}% / {:>6.2f}% / {:>6.2f}% | {:>6.2f}% / {:>6.2f}% | "
        "{:>11.2f}% |",
        models[m], versus[m].on_nodes ? "nodes" : "surface", 100 * d.mean, 100 * d.max, 100 * d.axis_mean[0],
        100 * d.axis_mean[1], 100 * d.axis_mean[2], 100 * d.paper_mean(), 100 * d.paper_max(),
        100 * versus[m].surface.mean);
    for (const ToolResult& t : r.tools) row += fmt::format(" {:>14.4f} |", t.force.norm());
    row += std::isfinite(factor) ? fmt::format(" {:>6.2f}x |", factor) : fmt::format(" {:>7} |", "-");
    row += fmt::format(" {:>+8.3f}% | {:>10.3f} | {:>15.3f} |", volume_change, r.frame_seconds * 1e3,
                       r.force_seconds * 1e6);
    std::cout << row << '\n';
  }
  std::vector<std::string> plots;
  if (!o.out_dir.empty()) plots = write_plots(o, organ, tools, models, results, versus);
  j["plots"] = plots;
  if (o.json) {
    std::cout << j.dump() << '\n';
    return 0;
  }
  std::cout << "\nforce x: the factor the tool forces are off the reference's, exp(sqrt(mean ln^2(|F| / |F_ref|))).\n"
               "frame: what the real-time engine computes per 60 Hz frame at the pressed state: the multi-beam\n"
               "deformation, the mass-spring model's 1/60 s of steps, one FEM iteration with the kept factor; force\n"
               "tick: the force law the 1 kHz loop evaluates per tool. Setups:\n";
  for (std::size_t m = 0; m < models.size(); ++m) std::cout << fmt::format("{:<14}{}\n", models[m], results[m].summary);
  if (!o.out_dir.empty())
    std::cout << fmt::format(
        "{:<14}{}/<model>.vtu and <model>_tetrahedra.vtu (deformed surface and tetrahedra, "
        "displacement and difference, LPS mm)\n",
        "written", o.out_dir);
  for (const std::string& path : plots) std::cout << fmt::format("{:<14}{}\n", "plotted", path);
  return 0;
}

}  // namespace

Command add_compare_command(CLI::App& app) {
  auto o = std::make_shared<CompareOptions>();
  app.add_option("model", o->model_path, "Model file (.organ)")->required();
  add_press_options(app, o->tools, o->press);
  CLI::Option* models = app.add_option("--models", o->models,
                                       "The models to press, comma-separated (default: every model the file can run)")
                            ->delimiter(',')
                            ->check(CLI::IsMember(deformation_model_names()))
                            ->capture_default_str();
  app.add_option("--reference", o->reference, "The model the others are measured against")
      ->check(CLI::IsMember(deformation_model_names()))
      ->capture_default_str();
  app.add_option(
      "--out", o->out_dir,
      "Write each model's deformed surface and tetrahedra as DIR/<model>.vtu and DIR/<model>_tetrahedra.vtu "
      "(ParaView) and the plots DIR/differences.png and DIR/force_depth.png (needs an X display: xvfb-run -a)");
  app.add_option("--sweep", o->sweep,
                 "With --out: press depths in the force-depth plot (the given presses' fractions k/N)")
      ->check(CLI::Range(1, 50))
      ->capture_default_str();
  app.add_flag("--json", o->json, "Print the comparison as one JSON object on stdout");
  return [o, models] {
    o->models_given = models->count() > 0;
    return run_compare(*o);
  };
}

}  // namespace organsim::cli
