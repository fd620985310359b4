// The FEM reference's site compliances (pipeline/site_compliance.h): a bar
// clamped at one end gives under its free end what a cantilever gives, and
// resting on a foundation what Hetényi's beam on an elastic foundation gives, the
// patch's own indentation is taken off, the result does not depend on the
// threads, and the surface's curvatures are those of known shapes.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include <Eigen/Eigenvalues>

#include "beam_on_foundation.h"
#include "organsim/fem/tet_mesh.h"
#include "organsim/geometry/tetrahedral_embedding.h"
#include "organsim/model/model_file.h"
#include "organsim/organ_fem/organ_fem.h"
#include "organsim/pipeline/site_compliance.h"

namespace organsim::pipeline {
namespace {

/// A square bar [0, length] × [0, side]² meshed by `across` cubes per side
/// (six tetrahedra each), held at the centre of its x = 0 end; its surface is
/// the tetrahedra's boundary.
model::OrganModel bar(double length, double side, int across) {
  const int along = static_cast<int>(std::lround(length / side * across));
  const fem::TetMesh mesh = fem::box_mesh(Eigen::Vector3i(along, across, across), Eigen::Vector3d(length, side, side));
  model::OrganModel m;
  for (const Eigen::Vector3d& p : mesh.nodes) m.volume_vertices.push_back({p[0], p[1], p[2]});
  for (const auto& t : mesh.tetrahedra)
    m.tetrahedra.push_back({static_cast<std::uint32_t>(t[0]), static_cast<std::uint32_t>(t[1]),
                            static_cast<std::uint32_t>(t[2]), static_cast<std::uint32_t>(t[3])});
  // The surface: the boundary faces on the boundary nodes, renumbered.
  std::vector<std::int64_t> surface_index(mesh.nodes.size(), -1);
  for (const model::Triangle& f : geometry::tetrahedral_boundary(m.tetrahedra).faces) {
    model::Triangle t;
    for (int k = 0; k < 3; ++k) {
      if (surface_index[f[k]] < 0) {
        surface_index[f[k]] = static_cast<std::int64_t>(m.surface_vertices.size());
        m.surface_vertices.push_back(m.volume_vertices[f[k]]);
      }
      t[k] = static_cast<std::uint32_t>(surface_index[f[k]]);
    }
    m.surface_triangles.push_back(t);
  }
  m.fixed_points = {{0.0, side / 2, side / 2}};
  m.material = model::liver_default_material();
  return m;
}

std::size_t nearest_vertex(const model::OrganModel& m, const Eigen::Vector3d& at) {
  std::size_t best = 0;
  for (std::size_t v = 1; v < m.surface_vertices.size(); ++v)
    if ((Eigen::Vector3d(m.surface_vertices[v].data()) - at).norm() <
        (Eigen::Vector3d(m.surface_vertices[best].data()) - at).norm())
      best = v;
  return best;
}

/// The cantilever's compliance under a force at `load` from its held end
/// (m/N): bending and Timoshenko shear (κ = 5/6), E and ν of the reference.
double cantilever(double load, double side, double young, double nu) {
  const double shear = young / (2 * (1 + nu)), area = side * side, second_moment = std::pow(side, 4) / 12.0;
  return std::pow(load, 3) / (3 * young * second_moment) + load / (5.0 / 6.0 * shear * area);
}

// The bar's end pressed down on its top face: the site compliance is the
// cantilever's (measured: 1.23 of it with 4 cubes across, 1.056 with 6; the
// clamp is a ball of nodes around the end's centre, a little softer than a
// built-in end), sideways the same, along the bar nearly nothing, and the
// end's turn couples the press to the face's motion along the bar (1.10 of
// the beam's with 4 cubes across, 1.12 with 6).
TEST(SiteCompliance, ABarClampedAtOneEndGivesUnderItsFreeEndWhatACantileverGives) {
  constexpr double kLength = 0.20, kSide = 0.02;  // m
  double coarse_ratio = 0.0;
  for (int across : {4, 6}) {
    const model::OrganModel m = bar(kLength, kSide, across);
    SiteComplianceOptions o;
    o.fixed_radius = 0.75 * kSide;
    SiteComplianceReport report;
    const model::SiteCompliance sites = compute_site_compliance(m, o, &report);
    ASSERT_EQ(sites.compliance.size(), m.surface_vertices.size());
    EXPECT_EQ(sites.young_modulus, m.material.young_modulus);
    EXPECT_EQ(sites.poisson_ratio, o.poisson_ratio);
    const double load = kLength - 0.5 * kSide;  // the patch's centre
    const std::array<double, 6>& c = sites.compliance[nearest_vertex(m, {load, kSide / 2, kSide})];
    const double ratio = c[2] / cantilever(load, kSide, m.material.young_modulus, o.poisson_ratio);
    if (across == 4) {
      EXPECT_NEAR(ratio, 1.0, 0.3);
      coarse_ratio = ratio;
    } else {
      EXPECT_NEAR(ratio, 1.0, 0.1);
      EXPECT_LT(std::abs(ratio - 1.0), std::abs(coarse_ratio - 1.0));  // refinement approaches the beam
    }
    EXPECT_NEAR(c[1] / c[2], 1.0, 0.02);  // the square section bends alike both ways
    EXPECT_LT(c[0], 0.02 * c[2]);         // stretching the bar: far stiffer
    // Pressing the top face down turns the end: the face moves along the
    // bar by its distance from the axis times the slope, F (a/2) L²/(2 E I).
    const double turning = 0.5 * kSide * load * load / (2 * m.material.young_modulus * std::pow(kSide, 4) / 12.0);
    EXPECT_NEAR(std::abs(c[4]) / turning, 1.0, 0.25);
    EXPECT_LT(std::abs(c[3]) + std::abs(c[5]), 0.1 * c[2]);  // the mesh's asymmetry only
  }
}

// Near the clamp the organ hardly gives: the compliance there is a small
// fraction of the free end's, and the patch's own indentation, taken off,
// leaves no negative direction behind.
TEST(SiteCompliance, TheClampHoldsAndNoDirectionIsNegative) {
  constexpr double kLength = 0.20, kSide = 0.02;
  const model::OrganModel m = bar(kLength, kSide, 4);
  SiteComplianceOptions o;
  o.fixed_radius = 0.75 * kSide;
  const model::SiteCompliance sites = compute_site_compliance(m, o);
  const double near = sites.compliance[nearest_vertex(m, {0.02, kSide / 2, kSide})][2];
  const double far = sites.compliance[nearest_vertex(m, {kLength - 0.01, kSide / 2, kSide})][2];
  EXPECT_LT(near, 0.01 * far);
  for (const std::array<double, 6>& c : sites.compliance) {
    Eigen::Matrix3d matrix;
    matrix << c[0], c[3], c[4], c[3], c[1], c[5], c[4], c[5], c[2];
    EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(matrix).eigenvalues().minCoeff(), -1e-12 * matrix.norm());
  }
  // The bar's faces are flat: away from its edges no curvature.
  ASSERT_EQ(sites.curvature.size(), m.surface_vertices.size());
  const std::array<double, 2> mid_face = sites.curvature[nearest_vertex(m, {kLength / 2, kSide / 2, kSide})];
  EXPECT_NEAR(mid_face[0], 0.0, 1e-6);
  EXPECT_NEAR(mid_face[1], 0.0, 1e-6);
  model::OrganModel with = m;
  with.sites = sites;
  EXPECT_EQ(model::validate_organ_model(with), "");
}

// The bar resting along its lower face on a Winkler foundation (contacts,
// pushed into by the press from above): under its free end it gives what
// Hetényi's built-in beam on that foundation gives (measured: 0.94 of it
// with 6 cubes across), a sixth of what it gives held
// by its clamp alone; everywhere the supports only stiffen it (C_clamp −
// C_supported is positive semi-definite); a model without supports gets no
// second set.
TEST(SiteCompliance, ABarOnAFoundationGivesUnderItsFreeEndWhatHetenyisBeamGives) {
  constexpr double kLength = 0.20, kSide = 0.02;  // m
  model::OrganModel m = bar(kLength, kSide, 6);
  SiteComplianceOptions o;
  o.fixed_radius = 0.75 * kSide;
  EXPECT_TRUE(compute_site_compliance(m, o).supported.empty());

  // A foundation whose λL is 2: it carries the bar's far half.
  const double young = m.material.young_modulus, ei = young * std::pow(kSide, 4) / 12.0;
  const double per_length = 4 * ei * std::pow(2.0 / kLength, 4);  // N/m²
  for (const model::Point3& p : m.surface_vertices)
    m.supports.vertices.push_back(p[2] < 1e-9 ? std::array<double, 2>{1.0, per_length / kSide}
                                              : std::array<double, 2>{0.0, 0.0});
  // The foundation the mesh carries: its nodes' springs per length of bar
  // (the nodes on the lower edges also count their side faces' area).
  double carried = 0.0;
  for (const fem::FoundationSpring& spring :
       fem::foundation_springs(m, fem::clamped_dofs(m, o.fixed_radius), geometry::tetrahedral_boundary(m.tetrahedra)))
    carried += spring.stiffness;
  carried /= kLength;
  EXPECT_NEAR(carried / per_length, 1.0, 0.25);

  const model::SiteCompliance sites = compute_site_compliance(m, o);
  ASSERT_EQ(sites.supported.size(), m.surface_vertices.size());
  m.sites = sites;
  EXPECT_EQ(model::validate_organ_model(m), "");
  const double load = kLength - 0.5 * kSide;
  const std::size_t end = nearest_vertex(m, {load, kSide / 2, kSide});
  // The closed form's limit without a foundation: the cantilever.
  EXPECT_NEAR(testing::hetenyi_deflection(load, load, ei, 1e-9) / (std::pow(load, 3) / (3 * ei)), 1.0, 1e-6);
  const double expected = testing::hetenyi_deflection(load, load, ei, carried);
  EXPECT_NEAR(sites.supported[end][2] / expected, 1.0, 0.12);
  EXPECT_LT(sites.supported[end][2], 0.25 * sites.compliance[end][2]);
  auto unpacked = [](const std::array<double, 6>& c) {
    Eigen::Matrix3d matrix;
    matrix << c[0], c[3], c[4], c[3], c[1], c[5], c[4], c[5], c[2];
    return matrix;
  };
  // At the clamp both are the noise of the patch's indentation taken off
  // (and clipped at zero), below 10⁻⁵ of the free end's.
  const double scale = unpacked(sites.compliance[end]).norm();
  for (std::size_t v = 0; v < m.surface_vertices.size(); ++v) {
    const Eigen::Matrix3d difference = unpacked(sites.compliance[v]) - unpacked(sites.supported[v]);
    EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(difference).eigenvalues().minCoeff(), -1e-5 * scale)
        << "vertex " << v;
  }
}

