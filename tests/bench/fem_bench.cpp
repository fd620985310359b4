// FEM speed, one thread: per material, the gradient (internal forces) and the
// tangent assembly (CorotationalStress: the co-rotational stresses alone, one
// tetrahedron at a time or in SIMD lanes), the factorization and one solve with it, on the paper's
// curved tube (408 nodes, 1,152 tetrahedra), on a liver-sized box (3,179
// nodes, 15,360 tetrahedra) clamped at its x = 0 face, and — when
// ORGANSIM_BENCH_MODEL names a baked model — on its tetrahedra clamped as the
// engine clamps them (10 mm ball). A real-time frame (fem/organ_fem.h) costs
// one gradient and one solve; a full Newton iteration (NewtonIteration) is the
// tangent, the factorization and one solve. `solver` 0 is Eigen's simplicial
// LDLᵀ, 1 the direct library's (CHOLMOD / MUMPS; built with it only). The
// "nnz(L)" counter is the factor's size, which sets the solve's memory traffic
// (16 bytes per entry: value and index). FrameSolve times the frames' solve
// (`columns:1`; `columns:0` the same in parts, as a frame with contacts takes
// it, contact_responses.h; `columns:3` a contact's three directions in one
// pass), ContactResponse the sparse forward solve that replaced those three
// columns for a node a contact takes in. PshPress (with a baked model) is the
// PSH paper's figure (Ogata et al.): fem_paper's press of the model's top
// (top_press_problem) with PSH (E = 1 MPa, ν = 0.49, β = 100), solved as
// `organsim fem` solves it (kept factorization and GMRES), timed per Newton
// iteration. FrameEstimate (with ORGANSIM_BENCH_ESTIMATE_MODELS, a
// comma-separated list of baked models) checks the frame time a FEM model
// estimates when it is set up (DeformationModel::estimated_frame_seconds, what
// `replay` warns with) against the p50 of the frames of a 5 mm press: within a
// factor of 2; PeerStep (same list) times the interactive step of Vega FEM's
// simulator (stiffness_warping_peer.h) beside our co-rotational frames on that
// mesh.
#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <memory>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include <benchmark/benchmark.h>

#include "machine_limits.h"
#include "stiffness_warping_peer.h"

#include "constitutive.h"
#include "organsim/fem/contact_responses.h"
#include "organsim/fem/elasticity_system.h"
#include "organsim/fem/factorization.h"
#include "organsim/organ_fem/organ_fem.h"
#include "organsim/multibeam/multibeam.h"
#include "organsim/fem/static_solver.h"
#include "organsim/fem/tet_mesh.h"
#include "organsim/model/model_file.h"
#include "organsim/organ/organ.h"
#include "organsim/realtime/model_registry.h"
#ifdef ORGANSIM_HAVE_FEM_DIRECT
#include "organsim/fem_direct/direct_factorizations.h"
#endif
#ifdef ORGANSIM_CHOOSES_BLAS_KERNELS
#include "blas_kernels.h"
#endif

