// The spring networks: the paper's grid (counts per kind, border, rest
// lengths) and an organ's surface (edges, bending springs, anchors, masses).
#include <algorithm>
#include <cmath>
#include <map>
#include <ostream>
#include <set>
#include <stdexcept>
#include <string>
#include <utility>

#include <gtest/gtest.h>

#include "organsim/geometry/model_measures.h"
#include "organsim/springs/mass_spring.h"
#include "test_models.h"

namespace organsim::springs {

inline void PrintTo(StepStatus status, std::ostream* os) { *os << (status == StepStatus::ok ? "ok" : "blew_up"); }

namespace {

constexpr double kPi = 3.14159265358979323846;

std::size_t count_kind(const SpringNetwork& net, SpringKind kind) {
  return static_cast<std::size_t>(std::count(net.springs.kind.begin(), net.springs.kind.end(), kind));
}

Eigen::Vector3d vec(const model::Point3& p) { return {p[0], p[1], p[2]}; }

TEST(GridNetwork, SpringCountsPerKindMatchTheFormulas) {
  for (auto [n, m] : {std::pair{3u, 3u}, std::pair{15u, 15u}, std::pair{25u, 25u}, std::pair{4u, 7u}}) {
    GridOptions o;
    o.columns = n;
    o.rows = m;
    const SpringNetwork net = make_grid_network(o);
    EXPECT_EQ(count_kind(net, SpringKind::structural), 2 * n * m - n - m) << n << "x" << m;
    EXPECT_EQ(count_kind(net, SpringKind::shear), 2 * (n - 1) * (m - 1)) << n << "x" << m;
    EXPECT_EQ(count_kind(net, SpringKind::bending), n * (m - 2) + m * (n - 2)) << n << "x" << m;
    EXPECT_EQ(count_kind(net, SpringKind::body), n * m) << n << "x" << m;
    EXPECT_EQ(count_kind(net, SpringKind::volume), 0u);
    EXPECT_EQ(net.surface_nodes, n * m);
    EXPECT_EQ(net.rest.size(), 2 * n * m);
    EXPECT_EQ(net.triangles.size(), 2 * (n - 1) * (m - 1));
  }
  GridOptions no_body;
  no_body.body_factor = 0.0;
  const SpringNetwork net = make_grid_network(no_body);
  EXPECT_EQ(count_kind(net, SpringKind::body), 0u);
  EXPECT_EQ(net.rest.size(), 225u);
}

TEST(GridNetwork, BorderAndAnchorsAreFixedAndRestLengthsAreTheGrid) {
  GridOptions o;
  o.columns = 6;
  o.rows = 5;
  o.spacing = 0.02;
  const SpringNetwork net = make_grid_network(o);
  const std::uint32_t n = o.columns, m = o.rows;
  for (std::uint32_t j = 0; j < m; ++j)
    for (std::uint32_t i = 0; i < n; ++i) {
      const std::uint32_t v = i + n * j;
      EXPECT_EQ(net.rest[v], Eigen::Vector3d(i * o.spacing, j * o.spacing, 0.0));
      EXPECT_EQ(net.fixed[v], (i == 0 || j == 0 || i == n - 1 || j == m - 1) ? 1 : 0) << i << "," << j;
      EXPECT_EQ(net.fixed[n * m + v], 1);
      EXPECT_EQ(net.rest[n * m + v], net.rest[v] - Eigen::Vector3d(0, 0, o.spacing));
      EXPECT_EQ(net.mass[v], o.mass);
    }
  const std::map<SpringKind, std::pair<double, double>> expected{
      {SpringKind::structural, {o.spacing, o.structural_stiffness}},
      {SpringKind::shear, {std::sqrt(2.0) * o.spacing, o.shear_stiffness}},
      {SpringKind::bending, {2.0 * o.spacing, o.bending_stiffness}},
      {SpringKind::body, {o.spacing, o.body_factor * o.structural_stiffness}}};
  for (std::size_t k = 0; k < net.springs.size(); ++k) {
    const auto [length, stiffness] = expected.at(net.springs.kind[k]);
    EXPECT_LT(net.springs.a[k], net.springs.b[k]);
    EXPECT_NEAR(net.springs.rest_length[k], length, 1e-15) << k;
    EXPECT_NEAR((net.rest[net.springs.a[k]] - net.rest[net.springs.b[k]]).norm(), length, 1e-15) << k;
    EXPECT_EQ(net.springs.stiffness[k], stiffness) << k;
  }
  o.fix_border = false;
  const SpringNetwork loose = make_grid_network(o);
  EXPECT_EQ(std::count(loose.fixed.begin(), loose.fixed.end(), 1), static_cast<long>(n * m));  // the anchors
}

TEST(GridNetwork, BadOptionsAreRefusedByName) {
  GridOptions o;
  o.columns = 2;
  EXPECT_THROW(make_grid_network(o), std::invalid_argument);
  o = {};
  o.spacing = 0.0;
  EXPECT_THROW(make_grid_network(o), std::invalid_argument);
  o = {};
  o.mass = std::nan("");
  EXPECT_THROW(make_grid_network(o), std::invalid_argument);
  o = {};
  o.shear_damping = -1.0;
  try {
    make_grid_network(o);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("damping"), std::string::npos) << e.what();
  }
}

struct Cylinder : ::testing::Test {
  static testing::CylinderSpec cylinder() {
    testing::CylinderSpec c;  // coarse beam tables: they are not used here
    c.stations = 1;
    c.section_polygon_vertices = 8;
    return c;
  }
  testing::CylinderSpec spec = cylinder();
  model::OrganModel model = testing::make_cylinder_model(spec);
};

TEST_F(Cylinder, EverySurfaceEdgeIsOneStructuralSpringAndInteriorEdgesGetBendingSprings) {
  const SpringNetwork net = make_organ_network(model, {});
  const std::size_t ns = model.surface_vertices.size();
  std::map<std::pair<std::uint32_t, std::uint32_t>, std::vector<std::uint32_t>> edges;  // → opposite vertices
  for (const model::Triangle& t : model.surface_triangles)
    for (int k = 0; k < 3; ++k)
      edges[{std::min(t[k], t[(k + 1) % 3]), std::max(t[k], t[(k + 1) % 3])}].push_back(t[(k + 2) % 3]);
  std::size_t interior = 0;
  std::multiset<std::pair<std::uint32_t, std::uint32_t>> bending_expected;
  for (const auto& [edge, opposite] : edges)
    if (opposite.size() == 2) {
      ++interior;
      bending_expected.insert({std::min(opposite[0], opposite[1]), std::max(opposite[0], opposite[1])});
    }
  // A closed surface: every edge interior, E = 3T/2, V − E + T = 2.
  EXPECT_EQ(interior, edges.size());
  EXPECT_EQ(2 * edges.size(), 3 * model.surface_triangles.size());
  EXPECT_EQ(ns + model.surface_triangles.size(), edges.size() + 2);

  std::set<std::pair<std::uint32_t, std::uint32_t>> structural;
  std::multiset<std::pair<std::uint32_t, std::uint32_t>> bending;
  for (std::size_t k = 0; k < net.springs.size(); ++k) {
    const std::pair<std::uint32_t, std::uint32_t> ab{net.springs.a[k], net.springs.b[k]};
    ASSERT_LT(ab.first, ab.second);
    if (net.springs.kind[k] == SpringKind::structural) {
      EXPECT_TRUE(structural.insert(ab).second) << "twice";
    }
    if (net.springs.kind[k] == SpringKind::bending) bending.insert(ab);
  }
  EXPECT_EQ(structural.size(), edges.size());
  for (const auto& [edge, opposite] : edges) EXPECT_EQ(structural.count(edge), 1u);
  EXPECT_EQ(count_kind(net, SpringKind::bending), interior);
  EXPECT_EQ(bending, bending_expected);
  EXPECT_EQ(count_kind(net, SpringKind::body), ns);
  EXPECT_EQ(net.rest.size(), 2 * ns);
  EXPECT_EQ(net.surface_nodes, ns);
  EXPECT_EQ(net.triangles, model.surface_triangles);
}

TEST_F(Cylinder, SpringConstantsFollowTheOptions) {
  OrganNetworkOptions o;
  const SpringNetwork net = make_organ_network(model, o);
  double length_sum = 0.0;
  std::size_t edges = 0;
  for (std::size_t k = 0; k < net.springs.size(); ++k)
    if (net.springs.kind[k] == SpringKind::structural) {
      length_sum += net.springs.rest_length[k];
      ++edges;
    }
  const double mean = length_sum / edges, k = model.material.young_modulus * mean;
  double mean_mass = 0.0;
  for (std::size_t v = 0; v < net.surface_nodes; ++v) mean_mass += net.mass[v] / static_cast<double>(net.surface_nodes);
  const double d = o.critical_fraction * 2.0 * std::sqrt(k * mean_mass);  // a fraction of one spring's critical damping
  for (std::size_t s = 0; s < net.springs.size(); ++s) {
    const double factor = net.springs.kind[s] == SpringKind::bending ? o.bending_factor
                          : net.springs.kind[s] == SpringKind::body  ? o.body_factor
                                                                     : 1.0;
    EXPECT_NEAR(net.springs.stiffness[s], factor * k, 1e-12 * k) << s;
    EXPECT_NEAR(net.springs.damping[s], factor * d, 1e-12 * d) << s;
    EXPECT_NEAR(net.springs.rest_length[s], (net.rest[net.springs.a[s]] - net.rest[net.springs.b[s]]).norm(), 1e-15);
    if (net.springs.kind[s] == SpringKind::body) {
      EXPECT_NEAR(net.springs.rest_length[s], mean, 1e-12);
    }
  }
  o.stiffness = 7.0;
  o.anchor_depth = 0.004;
  const SpringNetwork given = make_organ_network(model, o);
  for (std::size_t s = 0; s < given.springs.size(); ++s) {
    if (given.springs.kind[s] == SpringKind::structural) {
      EXPECT_EQ(given.springs.stiffness[s], 7.0);
    }
    if (given.springs.kind[s] == SpringKind::body) {
      EXPECT_NEAR(given.springs.rest_length[s], 0.004, 1e-15);
    }
  }
}

TEST_F(Cylinder, AnchorsLieInsideAlongTheInwardNormal) {
  OrganNetworkOptions o;
  o.anchor_depth = 0.01;
  const SpringNetwork net = make_organ_network(model, o);
  const std::size_t ns = model.surface_vertices.size();
  // Signed distance to the polygonal cylinder (negative inside): max of the
  // caps' and the side faces' plane distances (a convex solid).
  auto signed_distance = [&](const Eigen::Vector3d& p) {
    double d = std::max(-p.x(), p.x() - spec.length);
    for (unsigned i = 0; i < spec.segments; ++i) {
      const double mid = 2.0 * kPi * (i + 0.5) / spec.segments;
      const double apothem = spec.radius * std::cos(kPi / spec.segments);
      d = std::max(d, p.y() * std::cos(mid) + p.z() * std::sin(mid) - apothem);
    }
    return d;
  };
  for (std::size_t v = 0; v < ns; ++v) {
    const Eigen::Vector3d anchor = net.rest[ns + v];
    EXPECT_TRUE(net.fixed[ns + v]);
    EXPECT_NEAR((anchor - net.rest[v]).norm(), o.anchor_depth, 1e-15) << v;
    EXPECT_LT(signed_distance(anchor), -1e-3) << v;  // at least 1 mm inside
    EXPECT_LE(std::abs(signed_distance(net.rest[v])), 1e-12) << v;
  }
  // A side vertex in the middle: the anchor is straight towards the axis.
  const std::size_t side = (spec.rings / 2) * spec.segments;  // angle 0: (x, r, 0)
  EXPECT_NEAR(net.rest[ns + side].y(), spec.radius - o.anchor_depth, 1e-12);
  EXPECT_NEAR(net.rest[ns + side].z(), 0.0, 1e-12);
  EXPECT_NEAR(net.rest[ns + side].x(), net.rest[side].x(), 1e-12);
}

TEST_F(Cylinder, MassesSumToDensityTimesVolumeSharedEquallyOrByArea) {
  const SpringNetwork equal = make_organ_network(model, {});
  for (std::size_t v = 0; v < model.surface_vertices.size(); ++v)
    EXPECT_NEAR(equal.mass[v],
                model.material.density * geometry::measure_model(model).tetrahedra_volume /
                    static_cast<double>(model.surface_vertices.size()),
                1e-15)
        << v;
  OrganNetworkOptions by_area;
  by_area.area_weighted_mass = true;
  const SpringNetwork net = make_organ_network(model, by_area);
  const std::size_t ns = model.surface_vertices.size();
  const geometry::ModelMeasures measures = geometry::measure_model(model);
  const double total = model.material.density * measures.tetrahedra_volume;
  double sum = 0.0;
  for (std::size_t v = 0; v < ns; ++v) sum += net.mass[v];
  EXPECT_NEAR(sum, total, 1e-12 * total);
  // Vertex area: a third of each adjacent triangle's area.
  std::vector<double> area(ns, 0.0);
  for (const model::Triangle& t : model.surface_triangles) {
    const double a = 0.5 * (vec(model.surface_vertices[t[1]]) - vec(model.surface_vertices[t[0]]))
                               .cross(vec(model.surface_vertices[t[2]]) - vec(model.surface_vertices[t[0]]))
                               .norm();
    for (std::uint32_t j : t) area[j] += a / 3.0;
  }
  for (std::size_t v = 0; v < ns; ++v) {
    EXPECT_NEAR(net.mass[v], total * area[v] / measures.surface_area, 1e-12 * total) << v;
    EXPECT_EQ(net.mass[ns + v], net.mass[v]);
  }

  // Without tetrahedra: the enclosed volume (the same polygonal cylinder here).
  model::OrganModel surface_only = model;
  surface_only.tetrahedra.clear();
  surface_only.volume_vertices.clear();
  const SpringNetwork hollow = make_organ_network(surface_only, by_area);
  sum = 0.0;
  for (std::size_t v = 0; v < ns; ++v) sum += hollow.mass[v];
  EXPECT_NEAR(sum, model.material.density * measures.surface_enclosed_volume, 1e-12 * total);

  OrganNetworkOptions uniform;
  uniform.uniform_mass = 0.002;
  const SpringNetwork even = make_organ_network(model, uniform);
  for (std::size_t v = 0; v < ns; ++v) EXPECT_EQ(even.mass[v], 0.002);
}

TEST_F(Cylinder, ClampRadiusFixesTheNodesNearTheFixedPoint) {
  OrganNetworkOptions o;
  o.clamp_radius = spec.radius * 1.01;  // the near cap: its rim and centre
  const SpringNetwork net = make_organ_network(model, o);
  std::size_t fixed = 0;
  for (std::size_t v = 0; v < model.surface_vertices.size(); ++v) {
    const bool near = vec(model.surface_vertices[v]).norm() <= o.clamp_radius;
    EXPECT_EQ(net.fixed[v] != 0, near) << v;
    fixed += near;
  }
  EXPECT_EQ(fixed, spec.segments + 1u);
  const SpringNetwork unclamped = make_organ_network(model, {});
  EXPECT_EQ(std::count(unclamped.fixed.begin(), unclamped.fixed.end(), 1),
            static_cast<long>(model.surface_vertices.size()));  // only the anchors
}

// The model's supports become node supports of the surface nodes they name:
// a contact unilateral, an attachment not, each of stiffness k A (the
// vertex's third of its triangles' area) along its outward normal; free and
// clamped vertices get none, and none without the option.
TEST_F(Cylinder, SupportsSitOnTheSurfaceNodesTheModelNames) {
  constexpr double kModulus = 2.5e5;  // Pa/m
  for (std::size_t v = 0; v < model.surface_vertices.size(); ++v)
    model.supports.vertices.push_back(model.surface_vertices[v][2] < -0.5 * spec.radius
                                          ? std::array<double, 2>{v % 2 ? 1.0 : 2.0, kModulus}
                                          : std::array<double, 2>{0.0, 0.0});
  EXPECT_TRUE(make_organ_network(model, {}).supports.empty());
  OrganNetworkOptions o;
  o.supports = true;
  o.clamp_radius = spec.radius * 1.01;
  const SpringNetwork net = make_organ_network(model, o);
  std::vector<double> area(model.surface_vertices.size(), 0.0);
  for (const model::Triangle& t : model.surface_triangles) {
    const double third = (vec(model.surface_vertices[t[1]]) - vec(model.surface_vertices[t[0]]))
                             .cross(vec(model.surface_vertices[t[2]]) - vec(model.surface_vertices[t[0]]))
                             .norm() /
                         6.0;
    for (std::uint32_t v : t) area[v] += third;
  }
  std::size_t expected = 0;
  for (std::size_t v = 0; v < model.surface_vertices.size(); ++v)
    expected += model.supports.kind(v) != model::Supports::Kind::kFree && !net.fixed[v];
  ASSERT_EQ(net.supports.size(), expected);
  ASSERT_GT(expected, 0u);
  for (const NodeSupport& support : net.supports) {
    EXPECT_EQ(support.unilateral, model.supports.kind(support.node) == model::Supports::Kind::kContact);
    EXPECT_NEAR(support.stiffness, kModulus * area[support.node], 1e-9 * kModulus * area[support.node]);
    EXPECT_LT(support.normal.z(), 0.0);  // the lower half's outward normals point down
    EXPECT_FALSE(net.fixed[support.node]);
  }
}

TEST_F(Cylinder, RefusesWhatItCannotBuild) {
  OrganNetworkOptions o;
  o.volume_springs = true;
  model::OrganModel surface_only = model;
  surface_only.tetrahedra.clear();
  try {
    make_organ_network(surface_only, o);
    FAIL();
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("volume springs need the model's tetrahedra"), std::string::npos) << e.what();
  }
  o.area_weighted_mass = true;
  EXPECT_THROW(make_organ_network(model, o), std::invalid_argument);
  o = {};
  model::OrganModel empty = model;
  empty.surface_triangles.clear();
  EXPECT_THROW(make_organ_network(empty, {}), std::invalid_argument);
  model::OrganModel stray = model;
  stray.surface_vertices.push_back({1.0, 1.0, 1.0});  // on no triangle
  EXPECT_THROW(make_organ_network(stray, {}), std::invalid_argument);
  o = {};
  o.anchor_depth = -1.0;
  EXPECT_THROW(make_organ_network(model, o), std::invalid_argument);
}