// A contact holds only while pressed. A bar clamped at one end with contacts
// along its top face: a press down on its top bends it away from every one
// of them, so with the contacts settled its free end gives exactly what it
// gives held by its clamp alone (the Woodbury identity on the released
// contacts), where taking them all as pressed makes it several times firmer.
// A press up from below pushes it into the contacts near the press, and
// further along, where a beam on a foundation this stiff (λL ≈ 6.6) swings
// back, lifts a few: settled, a little softer than two-way and still well
// held. Everywhere the settled compliance lies between the two-way one and the
// clamp's (to the clipping of the patch's indentation, 10⁻⁴), and the result is
// the same whatever the threads.
TEST(SiteCompliance, AContactAPressLiftsCarriesNothing) {
  constexpr double kLength = 0.10, kSide = 0.02;  // m
  model::OrganModel m = bar(kLength, kSide, 4);
  for (const model::Point3& p : m.surface_vertices)
    m.supports.vertices.push_back(p[2] > kSide - 1e-9 ? std::array<double, 2>{1.0, 2.5e5}
                                                      : std::array<double, 2>{0.0, 0.0});
  SiteComplianceOptions o;
  o.fixed_radius = 0.75 * kSide;
  const model::SiteCompliance two_way = compute_site_compliance(m, o);
  o.settle_contacts = true;
  o.threads = 1;
  const model::SiteCompliance settled = compute_site_compliance(m, o);
  o.threads = 2;
  EXPECT_TRUE(compute_site_compliance(m, o) == settled);

  const std::size_t top = nearest_vertex(m, {kLength - 0.005, kSide / 2, kSide});
  const std::size_t bottom = nearest_vertex(m, {kLength - 0.005, kSide / 2, 0.0});
  EXPECT_NEAR(settled.supported[top][2] / settled.compliance[top][2], 1.0, 1e-6);
  EXPECT_LT(two_way.supported[top][2], 0.5 * two_way.compliance[top][2]);
  EXPECT_GE(settled.supported[bottom][2] / two_way.supported[bottom][2], 1.0 - 1e-9);
  EXPECT_LT(settled.supported[bottom][2] / two_way.supported[bottom][2], 1.1);
  EXPECT_LT(settled.supported[bottom][2], 0.5 * settled.compliance[bottom][2]);
  auto unpacked = [](const std::array<double, 6>& c) {
    Eigen::Matrix3d matrix;
    matrix << c[0], c[3], c[4], c[3], c[1], c[5], c[4], c[5], c[2];
    return matrix;
  };
  auto least = [](const Eigen::Matrix3d& c) {
    return Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(c).eigenvalues()[0];
  };
  const double scale = unpacked(settled.compliance[top]).norm();
  for (std::size_t v = 0; v < m.surface_vertices.size(); ++v) {
    EXPECT_GE(least(unpacked(settled.supported[v]) - unpacked(two_way.supported[v])), -1e-4 * scale) << "vertex " << v;
    EXPECT_GE(least(unpacked(settled.compliance[v]) - unpacked(settled.supported[v])), -1e-4 * scale) << "vertex " << v;
  }
}