namespace {

using namespace organsim::fem;

constexpr MaterialModel kMaterials[] = {MaterialModel::linear, MaterialModel::corotational, MaterialModel::stvk,
                                        MaterialModel::mooney_rivlin};

const char* bench_model() { return std::getenv("ORGANSIM_BENCH_MODEL"); }

/// The baked model's tetrahedra (m) and its fixed point.
struct BakedMesh {
  TetMesh mesh;
  Eigen::Vector3d fixed_point = Eigen::Vector3d::Zero();
};

const BakedMesh& baked_mesh() {
  static const BakedMesh baked = [] {
    BakedMesh b;
    auto read = organsim::model::read_organ_model_file(bench_model());
    if (!read) throw std::runtime_error(read.error);
    const organsim::organ::Organ organ(std::move(*read.model));  // in metres
    for (const auto& p : organ.model().volume_vertices) b.mesh.nodes.emplace_back(p[0], p[1], p[2]);
    for (const auto& t : organ.model().tetrahedra)
      b.mesh.tetrahedra.push_back({static_cast<std::int32_t>(t[0]), static_cast<std::int32_t>(t[1]),
                                   static_cast<std::int32_t>(t[2]), static_cast<std::int32_t>(t[3])});
    const auto& f = organ.model().fixed_points[0];
    b.fixed_point = {f[0], f[1], f[2]};
    return b;
  }();
  return baked;
}

TetMesh mesh_for(int which) {
  if (which == 2) return baked_mesh().mesh;
  return which == 0 ? curved_tube(TubeOptions{}) : box_mesh({16, 16, 10}, {0.16, 0.16, 0.10});
}

bool held(int which, const TetMesh& mesh, std::size_t n) {
  if (which == 2) return (mesh.nodes[n] - baked_mesh().fixed_point).norm() <= 0.010;
  return which == 0 ? mesh.nodes[n].z() > mesh.nodes[0].z() - 1e-9 : mesh.nodes[n].x() < 1e-9;
}

std::unique_ptr<Factorization> factorization_for(int solver, const ElasticitySystem& system) {
  const MatrixKind kind = system.has_pressure() ? MatrixKind::quasi_definite : MatrixKind::positive_definite;
#ifdef ORGANSIM_HAVE_FEM_DIRECT
  if (solver == 1) return direct_factorization(kind, SolveUse::newton);
#endif
  (void)kind;
  (void)solver;
  return make_simplicial_factorization();
}

struct Setup {
  TetMesh mesh;
  std::unique_ptr<ElasticitySystem> system;
  Eigen::VectorXd state, gradient;

  Setup(int which, MaterialModel model) : mesh(mesh_for(which)) {
    std::vector<bool> clamped(3 * mesh.nodes.size(), false);
    for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
      if (held(which, mesh, n)) clamped[3 * n] = clamped[3 * n + 1] = clamped[3 * n + 2] = true;
    const Material material = model == MaterialModel::mooney_rivlin
                                  ? Material::mooney_rivlin_from_young(5000, 0.49, 100)
                                  : Material::from_young(model, 5000, 0.45);
    system = std::make_unique<ElasticitySystem>(mesh, material, clamped);
    // A small deformation, so that the nonlinear materials do real work.
    state = Eigen::VectorXd::Zero(system->dof_count());
    const Eigen::Vector3d origin = mesh.nodes[0];
    for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
      if (system->free_index()[3 * n] >= 0)
        state[static_cast<Eigen::Index>(3 * n + 1)] = 0.01 * (mesh.nodes[n] - origin).squaredNorm();
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

/// The co-rotational stress of every tetrahedron at the deformed state: one
/// at a time (evaluate_material, `lanes:1`) or kStressLanes at a time in SIMD
/// lanes (corotational_stress_lanes, `lanes:8`, what a frame's gradient uses).
void CorotationalStress(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)), MaterialModel::corotational);
  const Constitutive material(s.system->material());
  const std::size_t tets = s.mesh.tetrahedra.size(), blocks = (tets + kStressLanes - 1) / kStressLanes;
  std::vector<std::array<std::array<double, kStressLanes>, 9>> gradients(blocks);
  std::vector<Eigen::Matrix3d> one_by_one(tets);
  for (std::size_t e = 0; e < blocks * kStressLanes; ++e) {
    const Eigen::Matrix3d F = e < tets ? s.system->deformation_gradient(s.state, e) : Eigen::Matrix3d::Identity();
    if (e < tets) one_by_one[e] = F;
    for (int k = 0; k < 9; ++k)
      gradients[e / kStressLanes][static_cast<std::size_t>(k)][e % kStressLanes] = F(k % 3, k / 3);
  }
  double F[9][kStressLanes], P[9][kStressLanes];
  Eigen::Matrix3d stress;
  for (auto _ : state) {
    if (state.range(1) == 1) {
      for (const Eigen::Matrix3d& f : one_by_one) {
        evaluate_material(material, f, 0.0, stress, nullptr);
        benchmark::DoNotOptimize(stress.data());
      }
    } else {
      for (const auto& block : gradients) {
        for (int k = 0; k < 9; ++k)
          for (int l = 0; l < kStressLanes; ++l)
            F[k][l] = block[static_cast<std::size_t>(k)][static_cast<std::size_t>(l)];
        corotational_stress_lanes(material, F, P);
        benchmark::DoNotOptimize(P[0]);
      }
    }
  }
  state.counters["tets"] = static_cast<double>(tets);
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
  const auto factorization = factorization_for(static_cast<int>(state.range(2)), *s.system);
  factorization->analyze(s.system->tangent_free());
  for (auto _ : state)
    if (!factorization->factorize(s.system->tangent_free())) state.SkipWithError("factorization failed");
  state.counters["unknowns"] = static_cast<double>(s.system->free_count());
  state.counters["nnz(L)"] = static_cast<double>(factorization->factor_nonzeros());
}

