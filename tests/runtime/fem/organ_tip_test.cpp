// A tool tip of finite size on the FEM models (fem/organ_fem.h): on a block
// whose mesh is refined under the tip, its force converges, where a point
// tool's falls with the cells' size (it has no finite indentation
// stiffness); the tip takes in the boundary points it meets and lets go of
// them when pulled back. The block (60 × 60 × 60 mm, E 5 kPa, ν 0.3: P1
// tetrahedra free of locking) is held by a ball of nodes around its bottom
// centre, the tip (R = 2.5 mm, a laparoscopic probe's 5 mm end) pressed 1 mm
// into the middle of its top face, 0.25 mm per load step.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "organsim/fem_direct/direct_factorizations.h"
#include "organsim/organ_fem/organ_fem.h"
#include "organsim/fem/tet_mesh.h"
#include "organsim/geometry/tetrahedral_embedding.h"

namespace organsim::fem {
namespace {

constexpr double kHalfWidth = 0.03, kDepth = 0.06;  // m
constexpr double kRadius = 2.5e-3;                  // m
constexpr double kPress = 1e-3;                     // m

// Planes from 0 to `length`: `fine` apart up to `uniform`, then each cell
// 1.3 times the last (m).
std::vector<double> graded(double fine, double uniform, double length) {
  std::vector<double> planes{0.0};
  double cell = fine;
  while (planes.back() < length - 1e-12) {
    if (planes.back() >= uniform - 1e-12) cell *= 1.3;
    planes.push_back(std::min(planes.back() + cell, length));
    if (length - planes.back() < 0.5 * cell) planes.back() = length;
  }
  return planes;
}

std::vector<double> mirrored(const std::vector<double>& half) {
  std::vector<double> planes;
  for (auto it = half.rbegin(); it != half.rend(); ++it) planes.push_back(-*it);
  planes.insert(planes.end(), half.begin() + 1, half.end());
  return planes;
}

// The block as a model file would hold it: its tetrahedra, and its boundary
// as the surface; cells of `fine` within 6 mm of the top face's centre.
model::OrganModel block(double fine) {
  const std::vector<double> across = mirrored(graded(fine, 0.006, kHalfWidth));
  std::vector<double> depth;
  for (double z : graded(fine, 0.006, kDepth)) depth.insert(depth.begin(), -z);
  const TetMesh mesh = box_mesh(across, across, depth);
  model::OrganModel m;
  for (const Eigen::Vector3d& x : mesh.nodes) m.volume_vertices.push_back({x[0], x[1], x[2]});
  for (const auto& t : mesh.tetrahedra)
    m.tetrahedra.push_back({static_cast<std::uint32_t>(t[0]), static_cast<std::uint32_t>(t[1]),
                            static_cast<std::uint32_t>(t[2]), static_cast<std::uint32_t>(t[3])});
  const geometry::TetrahedralBoundary boundary = geometry::tetrahedral_boundary(m.tetrahedra);
  std::map<std::uint32_t, std::uint32_t> renumbered;
  for (const model::Triangle& face : boundary.faces) {
    model::Triangle t;
    for (std::size_t i = 0; i < 3; ++i) {
      const auto [it, added] = renumbered.emplace(face[i], static_cast<std::uint32_t>(m.surface_vertices.size()));
      if (added) m.surface_vertices.push_back(m.volume_vertices[face[i]]);
      t[i] = it->second;
    }
    m.surface_triangles.push_back(t);
  }
  m.fixed_points.push_back({0.0, 0.0, -kDepth});
  m.material.young_modulus = 5000.0;
  m.material.poisson_ratio = 0.3;
  return m;
}

OrganFemOptions options() {
  OrganFemOptions o;
  o.fixed_radius = 0.043;  // the bottom face and the sides' lower half
  o.factorization = [](MatrixKind, SolveUse) { return make_cholmod_factorization(); };
  o.realtime_solves = false;
  o.max_contact_nodes = 160;
  return o;
}

// Presses the top face's centre to `press` (m, along −z) in load steps of
// 0.25 mm, each solved until the contact settles; the force on the tool (N,
// +z pushes it back).
double press_block(OrganFem& fem, const geometry::ToolTip& tip, double press) {
  EXPECT_TRUE(fem.attach(0, Eigen::Vector3d::Zero(), tip));
  const int steps = std::max(1, static_cast<int>(std::ceil(press / 0.25e-3 - 1e-9)));
  for (int s = 1; s <= steps; ++s) {
    const Eigen::Vector3d d(0.0, 0.0, -press * s / steps);
    int frames = 0;
    do {
      EXPECT_EQ(fem.step(&d), FrameStatus::ok);
    } while (!fem.contact_settled() && ++frames < 40);
    EXPECT_TRUE(fem.contact_settled()) << "load step " << s;
  }
  return fem.contact_force(0).z();
}

geometry::ToolTip probe(double radius) {
  geometry::ToolTip tip;
  tip.radius = radius;
  tip.axis = Eigen::Vector3d::UnitZ();
  return tip;
}

// Cells of R/2, R/3 and R/4.5 under the tip: the tip's force falls towards
// Hertz's (18.4, 14.4, 11.9 mN; Hertz's frictionless half-space 11.6 mN),
// each change smaller than the one before (−22 %, −18 %), while the point
// tool's force falls in proportion to the cells' size (7.0, 4.6, 3.1 mN): it
// has no limit.
TEST(OrganFemTip, FiniteTipForceConvergesUnderRefinementWhileAPointToolsFalls) {
  std::vector<double> tip, point;
  for (const double cells_per_radius : {2.0, 3.0, 4.5}) {
    const model::OrganModel m = block(kRadius / cells_per_radius);
    {
      OrganFem fem(m, MaterialModel::linear, options(), 1);
      tip.push_back(press_block(fem, probe(kRadius), kPress));
      EXPECT_GT(fem.held_points(0), 3u) << "the tip holds a patch, not a point";
      EXPECT_EQ(fem.hold_overflows(), 0u);
    }
    OrganFem fem(m, MaterialModel::linear, options(), 1);
    point.push_back(press_block(fem, probe(0.0), kPress));
    const std::string at = std::to_string(static_cast<int>(10 * cells_per_radius));
    RecordProperty("tip_force_mN_" + at, std::to_string(tip.back() * 1e3));
    RecordProperty("point_force_mN_" + at, std::to_string(point.back() * 1e3));
  }
  for (std::size_t k = 0; k < tip.size(); ++k) {
    EXPECT_GT(tip[k], 0.0);
    EXPECT_GT(tip[k], 2.0 * point[k]) << "a 5 mm probe is stiffer than a point";
  }
  EXPECT_LT(tip[1], tip[0]);
  EXPECT_LT(tip[2], tip[1]);
  EXPECT_LT(tip[1] - tip[2], tip[0] - tip[1]) << "the changes shrink: the force converges";
  const double e_star = 5000.0 / (1.0 - 0.3 * 0.3);
  const double hertz = 4.0 / 3.0 * e_star * std::sqrt(kRadius) * std::pow(kPress, 1.5);
  RecordProperty("finest_over_hertz", std::to_string(tip[2] / hertz));
  EXPECT_NEAR(tip[2] / hertz, 1.0, 0.1);
  EXPECT_LT(point[1], 0.8 * point[0]);
  EXPECT_LT(point[2], 0.8 * point[1]);
}

// Pulled back to the surface, the tip lets go of every point it took in (they
// would pull on the organ); the first touch stays held until the engine ends
// the contact, where the organ is back at rest and nothing is felt.
TEST(OrganFemTip, PulledBackTheTipLetsGoOfWhatItTookIn) {
  const model::OrganModel m = block(kRadius / 2.0);
  OrganFem fem(m, MaterialModel::linear, options(), 1);
  ASSERT_GT(press_block(fem, probe(kRadius), kPress), 0.0);
  EXPECT_GT(fem.held_points(0), 3u);
  const Eigen::Vector3d back = Eigen::Vector3d::Zero();
  for (int frame = 0; frame < 10 && !(fem.held_points(0) == 1 && fem.contact_settled()); ++frame)
    ASSERT_EQ(fem.step(&back), FrameStatus::ok);
  EXPECT_EQ(fem.held_points(0), 1u);
  EXPECT_LT(fem.contact_force(0).norm(), 1e-9);
  EXPECT_LT(fem.displacements().cwiseAbs().maxCoeff(), 1e-12) << "the block is back at rest";
}

}  // namespace
}  // namespace organsim::fem