// A press that releases some contacts and is held by others: the bar with a
// stiff foundation along its top and a soft one (λL = 1.5, so that the bar
// bends the same way all along) under its far half, pressed down at its free
// end, lifts off every top contact and presses every bottom one; settled, it
// gives what the bar on the bottom foundation alone gives two-way. More
// contacts are released than held, so the set is solved through the held
// ones (the Schur complement).
TEST(SiteCompliance, ASettledPressGivesTheCompliancesOfTheContactsThatHoldIt) {
  constexpr double kLength = 0.10, kSide = 0.02;  // m
  const model::OrganModel plain = bar(kLength, kSide, 4);
  const double young = plain.material.young_modulus, ei = young * std::pow(kSide, 4) / 12.0;
  const double soft = 4 * ei * std::pow(1.5 / kLength, 4) / kSide;  // Pa/m
  auto on_foundations = [&](bool top) {
    model::OrganModel m = plain;
    for (const model::Point3& p : m.surface_vertices)
      if (top && p[2] > kSide - 1e-9)
        m.supports.vertices.push_back({1.0, 2.5e5});
      else if (p[2] < 1e-9 && p[0] > kLength / 2)
        m.supports.vertices.push_back({1.0, soft});
      else
        m.supports.vertices.push_back({0.0, 0.0});
    return m;
  };
  SiteComplianceOptions o;
  o.fixed_radius = 0.75 * kSide;
  const model::SiteCompliance bottom_only = compute_site_compliance(on_foundations(false), o);
  const model::SiteCompliance two_way = compute_site_compliance(on_foundations(true), o);
  o.settle_contacts = true;
  const model::SiteCompliance settled = compute_site_compliance(on_foundations(true), o);
  const std::size_t end = nearest_vertex(plain, {kLength - 0.005, kSide / 2, kSide});
  auto norm = [](const std::array<double, 6>& c) {
    double sum = 0.0;
    for (double x : c) sum += x * x;
    return std::sqrt(sum);
  };
  std::array<double, 6> difference;
  for (int k = 0; k < 6; ++k) difference[k] = settled.supported[end][k] - bottom_only.supported[end][k];
  EXPECT_LT(norm(difference), 1e-6 * norm(bottom_only.supported[end]));
  EXPECT_LT(two_way.supported[end][2], 0.5 * settled.supported[end][2]);
  EXPECT_LT(settled.supported[end][2], 0.9 * settled.compliance[end][2]);
}