void Solve(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)), kMaterials[state.range(1)]);
  s.system->assemble(s.state, s.gradient, true);
  const auto factorization = factorization_for(static_cast<int>(state.range(2)), *s.system);
  factorization->analyze(s.system->tangent_free());
  if (!factorization->factorize(s.system->tangent_free())) state.SkipWithError("factorization failed");
  const Eigen::VectorXd rhs = Eigen::VectorXd::Ones(s.system->free_count());
  Eigen::VectorXd x(s.system->free_count());
  for (auto _ : state) {
    factorization->solve(rhs, x);
    benchmark::DoNotOptimize(x.data());
  }
  // The factor is read twice (forward and backward), value and index per entry.
  const double bytes = 16.0 * 2.0 * static_cast<double>(factorization->factor_nonzeros());
  state.counters["GB/s"] = benchmark::Counter(bytes, benchmark::Counter::kIsIterationInvariantRate);
  state.counters["x_memory_limit"] = organsim::bench::times_memory_limit(bytes);
}

/// The frames' factorization of `s`'s tangent (FrameSolve's), factorized,
/// with what the factorization took in the `factorize_ms` counter.
std::unique_ptr<Factorization> frame_factorization(Setup& s, benchmark::State& state) {
  s.system->assemble(s.state, s.gradient, true);
  const MatrixKind kind = s.system->has_pressure() ? MatrixKind::quasi_definite : MatrixKind::positive_definite;
#ifdef ORGANSIM_HAVE_FEM_DIRECT
  auto factorization = make_factorization(direct_factorization, kind, SolveUse::realtime_iteration);
#else
  auto factorization = make_factorization(nullptr, kind, SolveUse::realtime_iteration);
#endif
  factorization->analyze(s.system->tangent_free());
  const auto factorize_start = std::chrono::steady_clock::now();
  if (!factorization->factorize(s.system->tangent_free())) state.SkipWithError("factorization failed");
  // What a refresh of the frames' tangent costs (the worker's, for the co-rotational and St. VK models).
  state.counters["factorize_ms"] =
      1e3 * std::chrono::duration<double>(std::chrono::steady_clock::now() - factorize_start).count();
  return factorization;
}

/// The solve a real-time frame of OrganFem makes (fem/organ_fem.h): the
/// factorization it keeps for a nonlinear material (SolveUse::realtime_iteration:
/// CHOLMOD's supernodal LLᵀ, solved in single precision, for the
/// displacement-only materials where the direct library is built, otherwise
/// and for PSH the simplicial LDLᵀ with
/// supernodal solves in single precision, in CHOLMOD's ordering where the
/// direct library is built), one right-hand side or a contact's three.
void FrameSolve(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)), kMaterials[state.range(1)]);
  const auto factorization = frame_factorization(s, state);
  const Eigen::MatrixX3d rhs = Eigen::MatrixX3d::Ones(s.system->free_count(), 3);
  Eigen::MatrixX3d x(s.system->free_count(), 3);
  const auto responses = ContactResponses::make(*factorization, s.system->free_count(), 1);
  for (auto _ : state) {
    if (state.range(2) == 3) {
      factorization->solve3(rhs, x);
    } else if (state.range(2) == 1) {
      factorization->solve(rhs.col(0), x.col(0));
    } else {  // a frame's step, solved in parts (contact_responses.h)
      responses->begin_step(rhs.col(0));
      responses->finish_step(x.col(0));
    }
    benchmark::DoNotOptimize(x.data());
  }
  state.counters["nnz(L)"] = static_cast<double>(factorization->factor_nonzeros());
  state.SetLabel(factorization->name());
}

