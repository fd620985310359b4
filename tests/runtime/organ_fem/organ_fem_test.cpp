// The FEM models frame by frame on a baked organ (fem/organ_fem.h): the
// constrained iteration against the static solver (an independent path: load
// steps, predictor, full Newton), the condensed contact stiffness against finite
// differences, the surface embedding, several tools, and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>

#include <Eigen/Eigenvalues>

#include "organsim/organ_fem/organ_fem.h"
#include "organsim/fem/static_solver.h"
#include "test_models.h"

namespace organsim::fem {
namespace {

Eigen::Vector3d point(const model::Point3& p) { return {p[0], p[1], p[2]}; }

/// A cylinder 150 mm long, radius 30 mm, clamped over its x = 0 cap (the cap's
/// centre and rim lie within 31 mm of the fixed point): a cantilever.
model::OrganModel cylinder() {
  testing::CylinderSpec spec;
  spec.stations = 2;
  spec.section_polygon_vertices = 64;
  return testing::make_cylinder_model(spec);
}

OrganFemOptions cap_clamp() {
  OrganFemOptions o;
  o.fixed_radius = 0.031;
  return o;
}

/// The node of the far cap's rim at the top (+z): index found by position.
std::int32_t top_far_node(const model::OrganModel& m) {
  std::int32_t best = -1;
  double best_score = -1e9;
  for (std::size_t n = 0; n < m.volume_vertices.size(); ++n) {
    const Eigen::Vector3d p = point(m.volume_vertices[n]);
    const double score = p.x() + p.z();
    if (score > best_score) best_score = score, best = static_cast<std::int32_t>(n);
  }
  return best;
}

/// The same press as a static problem: the clamp as fixed nodes, the contact
/// node's three components prescribed.
StaticSolution static_press(const model::OrganModel& m, MaterialModel law, const OrganFemOptions& o, std::int32_t node,
                            const Eigen::Vector3d& displacement) {
  StaticProblem p;
  for (const model::Point3& x : m.volume_vertices) p.mesh.nodes.push_back(point(x));
  for (const model::Tetrahedron& t : m.tetrahedra)
    p.mesh.tetrahedra.push_back({static_cast<std::int32_t>(t[0]), static_cast<std::int32_t>(t[1]),
                                 static_cast<std::int32_t>(t[2]), static_cast<std::int32_t>(t[3])});
  p.material = law == MaterialModel::mooney_rivlin
                   ? Material::mooney_rivlin_from_young(m.material.young_modulus, o.psh_poisson_ratio, o.stabilization)
                   : Material::from_young(law, m.material.young_modulus, m.material.poisson_ratio);
  for (std::size_t n = 0; n < p.mesh.nodes.size(); ++n)
    if ((p.mesh.nodes[n] - point(m.fixed_points[0])).norm() <= o.fixed_radius)
      p.fixed.push_back(static_cast<std::int32_t>(n));
  for (int k = 0; k < 3; ++k) p.prescribed.push_back({node, k, displacement[k]});
  p.load_steps = 4;
  p.tolerance = 1e-10;
  return solve_static(p);
}

TEST(OrganFem, SurfaceEmbeddingReproducesTheRestSurface) {
  const model::OrganModel m = cylinder();
  OrganFem fem(m, MaterialModel::linear, cap_clamp(), 1);
  std::size_t within = 0;
  for (const model::Point3& p : m.volume_vertices) within += point(p).norm() <= 0.031;
  EXPECT_EQ(fem.clamped_node_count(), within);
  EXPECT_GE(within, 25u);  // at least the cap: its 24 rim nodes and its centre
  std::vector<model::Point3> positions(m.surface_vertices.size());
  fem.surface_positions(positions.data());
  for (std::size_t v = 0; v < positions.size(); ++v)
    EXPECT_LT((point(positions[v]) - point(m.surface_vertices[v])).norm(), 1e-12) << "vertex " << v;
}

TEST(OrganFem, LinearFrameIsTheExactStaticSolution) {
  const model::OrganModel m = cylinder();
  const std::int32_t node = top_far_node(m);
  const Eigen::Vector3d press(0.0, 0.002, -0.008);
  OrganFem fem(m, MaterialModel::linear, cap_clamp(), 1);
  ASSERT_TRUE(fem.attach(0, point(m.volume_vertices[static_cast<std::size_t>(node)])));
  EXPECT_LT((fem.contact_point(0) - point(m.volume_vertices[static_cast<std::size_t>(node)])).norm(), 1e-12);
  ASSERT_EQ(fem.step(&press), FrameStatus::ok);

  const StaticSolution reference = static_press(m, MaterialModel::linear, cap_clamp(), node, press);
  ASSERT_TRUE(reference.converged) << reference.error;
  const double scale = reference.displacements.cwiseAbs().maxCoeff();
  EXPECT_LT((fem.displacements() - reference.displacements).cwiseAbs().maxCoeff(), 1e-9 * scale);
  EXPECT_LT((fem.contact_displacement(0) - press).norm(), 1e-12);
  // The tool feels minus the support's reaction; the linear contact force is −K d.
  const Eigen::Vector3d force = fem.contact_force(0);
  EXPECT_LT((force + reference.reaction_prescribed).norm(), 1e-8 * force.norm());
  EXPECT_LT((force + fem.contact_stiffness(0) * press).norm(), 1e-9 * force.norm());
  EXPECT_LT(fem.unbalanced_force(), 1e-9 * force.norm());
  EXPECT_LT(force.dot(press), 0.0);  // the organ pushes back
}

TEST(OrganFem, CondensedStiffnessIsSymmetricPositiveAndTheForceDerivative) {
  const model::OrganModel m = cylinder();
  OrganFem fem(m, MaterialModel::linear, cap_clamp(), 1);
  ASSERT_TRUE(fem.attach(0, Eigen::Vector3d(0.12, 0.0, 0.03)));
  const Eigen::Matrix3d k = fem.contact_stiffness(0);
  EXPECT_LT((k - k.transpose()).norm(), 1e-10 * k.norm());
  EXPECT_GT(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(k).eigenvalues().minCoeff(), 0.0);
  for (int axis = 0; axis < 3; ++axis) {
    const Eigen::Vector3d d = 1e-4 * Eigen::Vector3d::Unit(axis);
    ASSERT_EQ(fem.step(&d), FrameStatus::ok);
    EXPECT_LT((fem.contact_force(0) + k.col(axis) * 1e-4).norm(), 1e-9 * k.norm() * 1e-4) << "axis " << axis;
  }
}

class NonlinearOrganFem : public ::testing::TestWithParam<MaterialModel> {
 protected:
  /// Both tests: the far cap's top rim node pressed 15 mm down and 4 mm sideways.
  const model::OrganModel m = cylinder();
  const std::int32_t node = top_far_node(m);
  const Eigen::Vector3d press{0.0, 0.004, -0.015};
  Eigen::Vector3d node_point() const { return point(m.volume_vertices[static_cast<std::size_t>(node)]); }