TEST_F(Cylinder, VolumeSpringsJoinEveryTetrahedronEdgeAndTieEachVertexToItsTetrahedron) {
  OrganNetworkOptions o;
  o.volume_springs = true;
  o.volume_factor = 0.5;
  o.clamp_radius = spec.radius * 1.01;
  const SpringNetwork net = make_organ_network(model, o);
  const std::size_t ns = model.surface_vertices.size(), nv = model.volume_vertices.size(), base = 2 * ns;
  ASSERT_EQ(net.rest.size(), base + nv);
  EXPECT_EQ(net.surface_nodes, ns);
  std::set<std::pair<std::uint32_t, std::uint32_t>> tet_edges;
  for (const model::Tetrahedron& t : model.tetrahedra)
    for (int i = 0; i < 4; ++i)
      for (int j = i + 1; j < 4; ++j) tet_edges.insert({std::min(t[i], t[j]), std::max(t[i], t[j])});
  ASSERT_EQ(count_kind(net, SpringKind::volume), tet_edges.size() + 4 * ns);

  double structural_k = 0.0;
  for (std::size_t k = 0; k < net.springs.size(); ++k)
    if (net.springs.kind[k] == SpringKind::structural) structural_k = net.springs.stiffness[k];
  std::set<std::pair<std::uint32_t, std::uint32_t>> seen_edges;
  std::map<std::uint32_t, std::set<std::uint32_t>> ties;  // surface vertex → tetrahedral nodes
  for (std::size_t k = 0; k < net.springs.size(); ++k) {
    if (net.springs.kind[k] != SpringKind::volume) continue;
    const std::uint32_t a = net.springs.a[k], b = net.springs.b[k];
    EXPECT_NEAR(net.springs.rest_length[k], (net.rest[a] - net.rest[b]).norm(), 1e-15);
    ASSERT_GE(b, base);
    if (a >= base) {
      seen_edges.insert({a - static_cast<std::uint32_t>(base), b - static_cast<std::uint32_t>(base)});
      EXPECT_DOUBLE_EQ(net.springs.stiffness[k], 0.5 * structural_k);
    } else {
      ASSERT_LT(a, ns);
      ties[a].insert(b - static_cast<std::uint32_t>(base));
      EXPECT_DOUBLE_EQ(net.springs.stiffness[k], structural_k);
    }
  }
  EXPECT_EQ(seen_edges, tet_edges);
  ASSERT_EQ(ties.size(), ns);
  for (const auto& [vertex, corners] : ties) {
    // The four corners of one tetrahedron that holds the vertex (here a corner of it).
    ASSERT_EQ(corners.size(), 4u) << vertex;
    const bool one_tetrahedron = std::any_of(model.tetrahedra.begin(), model.tetrahedra.end(), [&](const auto& t) {
      return std::set<std::uint32_t>(t.begin(), t.end()) == corners;
    });
    EXPECT_TRUE(one_tetrahedron) << vertex;
    EXPECT_TRUE(corners.count(vertex)) << vertex;  // the cylinder's tetrahedra use the surface vertices
  }
  // Masses: ρV shared equally by the surface and tetrahedral nodes; the clamp holds tetrahedral nodes too.
  const double share =
      model.material.density * geometry::measure_model(model).tetrahedra_volume / static_cast<double>(ns + nv);
  for (std::size_t v = 0; v < net.rest.size(); ++v) {
    if (v < ns || v >= base) {
      EXPECT_NEAR(net.mass[v], share, 1e-15) << v;
    }
  }
  for (std::size_t v = base; v < net.rest.size(); ++v)
    EXPECT_EQ(net.fixed[v] != 0, net.rest[v].norm() <= o.clamp_radius) << v;
}