/// A contact point's response (contact_responses.h) with the frames'
/// factorization: a node of the free end (the box's x = max face; the baked
/// model's node farthest from its clamp), as a finite tip takes it in. With a
/// supernodal factor, a sparse forward solve; FrameSolve's `columns:3` is the
/// full three-column solve it replaces.
void ContactResponse(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)), kMaterials[state.range(1)]);
  const auto factorization = frame_factorization(s, state);
  const auto responses = ContactResponses::make(*factorization, s.system->free_count(), 24);
  std::size_t node = 0;
  const Eigen::Vector3d origin = s.mesh.nodes[0];
  for (std::size_t n = 0; n < s.mesh.nodes.size(); ++n)
    if (s.system->free_index()[3 * n] >= 0 && (s.mesh.nodes[n] - origin).norm() > (s.mesh.nodes[node] - origin).norm())
      node = n;
  std::array<std::int32_t, 3> dofs{};
  const double weight = 1.0;
  for (std::size_t k = 0; k < 3; ++k) dofs[k] = s.system->free_index()[3 * node + k];
  const PointLoad load{&dofs, &weight, 1};
  for (std::size_t slot = 1; slot < 24; ++slot) responses->respond(slot, load);  // others to couple with, as a tip's
  for (auto _ : state) responses->respond(0, load);
  state.SetLabel(factorization->supernodal_factor() ? "sparse forward solve" : "full three-column solve");
}

/// One full Newton iteration: gradient and tangent, factorization, solve.
void NewtonIteration(benchmark::State& state) {
  Setup s(static_cast<int>(state.range(0)), kMaterials[state.range(1)]);
  s.system->assemble(s.state, s.gradient, true);
  const auto factorization = factorization_for(static_cast<int>(state.range(2)), *s.system);
  factorization->analyze(s.system->tangent_free());
  Eigen::VectorXd rhs(s.system->free_count()), x(s.system->free_count());
  for (auto _ : state) {
    s.system->assemble(s.state, s.gradient, true);
    if (!factorization->factorize(s.system->tangent_free())) state.SkipWithError("factorization failed");
    for (Eigen::Index d = 0, j = 0; d < s.system->dof_count(); ++d)
      if (s.system->free_index()[static_cast<std::size_t>(d)] >= 0) rhs[j++] = -s.gradient[d];
    factorization->solve(rhs, x);
    benchmark::DoNotOptimize(x.data());
  }
  state.SetLabel(factorization->name());
}

/// Time per Newton iteration of the press, without the ordering's one-time
/// analysis. x_memory_limit: against reading the factor twice per solve at
/// the copy bandwidth (MUMPS keeps dense front panels: 8 bytes per entry, 4
/// for the single-precision factor GMRES refines).
void PshPress(benchmark::State& state) {
  const StaticProblem problem = top_press_problem(baked_mesh().mesh, baked_mesh().fixed_point,
                                                  Material::mooney_rivlin_from_young(1e6, 0.49, 100));
  SolverOptions options;
#ifdef ORGANSIM_HAVE_FEM_DIRECT
  options.factorization = direct_factorization;
#endif
  StaticSolution solution;
  int iterations = 0;
  for (auto _ : state) {
    solution = solve_static(problem, options);
    if (!solution.converged) state.SkipWithError(solution.error.c_str());
    iterations = 0;
    for (const int i : solution.newton_iterations) iterations += i;
    state.SetIterationTime((solution.assembly_seconds + solution.solve_seconds - solution.analysis_seconds) /
                           iterations);
  }
  ElasticitySystem system(problem.mesh, problem.material, std::vector<bool>(3 * problem.mesh.nodes.size(), false));
  Eigen::VectorXd x = Eigen::VectorXd::Zero(system.dof_count()), gradient(system.dof_count());
  system.assemble(x, gradient, true);
  const auto factorization =
      make_factorization(options.factorization, MatrixKind::quasi_definite, SolveUse::preconditioner);
  factorization->analyze(system.tangent_free());
  factorization->factorize(system.tangent_free());
  const double solves = solution.factorizations + solution.krylov_solves + solution.krylov_iterations;
  const double entry_bytes = factorization->exact() ? 8.0 : 4.0;
  const double bytes = entry_bytes * 2.0 * static_cast<double>(factorization->factor_nonzeros()) * solves / iterations;
  state.counters["newton_iterations"] = iterations;
  state.counters["factorizations"] = solution.factorizations;
  state.counters["solves"] = solves;
  state.counters["x_memory_limit"] = organsim::bench::times_memory_limit(bytes);
  state.SetLabel(solution.linear_solver);
}

