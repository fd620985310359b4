// FEM speed, one thread: per material, the gradient (internal forces) and the
// tangent assembly, the LDLᵀ factorization and one solve with it, on the
// paper's curved tube (408 nodes, 1,152 tetrahedra) and on a liver-sized box
// (3,179 nodes, 15,360 tetrahedra; the shipped liver has 4,029 and 14,904),
// clamped at its x = 0 face. A real-time frame (fem/organ_fem.h) costs one
// gradient and one solve; a full Newton iteration adds the tangent and the
// factorization. The "nnz(L)" counter is the factor's size, which sets the
// solve's memory traffic (16 bytes per entry: value and index).
#include <memory>
#include <vector>

#include <benchmark/benchmark.h>
#include <Eigen/SparseCholesky>

#include "organsim/fem/elasticity_system.h"
#include "organsim/fem/tet_mesh.h"

namespace {

using namespace organsim::fem;

constexpr MaterialModel kMaterials[] = {MaterialModel::linear, MaterialModel::corotational, MaterialModel::stvk,
                                        MaterialModel::mooney_rivlin};

TetMesh mesh_for(int which) {
  return which == 0 ? curved_tube(TubeOptions{}) : box_mesh({16, 16, 10}, {0.16, 0.16, 0.10});
}

struct Setup {
  TetMesh mesh;
  std::unique_ptr<ElasticitySystem> system;
  Eigen::VectorXd state, gradient;

  Setup(int which, MaterialModel model) : mesh(mesh_for(which)) {
    std::vector<bool> clamped(3 * mesh.nodes.size(), false);
    const double x0 = which == 0 ? mesh.nodes[0].z() : 0.0;
    for (std::size_t n = 0; n < mesh.nodes.size(); ++n) {
      const bool held = which == 0 ? mesh.nodes[n].z() > x0 - 1e-9 : mesh.nodes[n].x() < 1e-9;
      if (held) clamped[3 * n] = clamped[3 * n + 1] = clamped[3 * n + 2] = true;
    }
    const Material material = model == MaterialModel::mooney_rivlin ? Material::mooney_rivlin_from_young(5000, 0.49, 100)
                                                                   : Material::from_young(model, 5000, 0.45);
    system = std::make_unique<ElasticitySystem>(mesh, material, clamped);
    // A small deformation, so that the nonlinear materials do real work.
    state = Eigen::VectorXd::Zero(system->dof_count());
    for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
      if (system->free_index()[3 * n] >= 0) state[static_cast<Eigen::Index>(3 * n + 1)] = 0.01 * mesh.nodes[n].squaredNorm();
    gradient.resize(system->dof_count());
  }
};

void Gradient(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)), kMaterials[state.range(1)]);
  for (auto _ : state) {
    s.system->assemble(s.state, s.gradient, false);
    benchmark::DoNotOptimize(s.gradient.data());
  }
  state.counters["tets"] = static_cast<double>(s.mesh.tetrahedra.size());
}

void Tangent(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)), kMaterials[state.range(1)]);
  for (auto _ : state) {
    s.system->assemble(s.state, s.gradient, true);
    benchmark::DoNotOptimize(s.system->tangent_free().valuePtr());
  }
}

void Factorize(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)), kMaterials[state.range(1)]);
  s.system->assemble(s.state, s.gradient, true);
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt;
  ldlt.analyzePattern(s.system->tangent_free());
  for (auto _ : state) ldlt.factorize(s.system->tangent_free());
  state.counters["unknowns"] = static_cast<double>(s.system->free_count());
  state.counters["nnz(L)"] = static_cast<double>(ldlt.matrixL().nestedExpression().nonZeros());
}

void Solve(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)), kMaterials[state.range(1)]);
  s.system->assemble(s.state, s.gradient, true);
  Eigen::SimplicialLDLT<SparseMatrix, Eigen::Lower, Eigen::AMDOrdering<int>> ldlt(s.system->tangent_free());
  const Eigen::VectorXd rhs = Eigen::VectorXd::Ones(s.system->free_count());
  Eigen::VectorXd x(s.system->free_count());
  for (auto _ : state) {
    x = ldlt.solve(rhs);
    benchmark::DoNotOptimize(x.data());
  }
  const double bytes = 16.0 * 2.0 * static_cast<double>(ldlt.matrixL().nestedExpression().nonZeros());
  state.counters["GB/s"] = benchmark::Counter(bytes, benchmark::Counter::kIsIterationInvariantRate);
}

void Arguments(benchmark::internal::Benchmark* b) {
  b->ArgNames({"mesh", "material"})->Unit(benchmark::kMillisecond);
  for (int mesh = 0; mesh < 2; ++mesh)
    for (int material = 0; material < 4; ++material) b->Args({mesh, material});
}

BENCHMARK(Gradient)->Apply(Arguments);
BENCHMARK(Tangent)->Apply(Arguments);
BENCHMARK(Factorize)->Apply(Arguments)->Iterations(2);
BENCHMARK(Solve)->Apply(Arguments);

}  // namespace

BENCHMARK_MAIN();