TEST_F(Cylinder, VolumeSpringsRestInEquilibriumAndStiffenTheOrgan) {
  // A cantilever clamped at its near cap, pulled down at the far cap's centre:
  // the hollow surface network (no body springs) bends further than the one
  // filled with volume springs.
  auto deflection = [&](bool volume) {
    OrganNetworkOptions o;
    o.body_factor = 0.0;
    o.volume_springs = volume;
    o.clamp_radius = spec.radius * 1.01;
    o.critical_fraction = 1.0;
    SimulationOptions s;
    s.integrator = Integrator::implicit_euler;
    s.dt = 0.05;
    s.gravity.setZero();
    s.implicit_cg_iterations = 400;
    MassSpring sim(make_organ_network(model, o), s);
    for (int i = 0; i < 3; ++i) EXPECT_EQ(sim.step(), StepStatus::ok);
    double drift = 0.0;
    for (std::uint32_t v = 0; v < sim.node_count(); ++v)
      drift = std::max(drift, (sim.position(v) - sim.network().rest[v]).norm());
    EXPECT_LT(drift, 1e-12) << "volume " << volume;  // the rest shape is an equilibrium
    std::uint32_t far = 0;
    for (std::uint32_t v = 0; v < sim.network().surface_nodes; ++v)
      if (sim.network().rest[v].x() > sim.network().rest[far].x() + 1e-9 ||
          (std::abs(sim.network().rest[v].x() - sim.network().rest[far].x()) < 1e-9 &&
           sim.network().rest[v].norm() < sim.network().rest[far].norm()))
        far = v;
    sim.set_external_force(far, Eigen::Vector3d(0, 0, -0.05));
    for (int i = 0; i < 400; ++i) EXPECT_EQ(sim.step(), StepStatus::ok);
    EXPECT_LT(sim.velocity(far).norm(), 1e-4) << "volume " << volume;
    return sim.network().rest[far].z() - sim.position(far).z();
  };
  const double hollow = deflection(false), filled = deflection(true);
  EXPECT_GT(filled, 0.0);
  EXPECT_LT(filled, 0.5 * hollow) << "hollow " << hollow << " m, filled " << filled << " m";
}