/// A press at the surface vertex farthest from the clamp: a 2.5 mm tip
/// driven 5 mm in along the normal over 60 frames and held for 60.
struct Press {
  static constexpr int kFrames = 120, kRampFrames = 60;
  std::size_t site = 0;
  Eigen::Vector3d point, normal;

  explicit Press(const organsim::organ::Organ& organ) {
    const auto& vertices = organ.model().surface_vertices;
    const auto& fixed = organ.model().fixed_points[0];
    double farthest = -1.0;
    for (std::size_t v = 0; v < vertices.size(); ++v) {
      const double d = std::hypot(vertices[v][0] - fixed[0], vertices[v][1] - fixed[1], vertices[v][2] - fixed[2]);
      if (d > farthest) farthest = d, site = v;
    }
    std::vector<organsim::model::Point3> normals(vertices.size());
    organsim::organ::compute_vertex_normals(organ, vertices.data(), normals.data(), 0, vertices.size());
    point = {vertices[site][0], vertices[site][1], vertices[site][2]};
    normal = {normals[site][0], normals[site][1], normals[site][2]};
  }
  /// Of the press's full depth, how much frame `frame` asks for.
  static double ramp(int frame) { return std::min(1.0, (frame + 1.0) / kRampFrames); }
};

/// Each frame of the press through `model` as the engine steps it (s), and
/// the force the tool applied to the organ at the end (N).
std::vector<double> press_frames(organsim::realtime::DeformationModel& model, const organsim::organ::Organ& organ,
                                 const Press& press, Eigen::Vector3d& applied) {
  organsim::geometry::ToolTip tip;
  tip.radius = 2.5e-3;
  tip.axis = press.normal;
  std::array<organsim::realtime::ContactLinearization, organsim::multibeam::kMaxTools> contacts{};
  if (!model.attach(0, press.point, tip, contacts[0])) throw std::runtime_error("the press site refused the contact");
  std::vector<organsim::model::Point3> positions(organ.vertex_count()), normals(organ.vertex_count());
  std::vector<double> frames;
  for (int frame = 0; frame < Press::kFrames; ++frame) {
    const Eigen::Vector3d displacement = -5e-3 * Press::ramp(frame) * press.normal;
    const auto start = std::chrono::steady_clock::now();
    model.step(1.0 / 60.0, &displacement, positions.data(), normals.data(), contacts.data());
    frames.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  applied = -contacts[0].force;
  model.detach(0);
  return frames;
}

double quantile(std::vector<double> samples, double q) {
  std::sort(samples.begin(), samples.end());
  return samples[std::min(samples.size() - 1, static_cast<std::size_t>(q * static_cast<double>(samples.size())))];
}

organsim::organ::Organ read_organ(const std::string& path) {
  auto read = organsim::model::read_organ_model_file(path);
  if (!read) throw std::runtime_error(read.error);
  return organsim::organ::Organ(std::move(*read.model));
}

/// The options `replay` runs the FEM models with: the direct library's
/// factorizations where it is built.
organsim::realtime::ModelOptions replay_options() {
  organsim::realtime::ModelOptions options;
#ifdef ORGANSIM_HAVE_FEM_DIRECT
  options.edit<organsim::fem::OrganFemOptions>().factorization = direct_factorization;
#endif
  return options;
}

/// The frame time a FEM model estimates when it is set up against the p50
/// of the press's frames (real-time mode: a frame does not wait for the
/// tangent worker): within a factor of 2.
void FrameEstimate(benchmark::State& state, const std::string& path, const char* model_name) {
  const organsim::organ::Organ organ = read_organ(path);
  const auto setup_start = std::chrono::steady_clock::now();
  auto model = organsim::realtime::make_deformation_model(model_name, organ, replay_options(), 1);
  const double setup_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - setup_start).count();
  model->set_reproducible(false);
  const Press press(organ);
  std::vector<double> frames;
  Eigen::Vector3d applied;
  for (auto _ : state) frames = press_frames(*model, organ, press, applied);
  const double p50 = quantile(frames, 0.5), estimate = model->estimated_frame_seconds();
  state.counters["tets"] = static_cast<double>(organ.model().tetrahedra.size());
  state.counters["setup_s"] = setup_seconds;
  state.counters["p50_ms"] = p50 * 1e3;
  state.counters["p99_ms"] = quantile(frames, 0.99) * 1e3;
  state.counters["estimate_ms"] = estimate * 1e3;
  state.counters["estimate/p50"] = estimate / p50;
  if (!(estimate > 0.5 * p50 && estimate < 2.0 * p50))
    state.SkipWithError("the set-up's frame estimate is off the frames' p50 by more than a factor of 2");
}

