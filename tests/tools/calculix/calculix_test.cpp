// Our FEM against CalculiX on the same C3D4 mesh (organsim/calculix/calculix.h):
// the same discretization, so the displacements must agree to the two solvers'
// tolerances (aim: 1e-4 of the largest displacement), not to a discretization error.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <cstdio>
#include <string>

#include "organsim/calculix/calculix.h"
#include "organsim/organ_fem/organ_fem.h"
#include "organsim/geometry/tool_tip.h"
#include "organsim/model/model_file.h"
#include "organsim/organ/organ.h"
#include "test_models.h"

namespace organsim::fem {
namespace {

Eigen::VectorXd run_calculix(const StaticProblem& problem, const std::string& name) {
  try {
    return calculix::solve(problem, name);
  } catch (const std::exception& e) {
    ADD_FAILURE() << e.what();
    return Eigen::VectorXd::Constant(3 * static_cast<Eigen::Index>(problem.mesh.nodes.size()), std::nan(""));
  }
}

/// A 5 × 1 × 1 cm bar, fixed at x = 0, under self-weight, with its end either
/// loaded or moved.
StaticProblem bar_problem(const Material& material) {
  StaticProblem problem;
  problem.mesh = box_mesh({10, 2, 2}, {0.05, 0.01, 0.01});
  problem.material = material;
  problem.density = 1000;
  problem.gravity = {0, 0, -9.81};
  problem.load_steps = 4;
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n) {
    const auto node = static_cast<std::int32_t>(n);
    if (problem.mesh.nodes[n].x() == 0) problem.fixed.push_back(node);
    if (std::abs(problem.mesh.nodes[n].x() - 0.05) < 1e-12) {
      if (material.model == MaterialModel::linear)
        problem.loads.push_back({node, 2, -2e-3});
      else
        problem.prescribed.push_back({node, 2, -0.012});  // a large bend: 24 % of the length
    }
  }
  return problem;
}

double relative_difference(const Eigen::VectorXd& ours, const Eigen::VectorXd& reference) {
  double largest = 0, worst = 0;
  for (Eigen::Index n = 0; n < ours.size() / 3; ++n) {
    largest = std::max(largest, reference.segment<3>(3 * n).norm());
    worst = std::max(worst, (ours.segment<3>(3 * n) - reference.segment<3>(3 * n)).norm());
  }
  return worst / largest;
}

/// Solves `material`'s bar problem with both solvers; expects agreement to 1e-4.
void expect_agreement(const Material& material, const std::string& label) {
  const StaticProblem problem = bar_problem(material);
  const StaticSolution ours = solve_static(problem);
  ASSERT_TRUE(ours.converged) << label << ": " << ours.error;
  const double difference = relative_difference(ours.displacements, run_calculix(problem, "bar"));
  std::printf("%s: largest difference / largest displacement %.3g\n", label.c_str(), difference);
  EXPECT_LT(difference, 1e-4) << label;
}

TEST(CalculiX, LinearAgrees) { expect_agreement(Material::from_young(MaterialModel::linear, 1e6, 0.3), "linear"); }

TEST(CalculiX, StVenantKirchhoffAgrees) {
  expect_agreement(Material::from_young(MaterialModel::stvk, 1e5, 0.3), "St. Venant-Kirchhoff");
}

TEST(CalculiX, MooneyRivlinWithoutStabilizationAgrees) {
  // κ / μ = 9.7 and 50 (the paper's ν = 0.49).
  expect_agreement(Material::mooney_rivlin_from_young(1e5, 0.45, 0), "Mooney-Rivlin, nu 0.45");
  expect_agreement(Material::mooney_rivlin_from_young(1e5, 0.49, 0), "Mooney-Rivlin, nu 0.49");
}

/// The real-time FEM model's grasp on the helper cylinder (150 mm long,
/// radius 30 mm, clamped over its x = 0 cap): a point tool touches the side's
/// top node at x = 80 mm, the jaws close, and the tool pulls it `pull` out.
/// Returns the engine model's nodal displacements once the frames have
/// converged, and fills `problem` with the same held node prescribed and the
/// same clamp, for CalculiX (docs/realtime.md#grasping).
Eigen::VectorXd grasp_and_pull(MaterialModel law, const Eigen::Vector3d& pull, StaticProblem& problem) {
  testing::CylinderSpec spec;
  spec.stations = 2;
  spec.section_polygon_vertices = 32;
  const model::OrganModel m = testing::make_cylinder_model(spec);
  OrganFemOptions options;
  options.fixed_radius = 0.031;
  options.refresh_frames = 2;
  std::int32_t node = -1;
  double best = 1e9;
  for (std::size_t n = 0; n < m.volume_vertices.size(); ++n) {
    const Eigen::Vector3d x(m.volume_vertices[n][0], m.volume_vertices[n][1], m.volume_vertices[n][2]);
    const double distance = (x - Eigen::Vector3d(0.08, 0.03, 0.0)).norm();
    if (distance < best) best = distance, node = static_cast<std::int32_t>(n);
  }
  const auto& held = m.volume_vertices[static_cast<std::size_t>(node)];
  OrganFem fem(m, law, options, 1);
  EXPECT_TRUE(fem.attach(0, {held[0], held[1], held[2]}));
  fem.grasp(0, true);
  for (int frame = 0; frame < 400; ++frame) {
    EXPECT_NE(fem.step(&pull), FrameStatus::not_finite);
    if (frame > 10 && fem.unbalanced_force() < 1e-12) break;
  }
  EXPECT_LT(fem.unbalanced_force(), 1e-9) << "the frames converged";
  problem = StaticProblem{};
  problem.mesh = tet_mesh_of(m);
  problem.material = Material::from_young(law, m.material.young_modulus, m.material.poisson_ratio);
  problem.load_steps = 4;
  for (std::size_t n = 0; n < problem.mesh.nodes.size(); ++n)
    if (problem.mesh.nodes[n].norm() <= options.fixed_radius) problem.fixed.push_back(static_cast<std::int32_t>(n));
  for (int k = 0; k < 3; ++k) problem.prescribed.push_back({node, k, pull[k]});
  return fem.displacements();
}

// A grasp in the real-time FEM model is a prescribed displacement of the held
// point: pulled 10 mm out of the cylinder's side (and 5 mm along it), the
// engine model's nodal displacements are CalculiX's with that node prescribed
// on the same C3D4 mesh, small strain and large.
TEST(CalculiX, AGraspedPointPulledOutIsAPrescribedDisplacement) {
  for (const MaterialModel law : {MaterialModel::linear, MaterialModel::stvk}) {
    StaticProblem problem;
    const Eigen::VectorXd ours = grasp_and_pull(law, {0.005, 0.010, 0.0}, problem);
    const double difference = relative_difference(ours, run_calculix(problem, "grasp"));
    std::printf("grasp, %s: largest difference / largest displacement %.3g\n",
                law == MaterialModel::linear ? "linear" : "stvk", difference);
    EXPECT_LT(difference, 1e-4);
  }
}

/// A grasp of `m` by a tip of finite size, as the engine model runs it: the
/// tip touches `site` (m) along the outward unit `normal`, bites `bite` (m)
/// in along it (the points it meets on the way are held: the first touch, and
/// nodes, edge and face points of the boundary within the tip), the jaws
/// close (holding the tip's footprint as one patch) and the tool pulls the
/// patch by `pull` (m) from its rest place. Fills `points` with what the tool
/// holds as prescribed displacements and `problem` with the same mesh, clamp
/// and material, for CalculiX.
struct GraspedPatch {
  StaticProblem problem;
  std::vector<calculix::PointDisplacement> points;
  Eigen::VectorXd displacements;
  Eigen::Vector3d force_on_tool = Eigen::Vector3d::Zero();
};

GraspedPatch grasp_patch(const model::OrganModel& m, MaterialModel law, double fixed_radius,
                         const Eigen::Vector3d& site, const Eigen::Vector3d& normal, double tip_radius, double bite,
                         const Eigen::Vector3d& pull) {
  GraspedPatch g;
  OrganFemOptions options;
  options.fixed_radius = fixed_radius;
  options.refresh_frames = 2;
  OrganFem fem(m, law, options, 1);
  const geometry::ToolTip tip = geometry::ToolTip::touching(tip_radius, normal, normal);
  EXPECT_TRUE(fem.attach(0, site, tip));
  auto settle = [&](const Eigen::Vector3d& d) {
    for (int frame = 0; frame < 1000; ++frame) {
      EXPECT_NE(fem.step(&d), FrameStatus::not_finite);
      if (frame > 10 && fem.unbalanced_force() < 1e-12) break;
    }
  };
  const Eigen::Vector3d in = -bite * normal;
  for (int k = 1; k <= 6; ++k) settle(in * k / 6.0);  // the tip takes in the points it meets on the way
  fem.grasp(0, true);
  for (int k = 1; k <= 10; ++k) settle(in + (pull - in) * k / 10.0);
  EXPECT_LT(fem.unbalanced_force(), 1e-9) << "the frames converged";
  for (const OrganFem::HeldPoint& h : fem.held_point_displacements(0))
    g.points.push_back({h.nodes, h.weights, h.displacement});
  g.problem.mesh = tet_mesh_of(m);
  g.problem.material = Material::from_young(law, m.material.young_modulus, m.material.poisson_ratio);
  g.problem.load_steps = 4;
  const Eigen::Vector3d fixed(m.fixed_points[0][0], m.fixed_points[0][1], m.fixed_points[0][2]);
  for (std::size_t n = 0; n < g.problem.mesh.nodes.size(); ++n)
    if ((g.problem.mesh.nodes[n] - fixed).norm() <= fixed_radius)
      g.problem.fixed.push_back(static_cast<std::int32_t>(n));
  g.displacements = fem.displacements();
  g.force_on_tool = fem.contact_force(0);
  return g;
}

/// CalculiX given the patch's held points on the same C3D4 mesh: every node
/// moves as in the engine model, and the points take the tool's force.
void expect_calculix_agrees(const GraspedPatch& g, const std::string& label) {
  calculix::Solution reference;
  try {
    reference = calculix::solve(g.problem, "patch", g.points);
  } catch (const std::exception& e) {
    FAIL() << label << ": " << e.what();
  }
  const double difference = relative_difference(g.displacements, reference.displacements);
  // The tool pulls the organ with the force CalculiX's held points take.
  const double force_difference = (g.force_on_tool + reference.point_force).norm() / reference.point_force.norm();
  std::printf(
      "%s, a patch on %zu nodes: largest difference / largest displacement %.3g; force %.4f N, "
      "CalculiX %.4f N, difference %.3g\n",
      label.c_str(), g.points.empty() ? std::size_t{0} : g.points[0].nodes.size(), difference, g.force_on_tool.norm(),
      reference.point_force.norm(), force_difference);
  EXPECT_LT(difference, 1e-4) << label;
  EXPECT_LT(force_difference, 1e-4) << label;
}

// A grasp is the prescribed displacement of the patch it holds: a 10 mm tip
// bites 5 mm into the helper cylinder's side near its clamp, closes and pulls
// 10 mm out and 5 mm along; CalculiX, given the patch (its mean tied to its
// nodes by their area weights), agrees, small strain and large.
TEST(CalculiX, AGraspedPatchPulledOutIsThePrescribedDisplacementOfItsPoints) {
  testing::CylinderSpec spec;
  spec.segments = 48;
  spec.rings = 24;
  spec.stations = 2;
  spec.section_polygon_vertices = 32;
  const model::OrganModel m = testing::make_cylinder_model(spec);
  for (const MaterialModel law : {MaterialModel::linear, MaterialModel::stvk}) {
    const GraspedPatch g =
        grasp_patch(m, law, 0.031, {0.05, 0.03, 0.0}, Eigen::Vector3d::UnitY(), 0.010, 0.005, {0.005, 0.010, 0.0});
    ASSERT_EQ(g.points.size(), 1u) << "closed jaws hold one patch";
    EXPECT_GE(g.points[0].nodes.size(), 6u) << "a patch, not a point";
    double weight = 0.0;
    for (double w : g.points[0].weights) weight += w;
    EXPECT_NEAR(weight, 1.0, 1e-12) << "the patch's area weights";
    expect_calculix_agrees(g, law == MaterialModel::linear ? "cylinder, linear" : "cylinder, stvk");
  }
}

// The same on the liver baked from the shipped CT (15,780 tetrahedra): a 6 mm
// tip bites 4 mm into the surface and pulls the patch 10 mm out along the
// normal, at the first of the surface points 40, 60, … mm from the clamp where
// its patch spreads over more than one face's nodes (the linear material:
// ccx's large-strain solve of the liver takes minutes).
TEST(CalculiX, AGraspedPatchOfTheShippedLiverIsThePrescribedDisplacementOfItsPoints) {
  const std::filesystem::path model_path =
      std::filesystem::temp_directory_path() / ("organsim_ccx_liver_" + std::to_string(::getpid()) + ".organ");
  const std::string samples = ORGANSIM_DATA_SAMPLES;
  const std::string bake = std::string(ORGANSIM_EXECUTABLE) + " bake " + samples +
                           "/real_ct_totalseg/example_ct.nii.gz --label " + samples +
                           "/real_ct_totalseg/liver_mask_ct.nii.gz -o " + model_path.string() + " --quiet";
  ASSERT_EQ(std::system(bake.c_str()), 0) << bake;
  model::ModelReadResult read = model::read_organ_model_file(model_path.string());
  std::filesystem::remove(model_path);
  ASSERT_TRUE(read) << read.error;
  const model::OrganModel& m = *read.model;
  const organ::Organ organ(m);
  const Eigen::Vector3d fixed(m.fixed_points[0][0], m.fixed_points[0][1], m.fixed_points[0][2]);
  // The first of a few surface points, farther and farther from the clamp,
  // where the tip takes in a patch.
  GraspedPatch g;
  for (const double distance : {0.04, 0.06, 0.08, 0.10, 0.12}) {
    auto off = [&](std::size_t v) {
      const auto& p = organ.model().surface_vertices[v];
      return std::abs((Eigen::Vector3d(p[0], p[1], p[2]) - fixed).norm() - distance);
    };
    std::size_t chosen = 0;
    for (std::size_t v = 1; v < organ.vertex_count(); ++v)
      if (off(v) < off(chosen)) chosen = v;
    const auto& p = organ.model().surface_vertices[chosen];
    const Eigen::Vector3d site(p[0], p[1], p[2]);
    const Eigen::Vector3d normal = organ.rest_normal_at(organ.surface_tree().closest_point(site));
    g = grasp_patch(m, MaterialModel::linear, 0.010, site, normal, 0.006, 0.004, 0.010 * normal);
    const std::size_t nodes = g.points.empty() ? 0 : g.points[0].nodes.size();
    std::printf("%.0f mm from the clamp: a patch on %zu nodes\n", distance * 1e3, nodes);
    if (nodes > 3) break;
  }
  ASSERT_EQ(g.points.size(), 1u) << "closed jaws hold one patch";
  EXPECT_GT(g.points[0].nodes.size(), 3u) << "a patch, not a point";
  expect_calculix_agrees(g, "shipped liver, linear");
}

}  // namespace
}  // namespace organsim::fem