TEST_F(Cylinder, TheOrganNetworkSettlesUnderItsOwnWeightOnItsClampAndAnchors) {
  OrganNetworkOptions o;
  o.clamp_radius = spec.radius * 1.01;
  SimulationOptions s;
  s.integrator = Integrator::implicit_euler;
  s.dt = 0.02;
  MassSpring sim(make_organ_network(model, o), s);
  for (int i = 0; i < 150; ++i) ASSERT_EQ(sim.step(), StepStatus::ok);
  double speed = 0.0, sag = 0.0, free_mass = 0.0;
  Eigen::Vector3d support = Eigen::Vector3d::Zero();  // Σ spring forces on the fixed nodes
  for (std::uint32_t v = 0; v < sim.node_count(); ++v) {
    speed = std::max(speed, sim.velocity(v).norm());
    sag = std::min(sag, sim.position(v).z() - sim.network().rest[v].z());
    if (sim.network().fixed[v]) {
      support += sim.reaction_force(v);
    } else {
      free_mass += sim.network().mass[v];
    }
  }
  EXPECT_LT(speed, 1e-6);
  EXPECT_LT(sag, -1e-3);  // it hangs down a little
  EXPECT_GT(sag, -spec.radius);
  // At rest the supports carry the whole weight of the free nodes.
  const Eigen::Vector3d weight = free_mass * s.gravity;
  EXPECT_LT((support - weight).norm(), 1e-4 * weight.norm()) << support.transpose();
}

}  // namespace
}  // namespace organsim::springs