/// Vega FEM's interactive co-rotational step (stiffness_warping_peer.h) on
/// the same tetrahedra and clamp as our co-rotational model, loaded at the
/// press site's nearest node by the force our model's press ended with
/// (ramped and held as the press), beside our frames of that press.
void PeerStep(benchmark::State& state, const std::string& path) {
  const organsim::organ::Organ organ = read_organ(path);
  const organsim::realtime::ModelOptions options = replay_options();
  auto ours = organsim::realtime::make_deformation_model("corotational", organ, options, 1);
  ours->set_reproducible(false);
  const Press press(organ);
  Eigen::Vector3d applied;
  const std::vector<double> our_frames = press_frames(*ours, organ, press, applied);

  TetMesh mesh;
  for (const auto& p : organ.model().volume_vertices) mesh.nodes.emplace_back(p[0], p[1], p[2]);
  for (const auto& t : organ.model().tetrahedra)
    mesh.tetrahedra.push_back({static_cast<std::int32_t>(t[0]), static_cast<std::int32_t>(t[1]),
                               static_cast<std::int32_t>(t[2]), static_cast<std::int32_t>(t[3])});
  const auto& f = organ.model().fixed_points[0];
  const Eigen::Vector3d fixed(f[0], f[1], f[2]);
  std::vector<bool> clamped(3 * mesh.nodes.size(), false);
  std::size_t loaded = 0;
  for (std::size_t n = 0; n < mesh.nodes.size(); ++n) {
    if ((mesh.nodes[n] - fixed).norm() <= options.of<organsim::fem::OrganFemOptions>().fixed_radius)
      clamped[3 * n] = clamped[3 * n + 1] = clamped[3 * n + 2] = true;
    if ((mesh.nodes[n] - press.point).norm() < (mesh.nodes[loaded] - press.point).norm()) loaded = n;
  }
  organsim::bench::PeerOptions peer_options;
  peer_options.young_modulus = organ.model().material.young_modulus;
  peer_options.poisson_ratio = organ.model().material.poisson_ratio;
  organsim::bench::StiffnessWarpingPeer peer(mesh, clamped, peer_options);
  Eigen::VectorXd q = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(3 * mesh.nodes.size())), v = q, external = q;
  std::vector<double> peer_steps;
  double iterations = 0;
  for (auto _ : state) {
    for (int frame = 0; frame < Press::kFrames; ++frame) {
      external.segment<3>(static_cast<Eigen::Index>(3 * loaded)) = Press::ramp(frame) * applied;
      const auto start = std::chrono::steady_clock::now();
      iterations += peer.step(q, v, external);
      peer_steps.push_back(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
    }
  }
  const double ours_p50 = quantile(our_frames, 0.5), peer_p50 = quantile(peer_steps, 0.5);
  state.counters["tets"] = static_cast<double>(organ.model().tetrahedra.size());
  state.counters["peer_p50_ms"] = peer_p50 * 1e3;
  state.counters["peer_p99_ms"] = quantile(peer_steps, 0.99) * 1e3;
  state.counters["peer_cg_iterations"] = iterations / static_cast<double>(peer_steps.size());
  state.counters["ours_p50_ms"] = ours_p50 * 1e3;
  state.counters["ours_p99_ms"] = quantile(our_frames, 0.99) * 1e3;
  state.counters["peer/ours"] = peer_p50 / ours_p50;
}

