// `organsim info MODEL [--json] [--beam V]`: what a model file holds.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iostream>
#include <stdexcept>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line/command_line.h"
#include "organsim/geometry/model_measures.h"
#include "organsim/model/beam_frame.h"
#include "organsim/model/model_file.h"
#include "organsim/organ/site_law.h"

namespace organsim::cli {
namespace {

struct InfoOptions {
  std::string model_path;
  bool json = false;
  long long beam_vertex = -1;
};

nlohmann::json as_json(const model::Point3& p) { return {p[0], p[1], p[2]}; }
nlohmann::json as_json(const Eigen::Vector3d& p) { return {p[0], p[1], p[2]}; }

nlohmann::json beam_json(const model::OrganModel& m, std::size_t v) {
  nlohmann::json beam;
  beam["vertex"] = v;
  beam["position_m"] = as_json(m.surface_vertices[v]);
  const model::Point3& root = m.fixed_points.front();
  const model::Point3& tip = m.surface_vertices[v];
  beam["length_m"] = std::hypot(tip[0] - root[0], tip[1] - root[1], tip[2] - root[2]);
  model::BeamFrame frame;
  if (model::make_beam_frame(root, tip, frame))
    beam["frame"] = {{"x", as_json(frame.x)}, {"y", as_json(frame.y)}, {"z", as_json(frame.z)}};
  else
    beam["frame"] = nullptr;  // the vertex coincides with the fixed point
  nlohmann::json stations = nlohmann::json::array();
  for (std::uint32_t s = 0; s < m.beams.stations_per_beam; ++s) {
    const model::BeamSection& section = m.beams.at(v, s);
    stations.push_back({{"t", (s + 0.5) / m.beams.stations_per_beam},
                        {"area_m2", section.area},
                        {"i_yy_m4", section.i_yy},
                        {"i_zz_m4", section.i_zz},
                        {"i_yz_m4", section.i_yz},
                        {"torsion_j_m4", section.torsion_j},
                        {"centroid_y_m", section.centroid_y},
                        {"centroid_z_m", section.centroid_z}});
  }
  beam["stations"] = stations;
  return beam;
}

/// The site compliances in a few numbers: the reference's normal stiffness
/// under a tip of kTipRadius at every vertex (its quantiles) and the depth curve.
nlohmann::json sites_json(const model::OrganModel& m) {
  const model::SiteCompliance& sites = m.sites;
  if (sites.empty()) return nullptr;
  constexpr double kTipRadius = 0.0025;  // m: the default tool's end
  std::vector<Eigen::Vector3d> normals(m.surface_vertices.size(), Eigen::Vector3d::Zero());
  auto at = [&](std::uint32_t v) {
    return Eigen::Vector3d(m.surface_vertices[v][0], m.surface_vertices[v][1], m.surface_vertices[v][2]);
  };
  for (const model::Triangle& t : m.surface_triangles) {
    const Eigen::Vector3d n = (at(t[1]) - at(t[0])).cross(at(t[2]) - at(t[0]));
    for (std::uint32_t v : t) normals[v] += n;
  }
  // The quantiles over the surface of the normal stiffness under the tip for
  // one set of compliances.
  auto normal_stiffness = [&](const std::vector<std::array<double, 6>>& compliances) -> nlohmann::json {
    if (compliances.empty()) return nullptr;
    std::vector<double> stiffness;
    for (std::size_t v = 0; v < normals.size(); ++v) {
      const auto& c = compliances[v];
      Eigen::Matrix3d organ;
      organ << c[0], c[3], c[4], c[3], c[1], c[5], c[4], c[5], c[2];
      const Eigen::Vector3d n = normals[v].normalized();
      const Eigen::Matrix3d total =
          organ + organ::punch_compliance(sites.young_modulus, sites.poisson_ratio, kTipRadius, n);
      stiffness.push_back(n.dot(total.inverse() * n));
    }
    std::sort(stiffness.begin(), stiffness.end());
    auto quantile = [&](double q) {
      return stiffness[static_cast<std::size_t>(q * static_cast<double>(stiffness.size() - 1))];
    };
    return {{"min", quantile(0.0)},
            {"p10", quantile(0.1)},
            {"median", quantile(0.5)},
            {"p90", quantile(0.9)},
            {"max", quantile(1.0)}};
  };
  auto depth_curve = [](const std::vector<std::array<double, 2>>& points) {
    nlohmann::json curve = nlohmann::json::array();
    for (const auto& [depth, factor] : points) curve.push_back({{"depth_m", depth}, {"factor", factor}});
    return curve;
  };
  nlohmann::json pull = nlohmann::json::array();
  for (const auto& [drawn, softening] : sites.pull_curve)
    pull.push_back({{"drawn_m", drawn}, {"softening", softening}});
  nlohmann::json hertz = nullptr;
  if (!sites.curvature.empty()) {
    std::vector<double> radii;
    for (const auto& [first, second] : sites.curvature) radii.push_back(organ::hertz_radius(kTipRadius, first, second));
    std::sort(radii.begin(), radii.end());
    auto at_quantile = [&](double q) {
      return radii[static_cast<std::size_t>(q * static_cast<double>(radii.size() - 1))];
    };
    hertz = {{"min", at_quantile(0.0)},
             {"p10", at_quantile(0.1)},
             {"median", at_quantile(0.5)},
             {"p90", at_quantile(0.9)},
             {"max", at_quantile(1.0)}};
  }
  return {{"reference_young_modulus_pa", sites.young_modulus},
          {"reference_poisson_ratio", sites.poisson_ratio},
          {"normal_stiffness_n_per_m_at_2_5_mm_tip", normal_stiffness(sites.compliance)},
          {"normal_stiffness_on_the_supports_n_per_m_at_2_5_mm_tip", normal_stiffness(sites.supported)},
          {"hertz_radius_m_at_2_5_mm_tip", hertz},
          {"depth_curve", depth_curve(sites.depth_curve)},
          {"depth_curve_tip_radius_m", sites.curve_tip_radius},
          {"depth_curve_on_the_supports", depth_curve(sites.supported_depth_curve)},
          {"depth_curve_on_the_supports_tip_radius_m", sites.supported_curve_tip_radius},
          {"pull_curve", pull},
          {"pull_curve_tip_radius_m", sites.pull_tip_radius}};
}

nlohmann::json summary_json(const InfoOptions& o, const model::ModelReadResult& read) {
  const model::OrganModel& m = *read.model;
  const geometry::ModelMeasures measures = geometry::measure_model(m);
  nlohmann::json j;
  j["file"] = o.model_path;
  j["format_version"] = fmt::format("{}.{}", read.file.version.major, read.file.version.minor);
  j["file_bytes"] = read.file.file_bytes;
  nlohmann::json sections = nlohmann::json::array();
  for (const auto& s : read.file.sections)
    sections.push_back({{"tag", s.tag}, {"bytes", s.bytes}, {"understood", s.understood}});
  j["sections"] = sections;
  j["units"] = "SI";
  j["coordinate_frame"] = m.provenance.coordinate_frame;
  j["counts"] = {{"surface_vertices", m.surface_vertices.size()},
                 {"surface_triangles", m.surface_triangles.size()},
                 {"texture_coordinates", m.surface_texcoords.size()},
                 {"volume_vertices", m.volume_vertices.size()},
                 {"tetrahedra", m.tetrahedra.size()},
                 {"fixed_points", m.fixed_points.size()},
                 {"beam_stations", m.beams.stations_per_beam}};
  j["bounding_box_m"] = {{"min", as_json(measures.bounds_min)},
                         {"max", as_json(measures.bounds_max)},
                         {"size", as_json(Eigen::Vector3d(measures.bounds_max - measures.bounds_min))}};
  j["volume_m3"] = {
      {"tetrahedra", m.tetrahedra.empty() ? nlohmann::json(nullptr) : nlohmann::json(measures.tetrahedra_volume)},
      {"surface", measures.surface_enclosed_volume}};
  j["surface_area_m2"] = measures.surface_area;
  const model::Material& mat = m.material;
  j["material"] = {{"young_modulus_pa", mat.young_modulus},
                   {"poisson_ratio", mat.poisson_ratio},
                   {"density_kg_m3", mat.density},
                   {"attenuation_alpha", mat.attenuation_alpha},
                   {"attenuation_beta_per_m", mat.attenuation_beta},
                   {"beam_stiffness_scale", mat.beam_stiffness_scale},
                   {"spring_stiffness_scale", mat.spring_stiffness_scale}};
  nlohmann::json fixed = nlohmann::json::array();
  for (const model::Point3& p : m.fixed_points) fixed.push_back(as_json(p));
  j["fixed_points_m"] = fixed;
  j["meshing"] = m.meshing.empty() ? nlohmann::json(nullptr)
                                   : nlohmann::json{{"tet_size_m", m.meshing.tet_size},
                                                    {"clamp_radius_m", m.meshing.clamp_radius},
                                                    {"clamp_cell_size_m", m.meshing.clamp_cell_size}};
  if (m.supports.empty()) {
    j["supports"] = nullptr;
  } else {
    std::size_t counts[3] = {0, 0, 0};
    double areas[3] = {0.0, 0.0, 0.0}, modulus = 0.0;
    std::vector<double> vertex_area(m.surface_vertices.size(), 0.0);
    for (const model::Triangle& t : m.surface_triangles) {
      const auto p = [&](std::uint32_t v) {
        return Eigen::Vector3d(m.surface_vertices[v][0], m.surface_vertices[v][1], m.surface_vertices[v][2]);
      };
      const double third = (p(t[1]) - p(t[0])).cross(p(t[2]) - p(t[0])).norm() / 6.0;
      for (const std::uint32_t v : t) vertex_area[v] += third;
    }
    for (std::size_t v = 0; v < m.surface_vertices.size(); ++v) {
      const int kind = static_cast<int>(m.supports.kind(v));
      ++counts[kind], areas[kind] += vertex_area[v];
      modulus = std::max(modulus, m.supports.modulus(v));
    }
    j["supports"] = {{"contact_vertices", counts[1]},    {"contact_area_m2", areas[1]},
                     {"attachment_vertices", counts[2]}, {"attachment_area_m2", areas[2]},
                     {"free_vertices", counts[0]},       {"largest_foundation_modulus_pa_per_m", modulus}};
  }
  j["provenance"] = {{"program_version", m.provenance.program_version},
                     {"input_sha256", m.provenance.input_sha256},
                     {"parameters", m.provenance.parameters}};
  j["site_compliance"] = sites_json(m);
  if (o.beam_vertex >= 0) j["beam"] = beam_json(m, static_cast<std::size_t>(o.beam_vertex));
  return j;
}

void print_text(const nlohmann::json& j) {
  auto vec_mm = [](const nlohmann::json& v) {
    return fmt::format("{:.1f}, {:.1f}, {:.1f}", v[0].get<double>() * 1e3, v[1].get<double>() * 1e3,
                       v[2].get<double>() * 1e3);
  };
  const auto& c = j["counts"];
  fmt::print("model           {}\n", j["file"].get<std::string>());
  fmt::print("format          .organ {} ({} bytes; sections:", j["format_version"].get<std::string>(),
             j["file_bytes"].get<std::uint64_t>());
  for (const auto& s : j["sections"]) fmt::print(" {}", s["tag"].get<std::string>());
  fmt::print(")\n");
  fmt::print("units           SI (m, kg, s, N, Pa); coordinates in the patient frame {}\n",
             j["coordinate_frame"].get<std::string>());
  fmt::print("surface         {} vertices, {} triangles{}\n", c["surface_vertices"].get<std::size_t>(),
             c["surface_triangles"].get<std::size_t>(),
             c["texture_coordinates"].get<std::size_t>() > 0 ? ", with texture coordinates" : "");
  fmt::print("tetrahedra      {} tetrahedra on {} vertices\n", c["tetrahedra"].get<std::size_t>(),
             c["volume_vertices"].get<std::size_t>());
  if (!j["meshing"].is_null()) {
    const auto& mesh = j["meshing"];
    fmt::print("meshed          {:g} mm cells", mesh["tet_size_m"].get<double>() * 1e3);
    if (mesh["clamp_cell_size_m"].get<double>() > 0.0)
      fmt::print(", {:g} mm within {:g} mm of the fixed point", mesh["clamp_cell_size_m"].get<double>() * 1e3,
                 mesh["clamp_radius_m"].get<double>() * 1e3);
    fmt::print("\n");
  }
  if (!j["supports"].is_null()) {
    const auto& s = j["supports"];
    fmt::print(
        "supports        contact {:.0f} cm² ({} vertices), attachment {:.0f} cm² ({}), free {} vertices; foundation "
        "modulus up to {:.3g} Pa/m\n",
        s["contact_area_m2"].get<double>() * 1e4, s["contact_vertices"].get<std::size_t>(),
        s["attachment_area_m2"].get<double>() * 1e4, s["attachment_vertices"].get<std::size_t>(),
        s["free_vertices"].get<std::size_t>(), s["largest_foundation_modulus_pa_per_m"].get<double>());
  } else {
    fmt::print("supports        none: the organ is held by its clamp alone\n");
  }
  fmt::print("bounding box    min ({}) mm, max ({}) mm, size ({}) mm\n", vec_mm(j["bounding_box_m"]["min"]),
             vec_mm(j["bounding_box_m"]["max"]), vec_mm(j["bounding_box_m"]["size"]));
  const auto& volume = j["volume_m3"];
  if (!volume["tetrahedra"].is_null())
    fmt::print("volume          {:.6g} m³ ({:.1f} mL) from the tetrahedra; {:.1f} mL enclosed by the surface\n",
               volume["tetrahedra"].get<double>(), volume["tetrahedra"].get<double>() * 1e6,
               volume["surface"].get<double>() * 1e6);
  else
    fmt::print("volume          {:.1f} mL enclosed by the surface (no tetrahedra)\n",
               volume["surface"].get<double>() * 1e6);
  fmt::print("surface area    {:.6g} m² ({:.1f} cm²)\n", j["surface_area_m2"].get<double>(),
             j["surface_area_m2"].get<double>() * 1e4);
  const auto& mat = j["material"];
  fmt::print("material        E = {:g} Pa, nu = {:g}, rho = {:g} kg/m³, attenuation alpha = {:g}, beta = {:g} 1/m\n",
             mat["young_modulus_pa"].get<double>(), mat["poisson_ratio"].get<double>(),
             mat["density_kg_m3"].get<double>(), mat["attenuation_alpha"].get<double>(),
             mat["attenuation_beta_per_m"].get<double>());
  if (mat["beam_stiffness_scale"].get<double>() != 1.0 || mat["spring_stiffness_scale"].get<double>() != 1.0)
    fmt::print("calibrated      beams E x {:g}, springs E x {:g}\n", mat["beam_stiffness_scale"].get<double>(),
               mat["spring_stiffness_scale"].get<double>());
  for (const auto& p : j["fixed_points_m"]) fmt::print("fixed point     ({}) mm\n", vec_mm(p));
  fmt::print("beam tables     {}\n",
             c["beam_stations"].get<unsigned>() > 0
                 ? fmt::format("{} stations per surface vertex", c["beam_stations"].get<unsigned>())
                 : std::string("none"));
  if (const auto& sites = j["site_compliance"]; sites.is_null()) {
    fmt::print("site compliance none: the fast models give their own forces (docs/matching.md)\n");
  } else {
    const auto& k = sites["normal_stiffness_n_per_m_at_2_5_mm_tip"];
    fmt::print(
        "site compliance the FEM reference's normal stiffness under a 2.5 mm tip {:.3g} (p10) / {:.3g} (median) / "
        "{:.3g} (p90) N/m; ",
        k["p10"].get<double>(), k["median"].get<double>(), k["p90"].get<double>());
    if (const auto& s = sites["normal_stiffness_on_the_supports_n_per_m_at_2_5_mm_tip"]; !s.is_null())
      fmt::print("on the supports {:.3g} (p10) / {:.3g} (median) / {:.3g} (p90) N/m; ", s["p10"].get<double>(),
                 s["median"].get<double>(), s["p90"].get<double>());
    if (const auto& h = sites["hertz_radius_m_at_2_5_mm_tip"]; !h.is_null())
      fmt::print(
          "the surface's curvature makes a 2.5 mm tip's Hertz radius {:.2f} (p10) / {:.2f} (median) / {:.2f} "
          "(p90) mm; ",
          h["p10"].get<double>() * 1e3, h["median"].get<double>() * 1e3, h["p90"].get<double>() * 1e3);
    else
      fmt::print("flat at the tip's scale (no curvatures: a format 1.2 file); ");
    auto curve_text = [](const nlohmann::json& points) {
      std::string curve;
      for (const auto& point : points)
        curve += fmt::format("{}{:g} mm x {:.3g}", curve.empty() ? "" : ", ", point["depth_m"].get<double>() * 1e3,
                             point["factor"].get<double>());
      return curve;
    };
    if (sites["depth_curve"].empty())
      fmt::print("no depth curve (linear law; organsim calibrate fits one)");
    else
      fmt::print("depth curve {} (tip {:g} mm)", curve_text(sites["depth_curve"]),
                 sites["depth_curve_tip_radius_m"].get<double>() * 1e3);
    if (!sites["depth_curve_on_the_supports"].empty())
      fmt::print("; on the supports {} (tip {:g} mm)", curve_text(sites["depth_curve_on_the_supports"]),
                 sites["depth_curve_on_the_supports_tip_radius_m"].get<double>() * 1e3);
    fmt::print("\n");
    if (sites["pull_curve"].empty()) {
      fmt::print("{:<16}none (a grasp holds as the bonded punch; organsim calibrate --pull fits one)\n", "pull curve");
    } else {
      std::string curve;
      for (const auto& point : sites["pull_curve"])
        curve += fmt::format("{}{:.3g} mm x {:.3g}", curve.empty() ? "" : ", ", point["drawn_m"].get<double>() * 1e3,
                             point["softening"].get<double>());
      fmt::print("{:<16}a held patch's softening by the distance drawn: {} (tip {:g} mm)\n", "pull curve", curve,
                 sites["pull_curve_tip_radius_m"].get<double>() * 1e3);
    }
  }
  const auto& prov = j["provenance"];
  const std::string sha = prov["input_sha256"].get<std::string>();
  fmt::print("written by      organsim {}\n", prov["program_version"].get<std::string>());
  fmt::print("input image     {}\n", sha.empty() ? std::string("none (synthetic model)") : "voxel SHA-256 " + sha);
  for (const auto& [name, value] : prov["parameters"].items())
    fmt::print("parameter       {} = {}\n", name, value.get<std::string>());
  if (j.contains("beam")) {
    const auto& b = j["beam"];
    fmt::print("\nbeam to surface vertex {} at ({}) mm, length {:.2f} mm\n", b["vertex"].get<std::size_t>(),
               vec_mm(b["position_m"]), b["length_m"].get<double>() * 1e3);
    fmt::print("{:>6} {:>12} {:>12} {:>12} {:>12} {:>12} {:>10} {:>10}\n", "t", "A mm²", "Iyy mm⁴", "Izz mm⁴",
               "Iyz mm⁴", "J mm⁴", "cy mm", "cz mm");
    for (const auto& s : b["stations"])
      fmt::print("{:>6.3f} {:>12.4g} {:>12.4g} {:>12.4g} {:>12.4g} {:>12.4g} {:>10.3f} {:>10.3f}\n",
                 s["t"].get<double>(), s["area_m2"].get<double>() * 1e6, s["i_yy_m4"].get<double>() * 1e12,
                 s["i_zz_m4"].get<double>() * 1e12, s["i_yz_m4"].get<double>() * 1e12,
                 s["torsion_j_m4"].get<double>() * 1e12, s["centroid_y_m"].get<double>() * 1e3,
                 s["centroid_z_m"].get<double>() * 1e3);
  }
}

int run_info(const InfoOptions& o) {
  const model::ModelReadResult read = model::read_organ_model_file(o.model_path);
  if (!read) throw std::runtime_error(read.error);
  const model::OrganModel& m = *read.model;
  if (o.beam_vertex >= 0) {
    if (m.beams.empty())
      throw std::runtime_error(o.model_path + ": the model has no beam tables; re-bake it with --stations N");
    if (static_cast<std::size_t>(o.beam_vertex) >= m.surface_vertices.size())
      throw std::runtime_error(fmt::format("--beam {} is out of range: the model has {} surface vertices (0..{})",
                                           o.beam_vertex, m.surface_vertices.size(), m.surface_vertices.size() - 1));
  }
  const nlohmann::json j = summary_json(o, read);
  if (o.json)
    std::cout << j.dump() << '\n';
  else
    print_text(j);
  return 0;
}

}  // namespace

Command add_info_command(CLI::App& app) {
  auto options = std::make_shared<InfoOptions>();
  app.add_option("MODEL", options->model_path, "Model file (.organ)")->required();
  app.add_flag("--json", options->json, "Print one JSON object (keys: docs/cli.md) instead of text");
  app.add_option("--beam", options->beam_vertex, "Also print the beam table of this surface vertex")
      ->check(kNonNegative);
  return [options] { return run_info(*options); };
}

}  // namespace organsim::cli
