// The contact responses (contact_responses.h) against A⁻¹ formed by dense
// solves: couplings eₛᵀ A⁻¹ eₜ, projections eₛᵀ A⁻¹ r and the step
// A⁻¹ (r + Σ eₛ cₛ), with supernodal factors (double and single precision,
// positive definite and PSH's quasi-definite tangent) and with full responses;
// responses re-solved into a slot replace the old ones.
#include "organsim/fem/contact_responses.h"

#include <gtest/gtest.h>

#include <array>
#include <vector>

#include <Eigen/Dense>

#include "organsim/fem/elasticity_system.h"
#include "organsim/fem/tet_mesh.h"

namespace organsim::fem {
namespace {

/// A factorization without a supernodal factor: full responses.
class DenseFactorization final : public Factorization {
 public:
  void analyze(const SparseMatrix&) override {}
  bool factorize(const SparseMatrix& matrix) override {
    lu_.compute(Eigen::MatrixXd(matrix));
    return true;
  }
  Eigen::Index negative_pivots() const noexcept override { return 0; }
  void solve(const Eigen::Ref<const Eigen::VectorXd>& rhs, Eigen::Ref<Eigen::VectorXd> solution) noexcept override {
    solution = lu_.solve(rhs);
  }
  bool realtime_solve() const noexcept override { return false; }
  std::size_t factor_nonzeros() const noexcept override { return 0; }
  const char* name() const noexcept override { return "dense LU (test)"; }

 private:
  Eigen::PartialPivLU<Eigen::MatrixXd> lu_;
};

struct Case {
  const char* name;
  Material material;
  bool single_precision;
  bool dense;
};

/// A box held at x = 0, its tangent slightly deformed (pressures too, for PSH).
SparseMatrix box_tangent(const Material& material, std::unique_ptr<ElasticitySystem>& system) {
  const TetMesh mesh = box_mesh({5, 3, 3}, {0.05, 0.03, 0.03});
  std::vector<bool> constrained(3 * mesh.nodes.size(), false);
  for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
    if (mesh.nodes[n].x() < 1e-9) constrained[3 * n] = constrained[3 * n + 1] = constrained[3 * n + 2] = true;
  system = std::make_unique<ElasticitySystem>(mesh, material, constrained);
  Eigen::VectorXd x = Eigen::VectorXd::Zero(system->dof_count()), gradient(system->dof_count());
  for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
    x[static_cast<Eigen::Index>(3 * n + 2)] = 0.05 * mesh.nodes[n].x() * mesh.nodes[n].x();
  system->assemble(x, gradient, true);
  return system->tangent_free();
}

TEST(ContactResponses, CouplingsProjectionsAndStepsAreThoseOfTheInverse) {
  for (const Case& c :
       {Case{"corotational, double", Material::from_young(MaterialModel::corotational, 5000, 0.45), false, false},
        Case{"corotational, single", Material::from_young(MaterialModel::corotational, 5000, 0.45), true, false},
        Case{"psh, single", Material::mooney_rivlin_from_young(5000, 0.49, 100), true, false},
        Case{"psh, full responses", Material::mooney_rivlin_from_young(5000, 0.49, 100), false, true}}) {
    SCOPED_TRACE(c.name);
    std::unique_ptr<ElasticitySystem> system;
    const SparseMatrix a = box_tangent(c.material, system);
    std::unique_ptr<Factorization> f = c.dense ? std::unique_ptr<Factorization>(std::make_unique<DenseFactorization>())
                                               : make_simplicial_factorization(c.single_precision);
    f->analyze(a);
    ASSERT_TRUE(f->factorize(a));
    EXPECT_EQ(f->supernodal_factor() == nullptr, c.dense);
    const Eigen::MatrixXd inverse = Eigen::MatrixXd(a).inverse();
    // Single precision: solves to about 1e-7 relative.
    const double tolerance = c.single_precision ? 1e-5 : 1e-9;

    // Three slots: a node, a patch (twelve nodes with unequal weights), and a
    // node of the far end; slot 0 is first solved for another node, then
    // replaced.
    struct Load {
      std::vector<std::array<std::int32_t, 3>> dofs;
      std::vector<double> weights;
      PointLoad view() const { return {dofs.data(), weights.data(), dofs.size()}; }
    };
    auto add_node = [&](Load& load, std::size_t node, double weight) {
      load.weights.push_back(weight);
      load.dofs.push_back({});
      for (std::size_t k = 0; k < 3; ++k) load.dofs.back()[k] = system->free_index()[3 * node + k];
    };
    auto node_load = [&](std::int32_t node) {
      Load load;
      add_node(load, static_cast<std::size_t>(node), 1.0);
      return load;
    };
    // Nodes by their place: the free end's corner and one halfway along.
    const Points& at = system->mesh().nodes;
    const std::size_t nodes = at.size();
    std::int32_t halfway = 0;
    for (std::size_t n = 0; n < nodes; ++n)
      if (std::abs(at[n].x() - 0.02) < 1e-9) halfway = static_cast<std::int32_t>(n);
    ASSERT_GE(system->free_index()[3 * static_cast<std::size_t>(halfway)], 0);
    ASSERT_GT(at[nodes - 1].x(), 0.049);
    std::array<Load, 3> loads{node_load(static_cast<std::int32_t>(nodes - 1)), Load{}, node_load(halfway)};
    for (std::size_t i = 0; i < 12; ++i) add_node(loads[1], nodes - 2 - i, (1.0 + static_cast<double>(i)) / 78.0);
    auto columns = [&](const Load& load) {
      Eigen::MatrixX3d e = Eigen::MatrixX3d::Zero(a.rows(), 3);
      for (std::size_t i = 0; i < load.dofs.size(); ++i)
        for (std::size_t k = 0; k < 3; ++k)
          if (load.dofs[i][k] >= 0) e(load.dofs[i][k], static_cast<Eigen::Index>(k)) += load.weights[i];
      return e;
    };

    auto responses = ContactResponses::make(*f, a.rows(), 3);
    responses->respond(0, node_load(static_cast<std::int32_t>(nodes - 3)).view());
    for (std::size_t s = 0; s < 3; ++s) responses->respond(s, loads[s].view());
    for (std::size_t s = 0; s < 3; ++s)
      for (std::size_t t = 0; t < 3; ++t) {
        const Eigen::Matrix3d expected = columns(loads[s]).transpose() * inverse * columns(loads[t]);
        EXPECT_LT((responses->coupling(s, t) - expected).norm(), tolerance * expected.norm()) << s << ", " << t;
      }

    const Eigen::VectorXd r =
        Eigen::VectorXd::LinSpaced(a.rows(), -1.0, 2.0).cwiseProduct(a.diagonal().cwiseAbs().cwiseSqrt());
    responses->begin_step(r);
    const Eigen::VectorXd unconstrained = inverse * r;
    for (std::size_t s = 0; s < 3; ++s) {
      const Eigen::Vector3d expected = columns(loads[s]).transpose() * unconstrained;
      EXPECT_LT((responses->projected(s) - expected).norm(), tolerance * expected.norm()) << s;
    }
    const Eigen::Vector3d c0(1.0, -2.0, 0.5), c2(0.0, 3.0, -1.0);
    responses->add(0, c0);
    responses->add(2, c2);
    Eigen::VectorXd step(a.rows());
    responses->finish_step(step);
    const Eigen::VectorXd expected = inverse * (r + columns(loads[0]) * c0 + columns(loads[2]) * c2);
    EXPECT_LT((step - expected).norm(), tolerance * expected.norm());
  }
}

}  // namespace
}  // namespace organsim::fem