  /// Frames at a held press until the out-of-balance force is 1e-10 of the
  /// contact force; returns the frames taken (`limit` when it never got there).
  static int settle(OrganFem& fem, const Eigen::Vector3d& press, int limit, bool newton) {
    for (int frame = 1; frame <= limit; ++frame) {
      if (newton) {
        EXPECT_TRUE(fem.refresh_tangent());
      }
      EXPECT_EQ(fem.step(&press), FrameStatus::ok) << "frame " << frame;
      if (fem.unbalanced_force() < 1e-10 * fem.contact_force(0).norm()) return frame;
    }
    return limit;
  }

  /// The settled press against the static solver's solution of the same constraints.
  static void expect_static_solution(const OrganFem& fem, const model::OrganModel& m, std::int32_t node,
                                     const Eigen::Vector3d& press) {
    const StaticSolution reference = static_press(m, GetParam(), cap_clamp(), node, press);
    ASSERT_TRUE(reference.converged) << reference.error;
    const double scale = reference.displacements.cwiseAbs().maxCoeff();
    EXPECT_LT((fem.displacements() - reference.displacements).cwiseAbs().maxCoeff(), 1e-7 * scale);
    EXPECT_LT((fem.contact_force(0) + reference.reaction_prescribed).norm(),
              1e-6 * reference.reaction_prescribed.norm());
    if (GetParam() == MaterialModel::mooney_rivlin) {
      ASSERT_EQ(fem.pressures().size(), reference.pressures.size());
      EXPECT_LT((fem.pressures() - reference.pressures).cwiseAbs().maxCoeff(),
                1e-6 * reference.pressures.cwiseAbs().maxCoeff());
    }
  }
};

// The tangent refreshed before every frame: true Newton, quadratic.
TEST_P(NonlinearOrganFem, NewtonFramesConvergeToTheStaticSolution) {
  OrganFemOptions options = cap_clamp();
  options.refresh_frames = 0;
  options.relaxation = 1.0;
  OrganFem fem(m, GetParam(), options, 1);
  ASSERT_TRUE(fem.attach(0, node_point()));
  EXPECT_LE(settle(fem, press, 12, true), 8);
  expect_static_solution(fem, m, node, press);
}

// The real-time scheme: the tangent refactored by the worker every 4 frames
// from the state 4 frames back (psh: the rest tangent); linear convergence
// over frames.
TEST_P(NonlinearOrganFem, FramesWithAnAsynchronousTangentConvergeToTheStaticSolution) {
  OrganFemOptions options = cap_clamp();
  options.refresh_frames = 4;
  OrganFem fem(m, GetParam(), options, 1);
  ASSERT_TRUE(fem.attach(0, node_point()));
  EXPECT_LT(settle(fem, press, 300, false), 300) << "unbalanced " << fem.unbalanced_force() << " N";
  EXPECT_EQ(fem.tangent_refreshes() > 0, GetParam() != MaterialModel::mooney_rivlin);
  expect_static_solution(fem, m, node, press);
}

// Real-time loops do not wait for a late worker (set_reproducible(false)):
// a frame due to adopt a tangent that is not ready goes on with the kept one
// and a later frame adopts it. A refresh due every frame keeps the worker
// late most of the time; the frames still converge to the static solution.
TEST_P(NonlinearOrganFem, FramesThatDoNotWaitForALateTangentConvergeToTheStaticSolution) {
  OrganFemOptions options = cap_clamp();
  options.refresh_frames = 1;
  OrganFem fem(m, GetParam(), options, 1);
  fem.set_reproducible(false);
  ASSERT_TRUE(fem.attach(0, node_point()));
  EXPECT_LT(settle(fem, press, 600, false), 600) << "unbalanced " << fem.unbalanced_force() << " N";
  if (GetParam() != MaterialModel::mooney_rivlin) {
    EXPECT_GT(fem.tangent_refreshes() + fem.late_refreshes(), 0u);
  } else {
    EXPECT_EQ(fem.tangent_refreshes() + fem.late_refreshes(), 0u);  // psh keeps its rest tangent
  }
  expect_static_solution(fem, m, node, press);
}

// With no tool holding it (and no body force) the organ's equilibrium is its
// rest state: the frame after the last tool lets go is at rest, exactly, and
// the rest is a true equilibrium (a tool touching it there with no press moves
// nothing). The next press goes frame by frame as the first did, to the last
// bit: no tangent made at the first press's state is left over.
TEST_P(NonlinearOrganFem, TheFrameAfterTheToolsLetGoIsAtRestAndTheNextPressIsAsTheFirst) {
  OrganFemOptions options = cap_clamp();
  options.refresh_frames = 4;
  OrganFem fem(m, GetParam(), options, 1);
  auto press_frames = [&](int frames) {
    std::vector<Eigen::Vector3d> forces;
    for (int frame = 0; frame < frames; ++frame) {
      EXPECT_EQ(fem.step(&press), FrameStatus::ok) << "frame " << frame;
      forces.push_back(fem.contact_force(0));
    }
    return forces;
  };
  ASSERT_TRUE(fem.attach(0, node_point()));
  const std::vector<Eigen::Vector3d> first = press_frames(41);  // a refresh asked for at the last frame
  ASSERT_GT(fem.displacements().cwiseAbs().maxCoeff(), 1e-3);
  fem.detach(0);
  ASSERT_EQ(fem.step(&press), FrameStatus::ok);  // a detached tool's displacement is ignored
  EXPECT_EQ(fem.displacements().cwiseAbs().maxCoeff(), 0.0);
  if (fem.pressures().size() > 0) {
    EXPECT_EQ(fem.pressures().cwiseAbs().maxCoeff(), 0.0);
  }
  EXPECT_EQ(fem.unbalanced_force(), 0.0);
  ASSERT_TRUE(fem.attach(0, node_point()));
  const Eigen::Vector3d still = Eigen::Vector3d::Zero();
  ASSERT_EQ(fem.step(&still), FrameStatus::ok);
  EXPECT_LT(fem.displacements().cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT(fem.contact_force(0).norm(), 1e-12);
  fem.detach(0);
  ASSERT_EQ(fem.step(&still), FrameStatus::ok);
  ASSERT_TRUE(fem.attach(0, node_point()));
  const std::vector<Eigen::Vector3d> again = press_frames(41);
  for (std::size_t frame = 0; frame < first.size(); ++frame) ASSERT_EQ(again[frame], first[frame]) << "frame " << frame;
  EXPECT_LT(settle(fem, press, 300, false), 300) << "unbalanced " << fem.unbalanced_force() << " N";
  expect_static_solution(fem, m, node, press);
}

INSTANTIATE_TEST_SUITE_P(Materials, NonlinearOrganFem,
                         ::testing::Values(MaterialModel::corotational, MaterialModel::stvk,
                                           MaterialModel::mooney_rivlin),
                         [](const auto& material) {
                           return std::string(
                               material.param == MaterialModel::mooney_rivlin ? "psh" : material_name(material.param));
                         });

TEST(OrganFem, TwoToolsShareTheLoadAndDetachLetsTheOrganGoBack) {
  const model::OrganModel m = cylinder();
  OrganFem fem(m, MaterialModel::linear, cap_clamp(), 2);
  ASSERT_TRUE(fem.attach(0, Eigen::Vector3d(0.14, 0.0, 0.03)));
  ASSERT_TRUE(fem.attach(1, Eigen::Vector3d(0.08, 0.0, -0.03)));
  const Eigen::Vector3d presses[2] = {{0, 0, -0.004}, {0, 0, 0.002}};
  ASSERT_EQ(fem.step(presses), FrameStatus::ok);
  for (std::uint32_t t = 0; t < 2; ++t) EXPECT_LT((fem.contact_displacement(t) - presses[t]).norm(), 1e-12);

  // Superposition: each tool alone, the other holding its point still, gives
  // the same response as the capacitance system (linear material).
  const Eigen::Vector3d force0 = fem.contact_force(0), force1 = fem.contact_force(1);
  const Eigen::Vector3d nudged[2] = {presses[0] + Eigen::Vector3d(0, 0, -1e-4), presses[1]};
  ASSERT_EQ(fem.step(nudged), FrameStatus::ok);
  EXPECT_LT((fem.contact_force(0) - force0 - fem.contact_stiffness(0) * Eigen::Vector3d(0, 0, 1e-4)).norm(),
            1e-9 * force0.norm());
  EXPECT_GT((fem.contact_force(1) - force1).norm(), 0.0);  // the tools feel each other through the organ

  fem.detach(0);
  fem.detach(1);
  ASSERT_EQ(fem.step(presses), FrameStatus::ok);  // displacements of detached tools are ignored
  EXPECT_LT(fem.displacements().cwiseAbs().maxCoeff(), 1e-12);
  EXPECT_EQ(fem.contact_force(0), Eigen::Vector3d::Zero());
}

TEST(OrganFem, RefusesContactsItCannotHold) {
  const model::OrganModel m = cylinder();
  OrganFem fem(m, MaterialModel::linear, cap_clamp(), 2);
  EXPECT_FALSE(fem.attach(0, Eigen::Vector3d(0.0, 0.0, 0.03)));  // the clamped cap
  EXPECT_FALSE(fem.attach(0, Eigen::Vector3d(std::nan(""), 0.0, 0.0)));
  EXPECT_FALSE(fem.attach(2, Eigen::Vector3d(0.1, 0.0, 0.03)));  // no such tool
  ASSERT_TRUE(fem.attach(0, Eigen::Vector3d(0.1, 0.0, 0.03)));
  EXPECT_FALSE(fem.attach(1, Eigen::Vector3d(0.1, 0.001, 0.03)));  // the same face as tool 0
  EXPECT_FALSE(fem.attached(1));
  const Eigen::Vector3d bad[2] = {{std::nan(""), 0, 0}, {0, 0, 0}};
  EXPECT_EQ(fem.step(bad), FrameStatus::not_finite);
  EXPECT_EQ(fem.displacements().cwiseAbs().maxCoeff(), 0.0);
}

TEST(OrganFem, AStepThatWouldInvertATetrahedronIsCutOrUndone) {
  const model::OrganModel m = cylinder();
  OrganFem fem(m, MaterialModel::stvk, cap_clamp(), 1);
  ASSERT_TRUE(fem.attach(0, Eigen::Vector3d(0.05, 0.0, 0.03)));
  const Eigen::Vector3d small(0, 0, -0.002);
  ASSERT_EQ(fem.step(&small), FrameStatus::ok);
  EXPECT_EQ(fem.step_cuts(), 0u);

  // Into the clamp through the organ in one frame: a fraction of the step is taken.
  const Eigen::Vector3d through(-0.15, 0, -0.05);
  ASSERT_EQ(fem.step(&through), FrameStatus::ok);
  EXPECT_EQ(fem.step_cuts(), 1u);
  EXPECT_LT(fem.contact_displacement(0).norm(), 0.5 * through.norm());
  EXPECT_GT(fem.contact_displacement(0).norm(), small.norm());

  // Metres through: not even 1/16 of the step keeps every tetrahedron; nothing changes.
  const Eigen::VectorXd before = fem.displacements();
  const Eigen::Vector3d absurd(-3.0, 0, -1.0);
  EXPECT_EQ(fem.step(&absurd), FrameStatus::kept_shape);
  EXPECT_EQ(fem.displacements(), before);
}

// A state no step leads out of (every fraction of every step inverts a
// tetrahedron) is left after a second of kept frames: the organ starts again
// from rest, and the frames bring it back to the tool.
TEST(OrganFem, AnOrganThatKeepsItsShapeForASecondStartsAgainFromRest) {
  const model::OrganModel m = cylinder();
  OrganFem fem(m, MaterialModel::corotational, cap_clamp(), 1);
  ASSERT_TRUE(fem.attach(0, Eigen::Vector3d(0.05, 0.0, 0.03)));
  const Eigen::Vector3d press(0, 0, -0.004);
  for (int frame = 0; frame < 10; ++frame) ASSERT_EQ(fem.step(&press), FrameStatus::ok);
  const Eigen::VectorXd pressed = fem.displacements();
  ASSERT_GT(pressed.cwiseAbs().maxCoeff(), 1e-3);
  const Eigen::Vector3d absurd(-3.0, 0, -1.0);  // metres through the organ
  for (std::uint32_t frame = 1; frame < OrganFem::kKeptFramesBeforeRestart; ++frame) {
    ASSERT_EQ(fem.step(&absurd), FrameStatus::kept_shape) << frame;
    EXPECT_EQ(fem.displacements(), pressed) << frame;
  }
  EXPECT_EQ(fem.restarts(), 0u);
  EXPECT_EQ(fem.step(&absurd), FrameStatus::kept_shape);
  EXPECT_EQ(fem.restarts(), 1u);
  EXPECT_EQ(fem.displacements().cwiseAbs().maxCoeff(), 0.0);
  // Back at the tool, the organ settles where an organ pressed all along does.
  OrganFem undisturbed(m, MaterialModel::corotational, cap_clamp(), 1);
  ASSERT_TRUE(undisturbed.attach(0, Eigen::Vector3d(0.05, 0.0, 0.03)));
  for (int frame = 0; frame < 300; ++frame) {
    ASSERT_EQ(fem.step(&press), FrameStatus::ok) << frame;
    ASSERT_EQ(undisturbed.step(&press), FrameStatus::ok) << frame;
  }
  EXPECT_LT((fem.contact_displacement(0) - press).norm(), 1e-9);
  EXPECT_LT((fem.displacements() - undisturbed.displacements()).cwiseAbs().maxCoeff(),
            1e-6 * undisturbed.displacements().cwiseAbs().maxCoeff());
}

TEST(OrganFem, RejectsModelsItCannotSolve) {
  model::OrganModel m = cylinder();
  EXPECT_THROW(OrganFem(m, MaterialModel::linear, OrganFemOptions{}, 1),
               std::invalid_argument);  // 10 mm: the cap centre only
  OrganFemOptions bad = cap_clamp();
  bad.psh_poisson_ratio = 0.5;
  EXPECT_THROW(OrganFem(m, MaterialModel::mooney_rivlin, bad, 1), std::invalid_argument);
  EXPECT_THROW(OrganFem(m, MaterialModel::linear, cap_clamp(), 17), std::invalid_argument);
  m.tetrahedra.clear();
  m.volume_vertices.clear();
  try {
    OrganFem(m, MaterialModel::linear, cap_clamp(), 1);
    FAIL() << "no tetrahedra accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("no tetrahedra"), std::string::npos) << e.what();
  }
}

/// The cylinder lying on supports (docs/supports.md) along its lower half
/// (z < −10 mm): contacts (unilateral) or attachments, of 2.5 × 10⁵ Pa/m.
model::OrganModel cylinder_on_supports(model::Supports::Kind kind) {
  model::OrganModel m = cylinder();
  for (const model::Point3& v : m.surface_vertices)
    m.supports.vertices.push_back(v[2] < -0.010
                                      ? std::array<double, 2>{static_cast<double>(static_cast<int>(kind)), 2.5e5}
                                      : std::array<double, 2>{0.0, 0.0});
  return m;
}

/// The force on a tool that holds the far cap's top node displaced by
/// `displacement`, after enough frames for the contacts to settle.
Eigen::Vector3d held_force(const model::OrganModel& m, const OrganFemOptions& o, const Eigen::Vector3d& displacement) {
  OrganFem fem(m, MaterialModel::linear, o, 1);
  const std::int32_t node = top_far_node(m);
  EXPECT_TRUE(fem.attach(0, point(m.volume_vertices[static_cast<std::size_t>(node)])));
  for (int frame = 0; frame < 200; ++frame) EXPECT_EQ(fem.step(&displacement), FrameStatus::ok);
  return fem.contact_force(0);
}

// A cantilever resting on its supports: pressed down into them it is much
// stiffer than clamped alone; lifted, its contacts let go and it is the
// clamped cantilever again; attached, it is held both ways.
TEST(OrganFem, SupportsPushBackWhenPressedLetGoWhenLiftedAndAttachmentsHoldBothWays) {
  const Eigen::Vector3d down(0.0, 0.0, -0.004), up(0.0, 0.0, 0.004);
  OrganFemOptions with = cap_clamp();
  with.supports = true;
  const model::OrganModel contacts = cylinder_on_supports(model::Supports::Kind::kContact);
  EXPECT_GT(OrganFem(contacts, MaterialModel::linear, with, 1).supported_node_count(), 20u);
  EXPECT_EQ(OrganFem(contacts, MaterialModel::linear, cap_clamp(), 1).supported_node_count(), 0u);
  const double clamped_down = held_force(cylinder(), cap_clamp(), down).norm();
  const double clamped_up = held_force(cylinder(), cap_clamp(), up).norm();
  const double resting_down = held_force(contacts, with, down).norm();
  const double resting_up = held_force(contacts, with, up).norm();
  RecordProperty("force_ratio_pressed", std::to_string(resting_down / clamped_down));
  EXPECT_GT(resting_down, 2.0 * clamped_down) << "the supports carry the press";
  EXPECT_NEAR(resting_up, clamped_up, 1e-4 * clamped_up) << "lifted off its contacts";
  EXPECT_NEAR(held_force(contacts, cap_clamp(), down).norm(), clamped_down, 1e-9 * clamped_down)
      << "supports off: the clamp alone";
  const model::OrganModel attached = cylinder_on_supports(model::Supports::Kind::kAttachment);
  EXPECT_GT(held_force(attached, with, up).norm(), 2.0 * clamped_up) << "attachments hold when lifted";
}

}  // namespace
}  // namespace organsim::fem
