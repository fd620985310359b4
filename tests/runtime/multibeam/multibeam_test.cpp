// The multi-beam model on organs with known geometry: analytic beam forces,
// the space distortion, merging of several tools, the beam on its supports,
// and bad input.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <random>

#include <gtest/gtest.h>

#include "organsim/multibeam/multibeam.h"
#include "test_models.h"

namespace organsim::multibeam {
namespace {

constexpr double kPi = 3.14159265358979323846;
// The distortion runs in single precision (docs/multibeam.md): displacements
// come out within 10⁻⁶ of themselves plus 10 nm.
constexpr double kDistortionRelative = 1e-6;
constexpr double kDistortionAbsolute = 1e-8;  // m
double distortion_tolerance(double displacement) { return kDistortionRelative * displacement + kDistortionAbsolute; }

Eigen::Vector3d vec(const model::Point3& p) { return {p[0], p[1], p[2]}; }

std::uint32_t nearest_vertex(const model::OrganModel& model, const Eigen::Vector3d& p) {
  std::uint32_t best = 0;
  for (std::uint32_t v = 0; v < model.surface_vertices.size(); ++v)
    if ((vec(model.surface_vertices[v]) - p).norm() < (vec(model.surface_vertices[best]) - p).norm()) best = v;
  return best;
}

struct CylinderOrgan : ::testing::Test {
  testing::CylinderSpec spec;
  organ::Organ organ{testing::make_cylinder_model(spec)};
  std::vector<model::Point3> positions = std::vector<model::Point3>(organ.vertex_count());
  std::vector<model::Point3> normals = std::vector<model::Point3>(organ.vertex_count());
  Eigen::Vector3d far_cap_centre{spec.length, 0.0, 0.0};
};

TEST_F(CylinderOrgan, PressAtTheFarCapGivesTheCantileverForces) {
  MultiBeam beams(organ, {});
  ASSERT_EQ(beams.attach(0, far_cap_centre + Eigen::Vector3d(0.002, 0.0, 0.0)), Status::ok);  // snapped onto the cap
  EXPECT_NEAR(beams.beam(0).length, spec.length, 1e-12);
  const model::Material& m = organ.model().material;
  const double area = kPi * spec.radius * spec.radius, inertia = kPi * std::pow(spec.radius, 4) / 4.0;
  const double delta = 0.005;

  Eigen::Vector3d force;
  ASSERT_EQ(beams.force(0, {0.0, delta, 0.0}, force), Status::ok);
  const double transverse = 3.0 * m.young_modulus * inertia * delta / std::pow(spec.length, 3);
  EXPECT_NEAR(force[1], -transverse, 1e-3 * transverse);  // the organ pushes back
  EXPECT_NEAR(force[0], 0.0, 1e-6 * transverse);
  EXPECT_NEAR(force[2], 0.0, 1e-6 * transverse);

  ASSERT_EQ(beams.force(0, {-delta, 0.0, 0.0}, force), Status::ok);
  const double axial = m.young_modulus * area * delta / spec.length;
  EXPECT_NEAR(force[0], axial, 1e-3 * axial);

  // Timoshenko: softer by the shear compliance L/(κGA).
  MultiBeamOptions timoshenko;
  timoshenko.beam.theory = BeamTheory::timoshenko;
  MultiBeam shear(organ, timoshenko);
  ASSERT_EQ(shear.attach(0, far_cap_centre), Status::ok);
  ASSERT_EQ(shear.force(0, {0.0, delta, 0.0}, force), Status::ok);
  const BeamElasticity el = BeamElasticity::from(m.young_modulus, m.poisson_ratio);
  const double compliance = std::pow(spec.length, 3) / (3.0 * m.young_modulus * inertia) +
                            spec.length / (el.shear_coefficient * el.shear_modulus * area);
  EXPECT_NEAR(-force[1], delta / compliance, 1e-3 * delta / compliance);
}

TEST_F(CylinderOrgan, ActionPointMovesExactlyByTheToolDisplacementAndTheClampStays) {
  MultiBeam beams(organ, {});
  ASSERT_EQ(beams.attach(0, far_cap_centre), Status::ok);
  const Eigen::Vector3d tip[1] = {{0.001, 0.004, -0.003}};
  ASSERT_EQ(beams.deform(tip, positions.data(), normals.data(), positions.size()), Status::ok);
  const std::uint32_t action = nearest_vertex(organ.model(), far_cap_centre);
  const std::uint32_t clamp = nearest_vertex(organ.model(), Eigen::Vector3d::Zero());
  EXPECT_LT((vec(positions[action]) - far_cap_centre - tip[0]).norm(), distortion_tolerance(tip[0].norm()));
  EXPECT_LT((vec(positions[clamp]) - vec(organ.model().surface_vertices[clamp])).norm(), 1e-15);
  // Every vertex moved less than the tip, and in the direction of the press.
  for (std::size_t v = 0; v < positions.size(); ++v) {
    const Eigen::Vector3d moved = vec(positions[v]) - vec(organ.model().surface_vertices[v]);
    EXPECT_LE(moved.norm(), tip[0].norm() + distortion_tolerance(tip[0].norm())) << v;
    EXPECT_GE(moved.dot(tip[0]), -distortion_tolerance(tip[0].norm()) * tip[0].norm()) << v;
    EXPECT_NEAR(vec(normals[v]).norm(), 1.0, 1e-6) << v;  // normalized in single precision
  }
}

TEST_F(CylinderOrgan, ZeroDisplacementGivesZeroDeformationAndZeroForce) {
  MultiBeam beams(organ, {});
  ASSERT_EQ(beams.attach(0, far_cap_centre), Status::ok);
  ASSERT_EQ(beams.attach(1, {0.08, spec.radius, 0.0}), Status::ok);
  const Eigen::Vector3d tips[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  ASSERT_EQ(beams.deform(tips, positions.data(), normals.data(), positions.size()), Status::ok);
  for (std::size_t v = 0; v < positions.size(); ++v)
    EXPECT_EQ(vec(positions[v]), vec(organ.model().surface_vertices[v])) << v;
  Eigen::Vector3d force;
  ASSERT_EQ(beams.force(1, Eigen::Vector3d::Zero(), force), Status::ok);
  EXPECT_EQ(force, Eigen::Vector3d::Zero());
}

TEST_F(CylinderOrgan, AttenuationScalesEachDisplacementByAlphaToTheMinusBetaD) {
  model::OrganModel unattenuated_model = testing::make_cylinder_model(spec);
  unattenuated_model.material.attenuation_beta = 0.0;
  const organ::Organ unattenuated(std::move(unattenuated_model));
  MultiBeam with(organ, {}), without(unattenuated, {});
  ASSERT_EQ(with.attach(0, far_cap_centre), Status::ok);
  ASSERT_EQ(without.attach(0, far_cap_centre), Status::ok);
  const Eigen::Vector3d tip[1] = {{0.0, 0.005, 0.0}};
  std::vector<model::Point3> plain(positions.size());
  ASSERT_EQ(with.deform(tip, positions.data(), normals.data(), positions.size()), Status::ok);
  ASSERT_EQ(without.deform(tip, plain.data(), normals.data(), plain.size()), Status::ok);
  const model::Material& m = organ.model().material;
  std::vector<std::pair<double, double>> by_distance;  // (d, attenuation)
  for (std::size_t v = 0; v < positions.size(); ++v) {
    const Eigen::Vector3d rest = vec(organ.model().surface_vertices[v]);
    const Eigen::Vector3d attenuated = vec(positions[v]) - rest, full = vec(plain[v]) - rest;
    const double d = (rest - far_cap_centre).norm();
    const double expected = std::pow(m.attenuation_alpha, -m.attenuation_beta * d);
    EXPECT_LT((attenuated - expected * full).norm(), 2.0 * distortion_tolerance(full.norm())) << v;
    by_distance.emplace_back(d, expected);
  }
  std::sort(by_distance.begin(), by_distance.end());
  for (std::size_t i = 1; i < by_distance.size(); ++i) EXPECT_LE(by_distance[i].second, by_distance[i - 1].second);
}

TEST_F(CylinderOrgan, TwoToolsPullingApartDragEachOtherOnlyUnderSuperposition) {
  // The paper's Fig. 5: with u = Σ u_i each action point also follows the other
  // beam; with the influence function it moves exactly with its own tool.
  const std::uint32_t a = nearest_vertex(organ.model(), {0.0875, spec.radius, 0.0});
  const std::uint32_t b = nearest_vertex(organ.model(), {0.1375, spec.radius, 0.0});
  const Eigen::Vector3d pa = vec(organ.model().surface_vertices[a]), pb = vec(organ.model().surface_vertices[b]);
  const Eigen::Vector3d tips[2] = {{-0.004, 0.003, 0.0}, {0.004, 0.003, 0.0}};
  for (MergeRule rule : {MergeRule::sum, MergeRule::influence}) {
    MultiBeamOptions options;
    options.merge = rule;
    MultiBeam beams(organ, options);
    ASSERT_EQ(beams.attach(0, pa), Status::ok);
    ASSERT_EQ(beams.attach(1, pb), Status::ok);
    ASSERT_EQ(beams.deform(tips, positions.data(), normals.data(), positions.size()), Status::ok);
    const double error_a = (vec(positions[a]) - pa - tips[0]).norm();
    const double error_b = (vec(positions[b]) - pb - tips[1]).norm();
    if (rule == MergeRule::sum) {
      EXPECT_GT(error_a, 0.2 * tips[0].norm());
      EXPECT_GT(error_b, 0.2 * tips[1].norm());
    } else {
      EXPECT_LT(error_a, distortion_tolerance(tips[0].norm()));
      EXPECT_LT(error_b, distortion_tolerance(tips[1].norm()));
    }
  }
}

TEST_F(CylinderOrgan, DisplacementAtAnyPointIsTheDistortionOfTheSurfaceVertices) {
  // Three tools, both merge rules: the point-wise field (for interior nodes)
  // reproduces distort() at every surface vertex, and moves interior points
  // smoothly (the axis under a tool follows it, attenuated).
  const Eigen::Vector3d points[3] = {far_cap_centre, {0.0875, spec.radius, 0.0}, {0.1375, 0.0, -spec.radius}};
  const Eigen::Vector3d tips[3] = {{0.0, 0.004, 0.001}, {-0.002, -0.003, 0.0}, {0.001, 0.0, 0.003}};
  for (MergeRule rule : {MergeRule::sum, MergeRule::influence}) {
    MultiBeamOptions options;
    options.merge = rule;
    MultiBeam beams(organ, options);
    for (std::uint32_t i = 0; i < 3; ++i) ASSERT_EQ(beams.attach(i, points[i]), Status::ok);
    ASSERT_EQ(beams.deform(tips, positions.data(), normals.data(), positions.size()), Status::ok);
    double largest = 0.0;
    for (std::size_t v = 0; v < organ.vertex_count(); ++v) {
      const Eigen::Vector3d rest = vec(organ.model().surface_vertices[v]);
      const Eigen::Vector3d expected = vec(positions[v]) - rest;
      largest = std::max(largest, expected.norm());
      ASSERT_LT((beams.displacement_at(rest) - expected).norm(), distortion_tolerance(expected.norm())) << v;
    }
    EXPECT_GT(largest, 0.003);
    const Eigen::Vector3d inside = beams.displacement_at({0.12, 0.0, 0.0});
    EXPECT_TRUE(inside.allFinite());
    EXPECT_GT(inside.norm(), 1e-4);
  }
}

// On its supports the beam rests on its sections' rims: the cylinder lying
// along its lower half on contacts, pressed down at the far cap's top,
// pushes back harder than clamped alone, and its middle follows the press
// less; with the supports off, or a model without them, the beam is the
// clamped one.
TEST_F(CylinderOrgan, OnItsSupportsTheBeamRestsOnItsSectionsRims) {
  model::OrganModel supported_model = testing::make_cylinder_model(spec);
  for (const model::Point3& p : supported_model.surface_vertices)
    supported_model.supports.vertices.push_back(p[2] < -1e-9 ? std::array<double, 2>{1.0, 2.5e5}
                                                             : std::array<double, 2>{0.0, 0.0});
  const organ::Organ on_supports(supported_model);
  MultiBeamOptions options;
  options.supports = true;
  const Eigen::Vector3d top(spec.length, 0.0, spec.radius), press(0.0, 0.0, -0.004);
  MultiBeam supported(on_supports, options), clamped(organ, options), off(on_supports, {});
  for (MultiBeam* beams : {&supported, &clamped, &off}) ASSERT_EQ(beams->attach(0, top), Status::ok);
  Eigen::Vector3d force_supported, force_clamped, force_off;
  ASSERT_EQ(supported.force(0, press, force_supported), Status::ok);
  ASSERT_EQ(clamped.force(0, press, force_clamped), Status::ok);
  ASSERT_EQ(off.force(0, press, force_off), Status::ok);
  EXPECT_GT(force_supported.z(), 2.0 * force_clamped.z());
  EXPECT_LT((force_off - force_clamped).norm(), 1e-9 * force_clamped.norm());
  std::vector<model::Point3> on(on_supports.vertex_count());
  ASSERT_EQ(supported.deform(&press, on.data(), normals.data(), on.size()), Status::ok);
  ASSERT_EQ(clamped.deform(&press, positions.data(), normals.data(), positions.size()), Status::ok);
  const std::uint32_t middle = nearest_vertex(on_supports.model(), {spec.length / 2, 0.0, spec.radius});
  const double moved_supported = on[middle][2] - on_supports.model().surface_vertices[middle][2];
  const std::uint32_t same = nearest_vertex(organ.model(), {spec.length / 2, 0.0, spec.radius});
  const double moved_clamped = positions[same][2] - organ.model().surface_vertices[same][2];
  EXPECT_LT(moved_clamped, -1e-4);
  EXPECT_GT(moved_supported, 0.5 * moved_clamped);  // less far down
}

TEST_F(CylinderOrgan, CoincidingToolsAreMergedWithoutNaN) {
  MultiBeam beams(organ, {});
  ASSERT_EQ(beams.attach(0, far_cap_centre), Status::ok);
  ASSERT_EQ(beams.attach(1, far_cap_centre + Eigen::Vector3d(0.0, 1e-4, 0.0)), Status::ok);
  const Eigen::Vector3d tips[2] = {{0.0, 0.004, 0.0}, {0.0, 0.002, 0.0}};
  ASSERT_EQ(beams.deform(tips, positions.data(), normals.data(), positions.size()), Status::ok);
  for (const model::Point3& p : positions) ASSERT_TRUE(vec(p).allFinite());
  // The shared point moves by the mean of the two tools' fields there.
  const std::uint32_t action = nearest_vertex(organ.model(), far_cap_centre);
  const Eigen::Vector3d moved = vec(positions[action]) - far_cap_centre;
  EXPECT_NEAR(moved[1], 0.003, 2e-5);
}

TEST_F(CylinderOrgan, BadToolInputGivesAClearStatusAndNeverNaN) {
  MultiBeam beams(organ, {});
  const double nan = std::nan(""), inf = std::numeric_limits<double>::infinity();
  EXPECT_EQ(beams.attach(0, {nan, 0.0, 0.0}), Status::not_finite);
  EXPECT_EQ(beams.attach(0, {inf, 0.0, 0.0}), Status::not_finite);
  EXPECT_EQ(beams.attach(0, {0.5, 0.5, 0.5}), Status::far_from_organ);
  EXPECT_EQ(beams.attach(0, {0.0, 0.0, 0.0}), Status::at_fixed_point);  // the clamp is on the near cap
  EXPECT_EQ(beams.attach(7, far_cap_centre), Status::too_many_tools);
  EXPECT_FALSE(beams.beam(0).attached);
  Eigen::Vector3d force;
  EXPECT_EQ(beams.force(0, {0.0, 0.001, 0.0}, force), Status::no_contact);
  EXPECT_EQ(force, Eigen::Vector3d::Zero());

  ASSERT_EQ(beams.attach(0, far_cap_centre), Status::ok);
  EXPECT_EQ(beams.force(0, {nan, 0.0, 0.0}, force), Status::not_finite);
  EXPECT_EQ(force, Eigen::Vector3d::Zero());
  const Eigen::Vector3d bad[1] = {{0.0, inf, 0.0}};
  for (model::Point3& p : positions) p = {1.0, 2.0, 3.0};
  EXPECT_EQ(beams.deform(bad, positions.data(), normals.data(), positions.size()), Status::not_finite);
  for (const model::Point3& p : positions) ASSERT_EQ(vec(p), Eigen::Vector3d(1.0, 2.0, 3.0));  // untouched
  const Eigen::Vector3d good[1] = {{0.0, 0.001, 0.0}};
  EXPECT_EQ(beams.deform(good, positions.data(), normals.data(), positions.size() - 1), Status::buffer_too_small);
}

// Area-weighted vertex normals the plain way: each triangle's cross product
// added to its three corners.
std::vector<Eigen::Vector3d> reference_normals(const organ::Organ& organ, const std::vector<model::Point3>& positions) {
  std::vector<Eigen::Vector3d> sum(positions.size(), Eigen::Vector3d::Zero());
  for (const model::Triangle& t : organ.model().surface_triangles) {
    const Eigen::Vector3d a = vec(positions[t[0]]), b = vec(positions[t[1]]), c = vec(positions[t[2]]);
    const Eigen::Vector3d n = (b - a).cross(c - a);
    for (std::uint32_t v : t) sum[v] += n;
  }
  for (Eigen::Vector3d& n : sum) n.normalize();
  return sum;
}

TEST(Organ, VertexNormalsAreTheAreaWeightedTriangleNormals) {
  const organ::Organ sphere(testing::make_sphere_model(2400, 20));
  const std::size_t n = sphere.vertex_count();
  std::vector<model::Point3> positions = sphere.model().surface_vertices, normals(n);
  compute_vertex_normals(sphere, positions.data(), normals.data(), 0, n);
  std::vector<Eigen::Vector3d> expected = reference_normals(sphere, positions);
  for (std::size_t v = 0; v < n; ++v) {
    EXPECT_LT((vec(normals[v]) - expected[v]).norm(), 1e-12) << v;
    EXPECT_GT(vec(normals[v]).dot(vec(positions[v]).normalized()), 0.999) << v;  // outward, nearly radial
  }
  // Deformed by two tools, and computed in two ranges as two threads would.
  MultiBeam beams(sphere, {});
  ASSERT_EQ(beams.attach(0, {0.08, 0.0, 0.0}), Status::ok);
  ASSERT_EQ(beams.attach(1, {0.0, 0.0, 0.08}), Status::ok);
  const Eigen::Vector3d tips[2] = {{-0.01, 0.002, 0.0}, {0.0, 0.004, -0.008}};
  ASSERT_EQ(beams.prepare(tips), Status::ok);
  const std::size_t half = n / 2 / organ::Organ::kPadding * organ::Organ::kPadding;
  beams.distort(0, half, positions.data());
  beams.distort(half, n, positions.data());
  expected = reference_normals(sphere, positions);
  compute_vertex_normals(sphere, positions.data(), normals.data(), half, n);
  compute_vertex_normals(sphere, positions.data(), normals.data(), 0, half);
  for (std::size_t v = 0; v < n; ++v) EXPECT_LT((vec(normals[v]) - expected[v]).norm(), 1e-12) << v;
  // The frame's normals, from distort()'s single-precision copy of the points
  // (relative to the fixed point: float's resolution there is about 4 nm):
  // off by about that resolution over the vertex's shortest edge.
  beams.normals(half, n, normals.data());
  beams.normals(0, half, normals.data());
  std::vector<double> shortest_edge(n, 1.0);
  for (const model::Triangle& t : sphere.model().surface_triangles)
    for (int k = 0; k < 3; ++k) {
      const double length = (vec(positions[t[k]]) - vec(positions[t[(k + 1) % 3]])).norm();
      for (std::uint32_t v : {t[k], t[(k + 1) % 3]}) shortest_edge[v] = std::min(shortest_edge[v], length);
    }
  for (std::size_t v = 0; v < n; ++v) {
    EXPECT_NEAR(vec(normals[v]).norm(), 1.0, 1e-6) << v;
    EXPECT_LT((vec(normals[v]) - expected[v]).norm(), 1e-8 / shortest_edge[v]) << v;
  }
}

TEST(Organ, VertexNormalsOnABorderAndOfAnIsolatedVertex) {
  // A hole: every triangle of vertex 100 removed, so that it is isolated and
  // its neighbours lie on a border (their rings are open).
  model::OrganModel model = testing::make_sphere_model(2400, 20);
  constexpr std::uint32_t kIsolated = 100;
  std::vector<model::Triangle>& triangles = model.surface_triangles;
  triangles.erase(std::remove_if(triangles.begin(), triangles.end(),
                                 [](const model::Triangle& t) {
                                   return t[0] == kIsolated || t[1] == kIsolated || t[2] == kIsolated;
                                 }),
                  triangles.end());
  const organ::Organ organ(std::move(model));
  const std::size_t n = organ.vertex_count();
  const std::uint32_t isolated = static_cast<std::uint32_t>(
      std::find(organ.file_vertex_index().begin(), organ.file_vertex_index().end(), kIsolated) -
      organ.file_vertex_index().begin());
  std::vector<model::Point3> normals(n);
  compute_vertex_normals(organ, organ.model().surface_vertices.data(), normals.data(), 0, n);
  const std::vector<Eigen::Vector3d> expected = reference_normals(organ, organ.model().surface_vertices);
  for (std::size_t v = 0; v < n; ++v) EXPECT_LT((vec(normals[v]) - expected[v]).norm(), 1e-12) << v;
  EXPECT_EQ(vec(normals[isolated]), Eigen::Vector3d::Zero());

  const MultiBeam beams(organ, {});  // before any distort(): the rest shape
  beams.normals(0, n, normals.data());
  for (std::size_t v = 0; v < n; ++v) EXPECT_LT((vec(normals[v]) - expected[v]).norm(), 1e-5) << v;
  EXPECT_EQ(vec(normals[isolated]), Eigen::Vector3d::Zero());
}

TEST(Organ, TheRestNormalAtAPointIsItsVerticesNormalsInterpolated) {
  // A contact's normal (its friction cone's axis): at a vertex the vertex's
  // normal whichever of its triangles the point is found on, the same on both
  // sides of an edge, and in a triangle the barycentric blend, normalized.
  const organ::Organ sphere(testing::make_sphere_model(2400, 20));
  const std::vector<model::Triangle>& triangles = sphere.model().surface_triangles;
  auto normal_of = [&](std::uint32_t v) { return vec(sphere.rest_normals()[v]); };
  std::size_t vertices_checked = 0, edges_checked = 0;
  for (std::uint32_t a = 0; a < triangles.size(); ++a) {
    for (int k = 0; k < 3; ++k) {
      geometry::SurfacePoint corner;
      corner.triangle = a;
      corner.barycentric = Eigen::Vector3d::Unit(k);
      EXPECT_LT((sphere.rest_normal_at(corner) - normal_of(triangles[a][k])).norm(), 1e-12);
      ++vertices_checked;
    }
    // Edge (t0, t1)'s midpoint seen from the triangle across it.
    for (std::uint32_t b = a + 1; b < triangles.size() && edges_checked < 500; ++b) {
      const auto shared = [&](std::uint32_t v) { return std::find(triangles[b].begin(), triangles[b].end(), v); };
      if (shared(triangles[a][0]) == triangles[b].end() || shared(triangles[a][1]) == triangles[b].end()) continue;
      geometry::SurfacePoint here, there;
      here.triangle = a;
      here.barycentric = {0.5, 0.5, 0.0};
      there.triangle = b;
      there.barycentric[shared(triangles[a][0]) - triangles[b].begin()] = 0.5;
      there.barycentric[shared(triangles[a][1]) - triangles[b].begin()] = 0.5;
      EXPECT_LT((sphere.rest_normal_at(here) - sphere.rest_normal_at(there)).norm(), 1e-12);
      ++edges_checked;
    }
  }
  EXPECT_GT(edges_checked, 50u);
  geometry::SurfacePoint inside;
  inside.barycentric = {0.2, 0.3, 0.5};
  const Eigen::Vector3d blend =
      0.2 * normal_of(triangles[0][0]) + 0.3 * normal_of(triangles[0][1]) + 0.5 * normal_of(triangles[0][2]);
  EXPECT_LT((sphere.rest_normal_at(inside) - blend.normalized()).norm(), 1e-12);
  EXPECT_NEAR(sphere.rest_normal_at(inside).norm(), 1.0, 1e-12);
  std::printf("rest normals: %zu corners, %zu edges\n", vertices_checked, edges_checked);
}

TEST(MultiBeam, RefusesAnOrganWithoutBeamTablesInOneLine) {
  model::OrganModel model = testing::make_cylinder_model({});
  model.beams = model::BeamTables{};
  const organ::Organ organ(std::move(model));  // the organ itself takes it: other models run on it
  EXPECT_FALSE(organ.has_beam_tables());
  try {
    MultiBeam beams(organ, {});
    FAIL() << "a multi-beam model without beam tables";
  } catch (const std::invalid_argument& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find("--no-beam-tables"), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

}  // namespace
}  // namespace organsim::multibeam