TEST(SiteCompliance, TheSameWhateverTheThreads) {
  const model::OrganModel m = bar(0.1, 0.02, 4);
  SiteComplianceOptions o;
  o.fixed_radius = 0.015;
  o.threads = 1;
  const model::SiteCompliance one = compute_site_compliance(m, o);
  o.threads = 2;
  EXPECT_TRUE(compute_site_compliance(m, o) == one);
}

/// The height field z = f(x, y) on a square grid of `step` (m) over
/// [−half, half]², triangulated counter-clockwise seen from +z (the outward
/// normal +z, as on an organ's top).
model::OrganModel height_field(double half, double step, const std::function<double(double, double)>& f) {
  model::OrganModel m;
  const int n = static_cast<int>(std::lround(2 * half / step)) + 1;
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const double x = -half + i * step, y = -half + j * step;
      m.surface_vertices.push_back({x, y, f(x, y)});
    }
  auto at = [n](int i, int j) { return static_cast<std::uint32_t>(j * n + i); };
  for (int j = 0; j + 1 < n; ++j)
    for (int i = 0; i + 1 < n; ++i) {
      m.surface_triangles.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1)});
      m.surface_triangles.push_back({at(i, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  return m;
}

// A sphere's outside is convex, 1/r both ways, wherever the vertex lies on it
// (the sloped ones need the graph's first fundamental form); a saddle's
// apex has its two curvatures with their signs; a plane has none.
TEST(SiteCompliance, TheSurfacesCurvaturesAreThoseOfKnownShapes) {
  constexpr double kFit = 0.005, kStep = 0.001, kHalf = 0.015;
  const double r = 0.02;
  const model::OrganModel cap =
      height_field(kHalf, kStep, [&](double x, double y) { return std::sqrt(r * r - x * x - y * y) - r; });
  const std::vector<std::array<double, 2>> sphere = site_curvatures(cap, kFit);
  ASSERT_EQ(sphere.size(), cap.surface_vertices.size());
  int inside = 0;
  for (std::size_t v = 0; v < sphere.size(); ++v) {
    const model::Point3& p = cap.surface_vertices[v];
    if (std::max(std::abs(p[0]), std::abs(p[1])) > kHalf - kFit - 1e-9) continue;  // its fit is one-sided
    ++inside;
    EXPECT_NEAR(sphere[v][0], 1 / r, 0.02 / r) << v;
    EXPECT_NEAR(sphere[v][1], 1 / r, 0.02 / r) << v;
  }
  EXPECT_GT(inside, 300);

  const model::OrganModel saddle =
      height_field(kHalf, kStep, [](double x, double y) { return -x * x / (2 * 0.01) + y * y / (2 * 0.04); });
  const std::array<double, 2> apex = site_curvatures(saddle, kFit)[saddle.surface_vertices.size() / 2];
  EXPECT_NEAR(apex[0], 100.0, 1.0);  // convex along x (radius 10 mm)
  EXPECT_NEAR(apex[1], -25.0, 0.5);  // concave along y (radius 40 mm)

  const model::OrganModel plane = height_field(kHalf, kStep, [](double x, double y) { return 0.3 * x - 0.2 * y; });
  for (const std::array<double, 2>& k : site_curvatures(plane, kFit)) {
    EXPECT_NEAR(k[0], 0.0, 1e-6);
    EXPECT_NEAR(k[1], 0.0, 1e-6);
  }
  // Fewer neighbours than the quadric's five unknowns: taken as flat.
  for (const std::array<double, 2>& k : site_curvatures(cap, 1.2 * kStep))
    EXPECT_EQ(k, (std::array<double, 2>{0.0, 0.0}));
  EXPECT_THROW(site_curvatures(cap, 0.0), std::invalid_argument);
  EXPECT_THROW(site_curvatures(cap, std::nan("")), std::invalid_argument);
}

TEST(SiteCompliance, RefusesWhatItCannotUse) {
  model::OrganModel m = bar(0.1, 0.02, 2);
  SiteComplianceOptions o;
  o.fixed_radius = 0.001;  // holds no three nodes
  EXPECT_THROW(compute_site_compliance(m, o), std::invalid_argument);
  o.fixed_radius = 0.015;
  o.poisson_ratio = 0.5;
  EXPECT_THROW(compute_site_compliance(m, o), std::invalid_argument);
  o.poisson_ratio = 0.49;
  m.tetrahedra.clear();
  EXPECT_THROW(compute_site_compliance(m, o), std::invalid_argument);
}

}  // namespace
}  // namespace organsim::pipeline