int meshes() { return bench_model() ? 3 : 2; }

void Arguments(benchmark::internal::Benchmark* b) {
  b->ArgNames({"mesh", "material"})->Unit(benchmark::kMillisecond);
  for (int mesh = 0; mesh < meshes(); ++mesh)
    for (int material = 0; material < 4; ++material) b->Args({mesh, material});
}

#ifdef ORGANSIM_HAVE_FEM_DIRECT
constexpr int kSolvers = 2;
#else
constexpr int kSolvers = 1;
#endif

void SolverArguments(benchmark::internal::Benchmark* b) {
  b->ArgNames({"mesh", "material", "solver"})->Unit(benchmark::kMillisecond);
  for (int mesh = 0; mesh < meshes(); ++mesh)
    for (int material = 0; material < 4; ++material)
      for (int solver = 0; solver < kSolvers; ++solver) b->Args({mesh, material, solver});
}

void FrameSolveArguments(benchmark::internal::Benchmark* b) {
  b->ArgNames({"mesh", "material", "columns"})->Unit(benchmark::kMillisecond);
  for (int mesh = 0; mesh < meshes(); ++mesh)
    for (int material : {1, 3})
      for (int columns : {0, 1, 3}) b->Args({mesh, material, columns});
}

void StressArguments(benchmark::internal::Benchmark* b) {
  b->ArgNames({"mesh", "lanes"})->Unit(benchmark::kMillisecond);
  for (int mesh = 0; mesh < meshes(); ++mesh)
    for (int lanes : {1, kStressLanes}) b->Args({mesh, lanes});
}

void ResponseArguments(benchmark::internal::Benchmark* b) {
  b->ArgNames({"mesh", "material"})->Unit(benchmark::kMillisecond);
  for (int mesh = 0; mesh < meshes(); ++mesh)
    for (int material : {1, 3}) b->Args({mesh, material});
}

BENCHMARK(Gradient)->Apply(Arguments);
BENCHMARK(CorotationalStress)->Apply(StressArguments);
BENCHMARK(Tangent)->Apply(Arguments);
BENCHMARK(Factorize)->Apply(SolverArguments)->Iterations(2);
BENCHMARK(Solve)->Apply(SolverArguments);
BENCHMARK(NewtonIteration)->Apply(SolverArguments)->Iterations(3);
BENCHMARK(FrameSolve)->Apply(FrameSolveArguments);
BENCHMARK(ContactResponse)->Apply(ResponseArguments);

// Only with a baked model (it is the liver's figure).
const bool press_registered =
    bench_model() &&
    benchmark::RegisterBenchmark("PshPress", PshPress)->Unit(benchmark::kMillisecond)->UseManualTime()->Iterations(1);

const bool estimates_registered = [] {
  const char* list = std::getenv("ORGANSIM_BENCH_ESTIMATE_MODELS");
  if (list == nullptr) return false;
  std::stringstream paths(list);
  for (std::string path; std::getline(paths, path, ',');) {
    for (const char* name : {"corotational", "psh"})
      benchmark::RegisterBenchmark(("FrameEstimate/" + std::string(name) + "/" + path).c_str(),
                                   [path, name](benchmark::State& state) { FrameEstimate(state, path, name); })
          ->Unit(benchmark::kMillisecond)
          ->Iterations(1);
    benchmark::RegisterBenchmark(("PeerStep/" + path).c_str(),
                                 [path](benchmark::State& state) { PeerStep(state, path); })
        ->Unit(benchmark::kMillisecond)
        ->Iterations(1);
  }
  return true;
}();

}  // namespace

int main(int argc, char** argv) {
#ifdef ORGANSIM_CHOOSES_BLAS_KERNELS
  organsim::fem::use_the_cpus_blas_kernels(argv);  // may start the program over once (blas_kernels.h)
#endif
  return organsim::bench::run_benchmarks(argc, argv);
}
