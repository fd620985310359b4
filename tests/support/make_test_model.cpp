// organsim-test-model: writes the test helpers' models to files, for the demo,
// the fuzz corpus and benchmarks.
#include <CLI/CLI.hpp>

#include <cstdio>

#include "organsim/model/model_file.h"
#include "test_models.h"

int main(int argc, char** argv) {
  CLI::App app{"Write a model with known geometry (test helper)"};
  std::string output, shape = "cylinder";
  organsim::testing::CylinderSpec cylinder;
  double radius_mm = cylinder.radius * 1e3, length_mm = cylinder.length * 1e3;
  std::size_t sphere_vertices = 100000;
  std::uint32_t stations = 20;
  app.add_option("shape", shape, "cylinder or sphere")->check(CLI::IsMember({"cylinder", "sphere"}));
  app.add_option("-o,--output", output, "Model file to write")->required();
  app.add_option("--radius-mm", radius_mm, "Cylinder radius, mm")->capture_default_str();
  app.add_option("--length-mm", length_mm, "Cylinder length, mm")->capture_default_str();
  app.add_option("--segments", cylinder.segments, "Cylinder segments around")->capture_default_str();
  app.add_option("--rings", cylinder.rings, "Cylinder rings along")->capture_default_str();
  app.add_option("--vertices", sphere_vertices, "Sphere surface vertices")->capture_default_str();
  app.add_option("--stations", stations, "Beam stations")->capture_default_str();
  bool sites = false;
  app.add_flag("--site-compliance", sites,
               "Add uniform site compliances and a depth curve (format 1.2's SITE section)");
  bool curvature = false;
  app.add_flag("--site-curvature", curvature,
               "With --site-compliance: the cylinder side's curvatures (1/radius, 0) at every vertex (format 1.3's "
               "CURV section)");
  bool supports = false;
  app.add_flag("--supports", supports,
               "Every vertex below the axis (z < 0) on a contact (format 1.5's SUPP section); with --site-compliance "
               "also the compliances on the supports, a quarter of the others (format 1.7's SSUP section), and "
               "their depth curve (format 1.8's SCRV section)");
  CLI11_PARSE(app, argc, argv);
  try {
    organsim::model::OrganModel model;
    if (shape == "cylinder") {
      cylinder.radius = radius_mm * 1e-3;
      cylinder.length = length_mm * 1e-3;
      cylinder.stations = stations;
      model = organsim::testing::make_cylinder_model(cylinder);
    } else {
      model = organsim::testing::make_sphere_model(sphere_vertices, stations);
    }
    if (sites) organsim::testing::add_uniform_site_compliance(model, 0.02);
    if (sites && curvature) model.sites.curvature.assign(model.surface_vertices.size(), {1.0 / cylinder.radius, 0.0});
    if (supports) {
      for (const organsim::model::Point3& p : model.surface_vertices)
        model.supports.vertices.push_back(p[2] < 0.0 ? std::array<double, 2>{1.0, 2.5e5}
                                                     : std::array<double, 2>{0.0, 0.0});
      if (sites) {
        for (const auto& c : model.sites.compliance)
          model.sites.supported.push_back({c[0] / 4, c[1] / 4, c[2] / 4, c[3] / 4, c[4] / 4, c[5] / 4});
        model.sites.supported_depth_curve = {{{0.0, 0.8}}, {{0.003, 1.1}}};
        model.sites.supported_curve_tip_radius = 0.0025;
      }
    }
    organsim::model::write_organ_model_file(model, output);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "organsim-test-model: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
