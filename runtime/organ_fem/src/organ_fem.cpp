#include "organsim/organ_fem/organ_fem.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>
#include <atomic>
#include <pthread.h>
#include <sched.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

#include "organsim/fem/contact_responses.h"
#include "organsim/organ/organ.h"

namespace organsim::fem {
namespace {

constexpr std::size_t kMaxTools = 16;
// Eigen keeps a fixed-capacity matrix within its stack allocation limit
// (128 KiB): W of at most 120 rows (120 sliding points, 40 point tools).
constexpr std::size_t kMaxConstraintRows = 3 * OrganFem::kMaxHolds;
constexpr std::size_t kMaxContactNodes = 256;
static_assert(OrganFem::kMaxPatchNodes <= PointLoad::kMaxNodes, "a patch's load spreads over its nodes");
// A grasped patch's area: each boundary face cut into this many sub-triangles
// per edge, each counted inside the tip's radius by its centroid.
constexpr int kPatchSubdivisions = 8;
// Candidate contact points per frame before the deepest are kept.
constexpr std::size_t kMaxCandidates = 512;
constexpr int kMaxStepCuts = 4;  // the smallest step tried: 1/16 of the iteration's
// A step may at most double a frame's out-of-balance force scale (a damped
// iteration that converges shrinks the imbalance; see iterate()); below
// 0.1 mN, under what a haptic device renders, an imbalance counts as 0.1 mN.
constexpr double kMaxImbalanceGrowth = 2.0;
constexpr double kNegligibleImbalance = 1e-4;  // N
// Frames that shrank the imbalance before a shortened step doubles back:
// half a second at 60 Hz, so that a step that still diverges is retried (one
// more assembly in that frame) at most twice a second.
constexpr std::uint32_t kSteadyFrames = 30;
constexpr double kRestTangentImbalanceShare = 0.25;  // of the frame's force scale: see iterate()
using SmallMatrix =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxConstraintRows, kMaxConstraintRows>;
using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxConstraintRows, 1>;
using ToolColumns = Eigen::Matrix<double, Eigen::Dynamic, 3, Eigen::ColMajor, kMaxConstraintRows, 3>;
// Alternating projections between a face and the capsule's axis: the pair of
// closest points of two convex sets (the hemisphere's centre is the answer
// for every face in front of the tip, found in the first pass).
constexpr int kClosestPairPasses = 4;
// A boundary point deeper inside a tip than this many radii is pushed out
// ahead of it, not to the nearest part of its surface.
constexpr double kPiercedDepth = 0.5;
// A boundary point a tip takes in must put at least this much of its weight
// on nodes the tool does not hold yet.
constexpr double kFreshWeight = 0.25;
// Nor may its place on the tip lie nearer a held point's than this fraction
// of the two points' distance in the organ now (see OrganFem::crowds_a_hold).
constexpr double kMaxTakeCompression = 0.5;

Eigen::Vector3d point(const model::Point3& p) { return {p[0], p[1], p[2]}; }

}  // namespace

/// A factorized tangent and, per node slot, the response A⁻¹ e of the node
/// it was solved for (contact_responses.h).
struct OrganFem::Tangent {
  std::unique_ptr<Factorization> factorization;
  std::unique_ptr<ContactResponses> responses;  ///< made at the first factorization
  std::vector<std::uint64_t> keys;              ///< per slot: the node slot generation of its response (0: none)
  Eigen::VectorXd warm_up;

  Tangent(const SparseMatrix& pattern, std::size_t slots, std::unique_ptr<Factorization> made)
      : factorization(std::move(made)), keys(slots, 0), warm_up(pattern.rows()) {
    factorization->analyze(pattern);
  }

  /// Factorizes `tangent` (same pattern); false when a pivot is zero or not
  /// finite, or when the inertia is not that of a stable equilibrium's tangent:
  /// positive definite, or for psh quasi-definite with exactly one negative
  /// pivot per pressure (Sylvester: LDLᵀ keeps the inertia under any ordering).
  /// A tangent that fails (a buckling or unstable state) would drive the next
  /// iterations away from equilibrium; the kept one serves instead. A first
  /// step's solve readies the factorization's real-time solves.
  bool factorize(const SparseMatrix& tangent, Eigen::Index negative_pivots) {
    std::fill(keys.begin(), keys.end(), 0);  // the responses were solved with another factorization
    if (!factorization->factorize(tangent) || factorization->negative_pivots() != negative_pivots) return false;
    if (!responses) responses = ContactResponses::make(*factorization, tangent.rows(), keys.size());
    responses->clear();
    warm_up.setZero();
    responses->begin_step(warm_up);
    responses->finish_step(warm_up);
    return true;
  }
};

/// The holds' capacitance matrix W and its factorization.
struct OrganFem::Capacitance {
  Eigen::Index rows = 0;
  SmallMatrix matrix;
  Eigen::LDLT<SmallMatrix> ldlt;
  SmallVector gap, multipliers;
  ToolColumns sums, solved;
};

/// Refactors the tangent at a snapshot of the state on its own thread. The
/// owner's thread and the worker hand the snapshot and the spare tangent over
/// through `phase_` (acquire/release): the worker touches them only while a
/// refresh is requested.
class OrganFem::Worker {
 public:
  Worker(const OrganFem& owner, const ElasticitySystem& system, std::unique_ptr<Tangent> spare)
      : owner_(owner),
        system_(system),
        snapshot_(Eigen::VectorXd::Zero(system.dof_count())),
        gradient_(system.dof_count()),
        slots_(owner.node_slots_.size()),
        patches_(owner.patches_.size()),
        spare_(std::move(spare)),
        thread_([this] { run(); }) {
    // PSH keeps its exact tangent here: its saddle-point form factorizes
    // wherever the state is stable, and projecting every element's tangent
    // (a 9 × 9 eigen-decomposition each) would slow every refresh.
    system_.set_definite_tangent(!system.has_pressure());
  }
  ~Worker() {
    stop_.store(true, std::memory_order_release);
    thread_.join();
  }

  /// Owner: starts a refresh at `state` for the nodes in `slots`.
  void request(const Eigen::VectorXd& state, const std::vector<NodeSlot>& slots,
               const std::vector<Patch>& patches) noexcept {
    snapshot_ = state;  // same sizes: copies, no allocation
    std::copy(slots.begin(), slots.end(), slots_.begin());
    std::copy(patches.begin(), patches.end(), patches_.begin());
    phase_.store(kRequested, std::memory_order_release);
  }
  /// Owner: waits for the requested refresh; true with `spare()` holding the
  /// fresh tangent, false when the tangent at the snapshot was unusable.
  bool wait() noexcept {
    // Sleep, not yield: the deformation loop runs with real-time priority,
    // and a yielding real-time thread would keep the worker off its CPU.
    while (phase_.load(std::memory_order_acquire) == kRequested)
      std::this_thread::sleep_for(std::chrono::microseconds(100));
    return phase_.load(std::memory_order_acquire) == kReady;
  }
  /// Owner: true when the requested refresh is done and usable (the owner
  /// may then work on `spare()`), without waiting.
  bool ready() const noexcept { return phase_.load(std::memory_order_acquire) == kReady; }
  /// Owner: true when the requested refresh is done, usable or not.
  bool finished() const noexcept { return phase_.load(std::memory_order_acquire) != kRequested; }
  std::unique_ptr<Tangent>& spare() noexcept { return spare_; }
  /// Owner: the result is taken; the worker may be asked again.
  void release() noexcept { phase_.store(kIdle, std::memory_order_release); }

 private:
  static constexpr int kIdle = 0, kRequested = 1, kReady = 2, kFailed = 3;

  void run() {
    // The lowest priority (SCHED_IDLE): the worker takes what the loops
    // leave. On the 2-vCPU VM, as an ordinary thread it made the co-rotational
    // liver's frame p99 27–88 ms (the scheduler now and then put the
    // deformation loop's work behind it); as an idle-class thread, 10–15 ms.
    sched_param idle{};
    pthread_setschedparam(pthread_self(), SCHED_IDLE, &idle);
    while (!stop_.load(std::memory_order_acquire)) {
      if (phase_.load(std::memory_order_acquire) != kRequested) {
        std::this_thread::sleep_for(std::chrono::microseconds(500));
        continue;
      }
      bool ok = system_.assemble(snapshot_, gradient_, true) < 0 &&
                spare_->factorize(system_.tangent_free(), owner_.pressure_count());
      if (ok)
        for (std::size_t slot = 0; slot < slots_.size(); ++slot)
          if (slots_[slot].node >= 0 && slots_[slot].held) owner_.respond(*spare_, slot, slots_[slot], patches_);
      phase_.store(ok ? kReady : kFailed, std::memory_order_release);
    }
  }

  const OrganFem& owner_;
  ElasticitySystem system_;  // its own: assembling the tangent writes the system's matrices
  Eigen::VectorXd snapshot_, gradient_;
  std::vector<NodeSlot> slots_;
  std::vector<Patch> patches_;
  std::unique_ptr<Tangent> spare_;
  std::atomic<int> phase_{kIdle};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

TetMesh tet_mesh_of(const model::OrganModel& model) {
  TetMesh mesh;
  mesh.nodes.reserve(model.volume_vertices.size());
  for (const model::Point3& p : model.volume_vertices) mesh.nodes.push_back(point(p));
  mesh.tetrahedra.reserve(model.tetrahedra.size());
  for (const model::Tetrahedron& t : model.tetrahedra)
    mesh.tetrahedra.push_back({static_cast<std::int32_t>(t[0]), static_cast<std::int32_t>(t[1]),
                               static_cast<std::int32_t>(t[2]), static_cast<std::int32_t>(t[3])});
  return mesh;
}

std::vector<FoundationSpring> foundation_springs(const model::OrganModel& model, const std::vector<bool>& constrained,
                                                 const geometry::TetrahedralBoundary& boundary) {
  if (model.supports.vertices.size() != model.surface_vertices.size()) return {};
  const std::size_t nodes = model.volume_vertices.size();
  std::vector<double> area(nodes, 0.0);
  std::vector<Eigen::Vector3d> normal(nodes, Eigen::Vector3d::Zero());
  for (std::size_t f = 0; f < boundary.faces.size(); ++f) {
    const model::Triangle& face = boundary.faces[f];
    const Eigen::Vector3d a = point(model.volume_vertices[face[0]]), b = point(model.volume_vertices[face[1]]),
                          c = point(model.volume_vertices[face[2]]);
    Eigen::Vector3d twice_area = (b - a).cross(c - a);
    // Outward: away from the owner's fourth node.
    for (const std::uint32_t corner : model.tetrahedra[boundary.owners[f]])
      if (corner != face[0] && corner != face[1] && corner != face[2] &&
          twice_area.dot(point(model.volume_vertices[corner]) - a) > 0)
        twice_area = -twice_area;
    for (const std::uint32_t v : face) area[v] += twice_area.norm() / 6.0, normal[v] += twice_area;
  }
  std::vector<FoundationSpring> springs;
  for (std::size_t n = 0; n < nodes; ++n) {
    if (!(area[n] > 0.0) || constrained[3 * n] || !(normal[n].norm() > 0.0)) continue;
    const Eigen::Vector3d at = point(model.volume_vertices[n]);
    std::size_t nearest = 0;
    double best = std::numeric_limits<double>::infinity();
    for (std::size_t v = 0; v < model.surface_vertices.size(); ++v)
      if (const double d = (point(model.surface_vertices[v]) - at).squaredNorm(); d < best) best = d, nearest = v;
    const model::Supports::Kind kind = model.supports.kind(nearest);
    if (kind == model::Supports::Kind::kFree) continue;
    springs.push_back({static_cast<std::int32_t>(n), model.supports.modulus(nearest) * area[n], normal[n].normalized(),
                       kind == model::Supports::Kind::kContact});
  }
  return springs;
}

std::vector<bool> clamped_dofs(const model::OrganModel& model, double fixed_radius) {
  if (model.fixed_points.empty()) throw std::invalid_argument("the model has no fixed point to clamp the FEM model at");
  // The clamp: a ball of nodes; three of them not on one line hold the body.
  const Eigen::Vector3d fixed_point = point(model.fixed_points[0]);
  std::vector<bool> constrained(3 * model.volume_vertices.size(), false);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> clamped;
  for (std::size_t n = 0; n < model.volume_vertices.size(); ++n)
    if (const Eigen::Vector3d at = point(model.volume_vertices[n]);
        organ::within_clamp(at, fixed_point, fixed_radius)) {
      clamped.push_back(at);
      mean += at;
      constrained[3 * n] = constrained[3 * n + 1] = constrained[3 * n + 2] = true;
    }
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
  if (!clamped.empty()) mean /= static_cast<double>(clamped.size());
  for (const Eigen::Vector3d& at : clamped) spread += (at - mean) * (at - mean).transpose();
  const Eigen::Vector3d spread_eigen = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(spread).eigenvalues();
  if (clamped.size() < 3 || !(std::sqrt(std::max(spread_eigen[1], 0.0)) > 1e-3 * fixed_radius))
    throw std::invalid_argument("only " + std::to_string(clamped.size()) +
                                " tetrahedral node(s) lie within the clamp radius of the fixed point, not three off "
                                "one line: raise the clamp radius (--fixed-radius)");
  return constrained;
}

OrganFem::OrganFem(const model::OrganModel& model, MaterialModel material, const OrganFemOptions& options,
                   std::size_t tools)
    : capacitance_(std::make_unique<Capacitance>()) {
  if (model.tetrahedra.empty() || model.volume_vertices.empty())
    throw std::invalid_argument("the model has no tetrahedra: re-bake it with organsim bake, which meshes the volume");
  if (model.fixed_points.empty()) throw std::invalid_argument("the model has no fixed point to clamp the FEM model at");
  if (!(options.fixed_radius > 0) || !std::isfinite(options.fixed_radius))
    throw std::invalid_argument("the FEM clamp radius must be a finite length > 0");
  if (!(options.psh_poisson_ratio > 0 && options.psh_poisson_ratio < 0.5))
    throw std::invalid_argument("the psh Poisson's ratio must lie in (0, 0.5)");
  if (!(options.relaxation > 0 && options.relaxation <= 1))
    throw std::invalid_argument("the FEM relaxation must lie in (0, 1]");
  if (!(options.stabilization >= 0) || !std::isfinite(options.stabilization))
    throw std::invalid_argument("the psh stabilization beta must be a finite number >= 0");
  if (tools == 0 || tools > kMaxTools) throw std::invalid_argument("the FEM model takes 1 to 16 tools");
  if (options.max_contact_nodes > kMaxContactNodes)
    throw std::invalid_argument("the FEM model keeps responses of at most " + std::to_string(kMaxContactNodes) +
                                " contact nodes");

  const TetMesh mesh = tet_mesh_of(model);
  const std::vector<bool> constrained = clamped_dofs(model, options.fixed_radius);
  clamped_nodes_ = static_cast<std::size_t>(std::count(constrained.begin(), constrained.end(), true)) / 3;

  const double young = model.material.young_modulus, poisson = model.material.poisson_ratio;
  const Material law = material == MaterialModel::mooney_rivlin
                           ? Material::mooney_rivlin_from_young(young, options.psh_poisson_ratio, options.stabilization)
                           : Material::from_young(material, young, poisson);
  system_ = std::make_unique<ElasticitySystem>(mesh, law, constrained);
  boundary_ = geometry::tetrahedral_boundary(model.tetrahedra);
  if (options.supports && !model.supports.empty()) {
    system_->set_foundation(foundation_springs(model, constrained, boundary_));
    supported_nodes_ = system_->foundation().size();
  }
  factorization_ = options.factorization;
  realtime_solves_ = options.realtime_solves;
  if (system_->has_pressure()) pressure_scale_ = law.bulk_modulus / system_->mean_diameter();

  const std::size_t dofs = static_cast<std::size_t>(system_->dof_count());
  const Eigen::Index free = system_->free_count();
  free_dofs_.resize(static_cast<std::size_t>(free));
  for (std::size_t d = 0; d < dofs; ++d)
    if (system_->free_index()[d] >= 0)
      free_dofs_[static_cast<std::size_t>(system_->free_index()[d])] = static_cast<std::int32_t>(d);
  state_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(dofs));
  saved_ = state_;
  gradient_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(dofs));
  saved_gradient_ = gradient_;
  system_->assemble(state_, gradient_, true);
  gradient_.setZero();  // the rest state is in equilibrium (no loads)

  displacement_dofs_ = 3 * mesh.nodes.size();
  contacts_.resize(tools);
  node_slots_.resize(options.max_contact_nodes > 0 ? options.max_contact_nodes
                                                   : std::min(kMaxContactNodes, 24 * tools));
  slot_of_node_.assign(mesh.nodes.size(), -1);
  holds_.resize(kMaxHolds);
  candidates_.resize(kMaxCandidates);
  patches_.resize(tools);
  patch_weight_.assign(mesh.nodes.size(), 0.0);
  node_tool_.assign(mesh.nodes.size(), -1);
  node_holds_.assign(mesh.nodes.size(), 0);
  tangent_ = make_tangent(true);
  const auto start = std::chrono::steady_clock::now();
  if (!tangent_->factorize(system_->tangent_free(), pressure_count()))
    throw std::invalid_argument(
        "the FEM stiffness at rest is singular: the clamp does not hold the organ (raise "
        "--fixed-radius)");
  factorization_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  node_points_ = model.volume_vertices;
  boundary_tree_ = std::make_unique<geometry::SurfaceBvh>(node_points_, boundary_.faces);
  for (std::size_t f = 0; f < boundary_.faces.size(); ++f) {
    const model::Triangle& face = boundary_.faces[f];
    if (!constrained[3 * face[0]] || !constrained[3 * face[1]] || !constrained[3 * face[2]])
      boundary_faces_.push_back(static_cast<std::int32_t>(f));
    for (int k = 0; k < 3; ++k)
      longest_boundary_edge_ =
          std::max(longest_boundary_edge_, (mesh.nodes[face[k]] - mesh.nodes[face[(k + 1) % 3]]).norm());
  }
  surface_rest_ = model.surface_vertices;
  embedding_ = geometry::embed_surface_in_tetrahedra(model, boundary_);

  rhs_.resize(free);
  step_.resize(free);
  refresh_frames_ =
      material == MaterialModel::corotational || material == MaterialModel::stvk ? options.refresh_frames : 0;
  relaxation_ = material == MaterialModel::linear ? 1.0 : options.relaxation;
  step_fraction_ = relaxation_;
  if (refresh_frames_ > 0) {
    // The rest factorization stays as the fallback; the frames use it until
    // the worker's first tangent takes the place of the empty one.
    rest_tangent_ = std::move(tangent_);
    using_rest_ = true;
    // The two tangents the frames and the worker trade are factorized once
    // here, at rest, the worker's by one refresh on its own thread, so that
    // their memory and the worker's working memory are touched at set-up and
    // not by the first refreshes mid-session (page faults in the loops, and
    // resident memory that grew by a factor's size over the first seconds).
    tangent_ = make_tangent(true);
    tangent_->factorize(system_->tangent_free(), pressure_count());
    worker_ = std::make_unique<Worker>(*this, *system_, make_tangent(true));
    worker_->request(state_, node_slots_, patches_);
    worker_->wait();
    worker_->release();
  }
  // Only a model that runs frames needs the estimate (a static press's
  // Newton solver would time work it never does).
  if (realtime_solves_) estimated_frame_seconds_ = time_frame_work();
}

double OrganFem::time_frame_work() {
  // On scratch vectors: the state stays at rest and the frames' buffers
  // untouched, so a model is the same whether or not it was timed.
  Eigen::VectorXd gradient(gradient_.size()), load = Eigen::VectorXd::Ones(rhs_.size()), solution(step_.size());
  double fastest = std::numeric_limits<double>::infinity();
  for (int repetition = 0; repetition < 3; ++repetition) {
    const auto start = std::chrono::steady_clock::now();
    system_->assemble(state_, gradient, false);
    kept().responses->begin_step(load);
    kept().responses->finish_step(solution);
    fastest = std::min(fastest, std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
  }
  return fastest;
}

OrganFem::~OrganFem() = default;

std::unique_ptr<OrganFem::Tangent> OrganFem::make_tangent(bool realtime_solve) const {
  const MatrixKind kind = system_->has_pressure() ? MatrixKind::quasi_definite : MatrixKind::positive_definite;
  // The nonlinear materials' frames iterate on their own residual: a factor
  // in single precision serves them; a linear frame is the exact solution.
  const SolveUse use = !(realtime_solve && realtime_solves_)                ? SolveUse::newton
                       : system_->material().model == MaterialModel::linear ? SolveUse::realtime
                                                                            : SolveUse::realtime_iteration;
  return std::make_unique<Tangent>(system_->tangent_free(), node_slots_.size(),
                                   make_factorization(factorization_, kind, use));
}

const char* OrganFem::linear_solver() const noexcept {
  return (using_rest_ ? *rest_tangent_ : *tangent_).factorization->name();
}

bool OrganFem::attached(std::uint32_t tool) const noexcept { return tool < contacts_.size() && contacts_[tool].active; }

void OrganFem::grasp(std::uint32_t tool, bool grasped) noexcept {
  if (!attached(tool)) return;
  contacts_[tool].grasped = grasped;
  if (!grasped) contacts_[tool].patch_refused = false;
}

std::size_t OrganFem::held_points(std::uint32_t tool) const noexcept {
  std::size_t count = 0;
  if (attached(tool))
    for (std::size_t k = 0; k < hold_count_; ++k) count += holds_[k].tool == tool;
  return count;
}

std::vector<OrganFem::HeldPoint> OrganFem::held_point_displacements(std::uint32_t tool) const {
  std::vector<HeldPoint> points;
  if (attached(tool))
    for (std::size_t k = 0; k < hold_count_; ++k)
      if (const Hold& h = holds_[k]; h.tool == tool) {
        HeldPoint p;
        for_each_node(h, [&](std::int32_t node, double weight) {
          p.nodes.push_back(node);
          p.weights.push_back(weight);
        });
        p.displacement = contacts_[tool].target + h.offset;
        points.push_back(std::move(p));
      }
  return points;
}

Eigen::Vector3d OrganFem::displacement_at(const std::array<std::int32_t, 3>& nodes,
                                          const Eigen::Vector3d& weights) const noexcept {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < 3; ++i)
    sum += weights[static_cast<Eigen::Index>(i)] * state_.segment<3>(3 * static_cast<Eigen::Index>(nodes[i]));
  return sum;
}

Eigen::Vector3d OrganFem::rest_at(const std::array<std::int32_t, 3>& nodes,
                                  const Eigen::Vector3d& weights) const noexcept {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < 3; ++i)
    sum += weights[static_cast<Eigen::Index>(i)] * point(node_points_[static_cast<std::size_t>(nodes[i])]);
  return sum;
}

std::array<Eigen::Vector3d, 3> OrganFem::face_now(const model::Triangle& face) const noexcept {
  std::array<Eigen::Vector3d, 3> x;
  for (std::size_t i = 0; i < 3; ++i)
    x[i] = point(node_points_[face[i]]) + state_.segment<3>(3 * static_cast<Eigen::Index>(face[i]));
  return x;
}

Eigen::Vector3d OrganFem::hold_displacement(const Hold& hold) const noexcept {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for_each_node(hold, [&](std::int32_t node, double weight) {
    sum += weight * state_.segment<3>(3 * static_cast<Eigen::Index>(node));
  });
  return sum;
}

Eigen::Vector3d OrganFem::hold_rest(const Hold& hold) const noexcept {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for_each_node(hold, [&](std::int32_t node, double weight) {
    sum += weight * point(node_points_[static_cast<std::size_t>(node)]);
  });
  return sum;
}

void OrganFem::respond(Tangent& tangent, std::size_t slot, const NodeSlot& node,
                       const std::vector<Patch>& patches) const noexcept {
  // On the stack: the worker solves responses while the frames go on.
  std::array<std::array<std::int32_t, 3>, kMaxPatchNodes> dofs;
  std::array<double, kMaxPatchNodes> weights;
  std::size_t count = 0;
  auto load = [&](std::int32_t at, double weight) {
    if (weight == 0.0) return;
    weights[count] = weight;
    for (std::size_t k = 0; k < 3; ++k) dofs[count][k] = system_->free_index()[static_cast<std::size_t>(3 * at) + k];
    ++count;
  };
  if (node.patch >= 0) {
    const Patch& patch = patches[static_cast<std::size_t>(node.patch)];
    for (std::size_t i = 0; i < patch.count; ++i) load(patch.nodes[i], patch.weights[i]);
  } else if (node.point) {
    for (std::size_t i = 0; i < 3; ++i) load(node.point_nodes[i], node.point_weights[static_cast<Eigen::Index>(i)]);
  } else {
    load(node.node, 1.0);
  }
  tangent.responses->respond(slot, PointLoad{dofs.data(), weights.data(), count});
  tangent.keys[slot] = node.generation;
}

void OrganFem::respond_all(Tangent& tangent) const noexcept {
  // The held nodes only: a slot kept for a node no hold weighs now is solved
  // again when a hold takes it (node_slot).
  for (std::size_t slot = 0; slot < node_slots_.size(); ++slot) {
    const NodeSlot& n = node_slots_[slot];
    if (n.node >= 0 && node_holds_[static_cast<std::size_t>(n.node)] > 0 && tangent.keys[slot] != n.generation)
      respond(tangent, slot, n, patches_);
  }
}

std::int32_t OrganFem::node_slot(std::int32_t node, std::size_t& solves) noexcept {
  std::int32_t slot = slot_of_node_[static_cast<std::size_t>(node)];
  if (slot >= 0) {
    NodeSlot& n = node_slots_[static_cast<std::size_t>(slot)];
    if (kept().keys[static_cast<std::size_t>(slot)] != n.generation) {
      // Kept from an earlier hold, its response is the tangent's before.
      if (realtime_solves_ && solves >= kJoinsPerFrame) return -1;
      respond(kept(), static_cast<std::size_t>(slot), n, patches_);
      solved_this_frame_ = true;
      ++solves;
    }
    n.used_frame = frame_ + 1;
    return slot;
  }
  if (realtime_solves_ && solves >= kJoinsPerFrame) return -1;
  const std::size_t chosen = free_slot();
  if (chosen == node_slots_.size()) return -1;
  NodeSlot& n = node_slots_[chosen];
  if (n.node >= 0) slot_of_node_[static_cast<std::size_t>(n.node)] = -1;
  n.node = node;
  n.generation = ++generations_;
  n.used_frame = frame_ + 1;
  slot_of_node_[static_cast<std::size_t>(node)] = static_cast<std::int32_t>(chosen);
  respond(kept(), chosen, n, patches_);
  solved_this_frame_ = true;
  ++solves;
  return static_cast<std::int32_t>(chosen);
}

std::size_t OrganFem::free_slot() const noexcept {
  std::size_t chosen = node_slots_.size();
  for (std::size_t k = 0; k < node_slots_.size(); ++k) {
    const NodeSlot& n = node_slots_[k];
    if (n.node < 0) return k;
    // A point's slot is freed with its hold (release), never taken over.
    if (!n.point && node_holds_[static_cast<std::size_t>(n.node)] == 0 &&
        (chosen == node_slots_.size() || n.used_frame < node_slots_[chosen].used_frame))
      chosen = k;
  }
  return chosen;
}

bool OrganFem::add_hold(Hold hold, std::size_t& solves, bool as_point) noexcept {
  if (hold_count_ == holds_.size()) {
    ++hold_overflows_;
    return false;
  }
  hold.point_slot = -1;
  hold.slots = {-1, -1, -1};
  if (as_point) {
    const std::size_t chosen = free_slot();
    if (chosen == node_slots_.size()) {
      ++hold_overflows_;
      return false;
    }
    NodeSlot& n = node_slots_[chosen];
    if (n.node >= 0) slot_of_node_[static_cast<std::size_t>(n.node)] = -1;
    n.point = true;
    n.patch = hold.patch;
    n.point_nodes = hold.nodes;
    n.point_weights = hold.weights;
    n.node = hold.patch >= 0 ? patches_[static_cast<std::size_t>(hold.patch)].nodes[0]
                             : hold.nodes[hold.weights[0] != 0.0   ? 0
                                          : hold.weights[1] != 0.0 ? 1
                                                                   : 2];
    n.generation = ++generations_;
    n.used_frame = frame_ + 1;
    respond(kept(), chosen, n, patches_);
    solved_this_frame_ = true;
    ++solves;
    hold.point_slot = static_cast<std::int32_t>(chosen);
  }
  for (std::size_t i = 0; i < 3 && !as_point; ++i) {
    if (hold.weights[static_cast<Eigen::Index>(i)] == 0.0) continue;
    hold.slots[i] = node_slot(hold.nodes[i], solves);
    if (hold.slots[i] < 0) {
      if (!realtime_solves_ || solves < kJoinsPerFrame) ++hold_overflows_;
      return false;
    }
  }
  for_each_node(hold, [&](std::int32_t node, double) {
    node_tool_[static_cast<std::size_t>(node)] = static_cast<std::int16_t>(hold.tool);
    ++node_holds_[static_cast<std::size_t>(node)];
  });
  holds_[hold_count_++] = hold;
  return true;
}

void OrganFem::release(std::size_t index) noexcept {
  const Hold& h = holds_[index];
  if (h.point_slot >= 0) node_slots_[static_cast<std::size_t>(h.point_slot)] = NodeSlot{};
  for_each_node(h, [&](std::int32_t at, double) {
    const auto node = static_cast<std::size_t>(at);
    if (--node_holds_[node] == 0) node_tool_[node] = -1;
  });
  holds_[index] = holds_[--hold_count_];
}

bool OrganFem::attach(std::uint32_t tool, const Eigen::Vector3d& rest_point, const geometry::ToolTip& tip) noexcept {
  if (tool >= contacts_.size() || !rest_point.allFinite() || !std::isfinite(tip.radius) || tip.radius < 0.0)
    return false;
  if (!tip.is_point() && !(std::abs(tip.axis.norm() - 1.0) < 1e-6 && std::isfinite(tip.shaft_length))) return false;
  const geometry::SurfacePoint nearest = boundary_tree_->closest_point(rest_point);
  const model::Triangle& face = boundary_.faces[nearest.triangle];
  for (std::uint32_t node : face) {
    if (system_->free_index()[3 * node] < 0) return false;  // a clamped node cannot follow a tool
    // Two tools holding one node would fight over it.
    if (node_tool_[node] >= 0 && node_tool_[node] != static_cast<std::int16_t>(tool)) return false;
  }
  detach(tool);
  Hold h;
  h.tool = tool;
  h.bilateral = true;  // the first touch is held until the contact ends
  h.nodes = {static_cast<std::int32_t>(face[0]), static_cast<std::int32_t>(face[1]),
             static_cast<std::int32_t>(face[2])};
  h.weights = nearest.barycentric;
  h.outward = -tip.axis;
  // Its response now, so that its stiffness is the linearization at once:
  // the point's as a whole, one solve (its nodes' would take three).
  std::size_t solves = 0;
  const bool added = add_hold(h, solves, true);
  if (!added) return false;
  Contact& c = contacts_[tool];
  c.active = true;
  c.grasped = false;
  c.patch_held = false;
  c.patch_refused = false;
  c.first_nodes = h.nodes;
  c.first_weights = h.weights;
  c.tip = tip;
  c.origin = rest_point + tip.seat;
  c.rest_point = nearest.position;
  // The organ may be deformed here already: the tool starts where the point is.
  c.target = displacement_at(h.nodes, h.weights);
  assemble_capacitance();
  update_stiffness();
  return true;
}

void OrganFem::detach(std::uint32_t tool) noexcept {
  if (!attached(tool)) return;
  contacts_[tool].active = false;
  contacts_[tool].grasped = false;
  contacts_[tool].patch_held = false;
  contacts_[tool].patch_refused = false;
  contacts_[tool].stiffness.setZero();
  for (std::size_t k = hold_count_; k-- > 0;)
    if (holds_[k].tool == tool) release(k);
  assemble_capacitance();
  update_stiffness();
}

bool OrganFem::build_patch(std::uint32_t tool) noexcept {
  const Contact& c = contacts_[tool];
  Patch& patch = patches_[tool];
  patch.count = 0;
  const double radius = c.tip.radius;
  const Eigen::Vector3d centre =
      rest_at(c.first_nodes, c.first_weights) + displacement_at(c.first_nodes, c.first_weights);
  constexpr double n = kPatchSubdivisions;
  double total = 0.0;
  bool overflow = false;
  for (std::int32_t f : boundary_faces_) {
    const model::Triangle& face = boundary_.faces[static_cast<std::size_t>(f)];
    const std::array<Eigen::Vector3d, 3> x = face_now(face);
    if (std::none_of(x.begin(), x.end(), [&](const Eigen::Vector3d& corner) {
          return (corner - centre).norm() < radius + longest_boundary_edge_;
        }))
      continue;
    // The face's area within the radius, on its nodes: each sub-triangle's
    // (upward and downward ones) by the barycentric weights of its centroid.
    const double sub_area = 0.5 * (x[1] - x[0]).cross(x[2] - x[0]).norm() / (n * n);
    Eigen::Vector3d weights = Eigen::Vector3d::Zero();
    auto count_in = [&](double b1, double b2) {
      const Eigen::Vector3d b(1.0 - b1 - b2, b1, b2);
      if ((b[0] * x[0] + b[1] * x[1] + b[2] * x[2] - centre).squaredNorm() <= radius * radius) weights += sub_area * b;
    };
    for (int i = 0; i < kPatchSubdivisions; ++i)
      for (int j = 0; i + j < kPatchSubdivisions; ++j) {
        count_in((i + 1.0 / 3.0) / n, (j + 1.0 / 3.0) / n);
        if (i + j + 1 < kPatchSubdivisions) count_in((i + 2.0 / 3.0) / n, (j + 2.0 / 3.0) / n);
      }
    for (std::size_t i = 0; i < 3; ++i) {
      const double weight = weights[static_cast<Eigen::Index>(i)];
      const std::size_t node = face[i];
      // A clamped node does not move; one another tool holds is not ours.
      if (weight == 0.0 || system_->free_index()[3 * node] < 0 ||
          (node_tool_[node] >= 0 && node_tool_[node] != static_cast<std::int16_t>(tool)))
        continue;
      if (patch_weight_[node] == 0.0) {
        if (patch.count == kMaxPatchNodes) {
          overflow = true;
          continue;
        }
        patch.nodes[patch.count++] = static_cast<std::int32_t>(node);
      }
      patch_weight_[node] += weight;
      total += weight;
    }
  }
  for (std::size_t i = 0; i < patch.count; ++i) {
    double& weight = patch_weight_[static_cast<std::size_t>(patch.nodes[i])];
    patch.weights[i] = weight / total;
    weight = 0.0;
  }
  if (overflow) ++hold_overflows_;
  if (overflow || patch.count == 0) {
    patch.count = 0;
    return false;
  }
  return true;
}

bool OrganFem::update_jaws() noexcept {
  bool changed = false;
  for (std::uint32_t tool = 0; tool < contacts_.size(); ++tool) {
    Contact& c = contacts_[tool];
    if (!c.active || c.tip.is_point()) continue;
    const bool close = c.grasped && !c.patch_held && !c.patch_refused;
    const bool open = !c.grasped && c.patch_held;
    if (!close && !open) continue;
    Hold h;
    h.tool = tool;
    h.bilateral = true;
    h.outward = -c.tip.axis;
    if (close) {
      if (!build_patch(tool)) {
        c.patch_refused = true;
        continue;
      }
      h.patch = static_cast<std::int32_t>(tool);
    } else {
      h.nodes = c.first_nodes;
      h.weights = c.first_weights;
    }
    // Held where it lies, with the force of what it replaces: the frame
    // starts from the state and the forces the last one ended with.
    h.offset = hold_displacement(h) - c.target;
    for (std::size_t k = hold_count_; k-- > 0;)
      if (holds_[k].tool == tool) {
        h.force += holds_[k].force;
        release(k);
      }
    std::size_t solves = 0;
    // The tool's holds are gone: a hold and a response slot are free.
    add_hold(h, solves, true);
    c.patch_held = close;
    changed = true;
  }
  return changed;
}

bool OrganFem::take_points() noexcept {
  bool taken = false;
  std::size_t solves = 0;
  for (std::uint32_t tool = 0; tool < contacts_.size(); ++tool) {
    const Contact& c = contacts_[tool];
    // Closed jaws hold the patch: nothing more enters the tip.
    if (!c.active || c.tip.is_point() || c.patch_held) continue;
    // The point of each boundary face nearest the capsule's axis, where it
    // lies inside the capsule; one per node, edge or face interior.
    const Eigen::Vector3d tip_point = c.origin + c.target;
    const Eigen::Vector3d centre = tip_point + c.tip.radius * c.tip.axis;
    const double reach = c.tip.radius + longest_boundary_edge_;
    std::size_t found = 0;
    for (std::int32_t f : boundary_faces_) {
      const model::Triangle& face = boundary_.faces[static_cast<std::size_t>(f)];
      const std::array<Eigen::Vector3d, 3> x = face_now(face);
      bool near = false;
      for (std::size_t i = 0; i < 3; ++i) {
        const double along = std::clamp((x[i] - centre).dot(c.tip.axis), 0.0, c.tip.shaft_length);
        near = near || (x[i] - centre - along * c.tip.axis).norm() < reach;
      }
      if (!near) continue;
      Eigen::Vector3d on_axis = centre, weights;
      for (int pass = 0; pass < kClosestPairPasses; ++pass) {
        weights = geometry::closest_point_barycentric(on_axis, x[0], x[1], x[2]);
        const Eigen::Vector3d q = weights[0] * x[0] + weights[1] * x[1] + weights[2] * x[2];
        on_axis = centre + std::clamp((q - centre).dot(c.tip.axis), 0.0, c.tip.shaft_length) * c.tip.axis;
      }
      Hold k;
      k.tool = tool;
      double fresh = 0.0;
      bool blocked = false;
      for (std::size_t i = 0; i < 3; ++i) {
        k.nodes[i] = static_cast<std::int32_t>(face[i]);
        if (weights[static_cast<Eigen::Index>(i)] == 0.0) continue;
        const std::int16_t owner = node_tool_[face[i]];
        if (owner < 0) fresh += weights[static_cast<Eigen::Index>(i)];
        blocked = blocked || (owner >= 0 && owner != static_cast<std::int16_t>(tool)) ||
                  system_->free_index()[3 * face[i]] < 0;
      }
      // A point mostly on nodes the tool holds already would add a
      // constraint theirs nearly imply (W near singular); one on another
      // tool's would fight it.
      if (fresh < kFreshWeight || blocked) continue;
      const Eigen::Vector3d q = weights[0] * x[0] + weights[1] * x[1] + weights[2] * x[2];
      Eigen::Vector3d normal;
      double gap = c.tip.signed_distance(tip_point, q, normal);
      if (gap >= 0.0) continue;
      Eigen::Vector3d at = q - gap * normal;  // where it meets the capsule's surface
      if (gap < -kPiercedDepth * c.tip.radius) {
        // Deep inside (a tip that moved into the organ faster than the organ
        // followed): the nearest way out may be sideways through the shaft,
        // which would thread the surface onto it. The point goes ahead of the
        // hemisphere instead, along −axis.
        const Eigen::Vector3d from_centre = q - centre;
        const double radial = (from_centre - from_centre.dot(c.tip.axis) * c.tip.axis).norm();
        const double behind_apex =
            c.tip.radius - std::sqrt(std::max(c.tip.radius * c.tip.radius - radial * radial, 0.0));
        const double ahead = (q - tip_point).dot(-c.tip.axis) + behind_apex;
        normal = -c.tip.axis;
        at = q - ahead * normal;
      }
      k.weights = weights;
      k.outward = normal;
      k.depth = -gap;
      k.offset = (at - rest_at(k.nodes, weights)) - c.target;
      if (crowds_a_hold(k)) continue;
      if (found < candidates_.size()) {
        candidates_[found++] = k;
      } else {
        ++hold_overflows_;
        auto shallowest = std::min_element(candidates_.begin(), candidates_.end(),
                                           [](const Hold& a, const Hold& b) { return a.depth < b.depth; });
        if (k.depth > shallowest->depth) *shallowest = k;
      }
    }
    std::sort(candidates_.begin(), candidates_.begin() + static_cast<std::ptrdiff_t>(found),
              [](const Hold& a, const Hold& b) { return a.depth > b.depth; });
    for (std::size_t m = 0; m < found; ++m) {
      // Taken ones may have claimed its nodes, or its place, since it was found.
      const Hold& k = candidates_[m];
      double fresh = 0.0;
      for (std::size_t i = 0; i < 3; ++i)
        if (node_tool_[static_cast<std::size_t>(k.nodes[i])] < 0) fresh += k.weights[static_cast<Eigen::Index>(i)];
      if (fresh >= kFreshWeight && !crowds_a_hold(k) && add_hold(k, solves)) taken = true;
    }
  }
  return taken;
}

bool OrganFem::crowds_a_hold(const Hold& candidate) const noexcept {
  const Eigen::Vector3d& tool_target = contacts_[candidate.tool].target;
  const Eigen::Vector3d rest = rest_at(candidate.nodes, candidate.weights);
  const Eigen::Vector3d now = rest + displacement_at(candidate.nodes, candidate.weights);
  const Eigen::Vector3d target = rest + tool_target + candidate.offset;
  for (std::size_t a = 0; a < hold_count_; ++a) {
    const Hold& h = holds_[a];
    if (h.tool != candidate.tool) continue;
    const Eigen::Vector3d held_rest = hold_rest(h);
    const Eigen::Vector3d held_now = held_rest + hold_displacement(h);
    const Eigen::Vector3d held_target = held_rest + tool_target + h.offset;
    if ((target - held_target).norm() < kMaxTakeCompression * (now - held_now).norm()) return true;
  }
  return false;
}

void OrganFem::assemble_capacitance() noexcept {
  Capacitance& w = *capacitance_;
  const auto n = static_cast<Eigen::Index>(3 * hold_count_);
  w.rows = n;
  w.matrix.resize(n, n);
  if (n == 0) return;
  // Block (a, b) of W: hold a's displacement under unit loads at hold b.
  const ContactResponses& responses = *kept().responses;
  for (std::size_t a = 0; a < hold_count_; ++a)
    for (std::size_t b = a; b < hold_count_; ++b) {
      Eigen::Matrix3d block = Eigen::Matrix3d::Zero();
      for_each_response(holds_[a], [&](std::size_t s, double ws) {
        for_each_response(holds_[b], [&](std::size_t t, double wt) { block += (ws * wt) * responses.coupling(s, t); });
      });
      w.matrix.block<3, 3>(static_cast<Eigen::Index>(3 * a), static_cast<Eigen::Index>(3 * b)) = block;
      w.matrix.block<3, 3>(static_cast<Eigen::Index>(3 * b), static_cast<Eigen::Index>(3 * a)) = block.transpose();
    }
  // W is symmetric in exact arithmetic (and for a nonlinear tangent, nearly):
  // its upper part, mirrored.
  w.ldlt.compute(w.matrix);
}

void OrganFem::update_stiffness() noexcept {
  // A tool moves all its points together: its stiffness is Eᵀ W⁻¹ E, E
  // summing the tool's blocks.
  Capacitance& w = *capacitance_;
  for (Contact& c : contacts_) c.stiffness.setZero();
  if (w.rows == 0) return;
  for (std::uint32_t tool = 0; tool < contacts_.size(); ++tool) {
    if (!contacts_[tool].active) continue;
    w.sums.setZero(w.rows, 3);
    bool any = false;
    for (std::size_t a = 0; a < hold_count_; ++a)
      if (holds_[a].tool == tool) {
        w.sums.block<3, 3>(static_cast<Eigen::Index>(3 * a), 0).setIdentity();
        any = true;
      }
    if (!any) continue;
    w.solved = w.ldlt.solve(w.sums);
    for (std::size_t a = 0; a < hold_count_; ++a)
      if (holds_[a].tool == tool)
        contacts_[tool].stiffness += w.solved.block<3, 3>(static_cast<Eigen::Index>(3 * a), 0);
  }
}

void OrganFem::adopt(std::unique_ptr<Tangent>& fresh) noexcept {
  std::swap(tangent_, fresh);
  using_rest_ = false;
  respond_all(*tangent_);
  assemble_capacitance();
  update_stiffness();
  ++refreshes_;
}

void OrganFem::end_refresh(bool adopt_it) noexcept {
  if (worker_->wait() && adopt_it) adopt(worker_->spare());
  worker_->release();
  refresh_due_ = 0;
  stale_refresh_ = false;
}

void OrganFem::request_refresh() noexcept {
  for (NodeSlot& n : node_slots_) n.held = n.node >= 0 && node_holds_[static_cast<std::size_t>(n.node)] > 0;
  worker_->request(state_, node_slots_, patches_);
  refresh_due_ = frame_ + refresh_frames_;
}

bool OrganFem::refresh_tangent() {
  // The exact Hessian (Newton), or where it is indefinite its definite part.
  // The tangent this replaces is analyzed already: the next call reuses it.
  std::unique_ptr<Tangent> fresh = newton_spare_ ? std::move(newton_spare_) : make_tangent(false);
  bool ok = false;
  for (bool definite : {false, true}) {
    system_->set_definite_tangent(definite);
    ok = system_->assemble(state_, gradient_, true) < 0 && fresh->factorize(system_->tangent_free(), pressure_count());
    if (ok) break;
  }
  system_->set_definite_tangent(false);
  if (ok) adopt(fresh);
  newton_spare_ = std::move(fresh);
  return ok;
}

double OrganFem::iterate(bool& released, bool& unbalanced) noexcept {
  // Unconstrained correction Δ₀ = −A⁻¹ g, then the multipliers that make the
  // held points land on their targets: W λ = d − Hᵀ(u + Δ₀). A finite tip
  // lets go of a point whose multiplier would pull it (unilateral contact),
  // the worst first, and solves again without it.
  // The solve in parts (contact_responses.h): Hᵀ Δ₀ from the forward half,
  // and one backward half for Δ₀ + A⁻¹ H λ.
  Capacitance& w = *capacitance_;
  ContactResponses& responses = *kept().responses;
  const Eigen::Index free = static_cast<Eigen::Index>(free_dofs_.size());
  const double unbalanced_at_start = out_of_balance(0.0);
  for (Eigen::Index j = 0; j < free; ++j) rhs_[j] = -gradient_[free_dofs_[static_cast<std::size_t>(j)]];
  responses.begin_step(rhs_);
  released = false;
  unbalanced = false;
  // The holds' forces as they stand, those about to be let go of included:
  // a released point leaves its node out of balance by up to its force.
  double force_scale = std::max(unbalanced_at_start, kNegligibleImbalance);
  for (std::size_t a = 0; a < hold_count_; ++a)
    force_scale = std::max(force_scale, holds_[a].force.cwiseAbs().maxCoeff());
  for (;;) {
    w.gap.resize(w.rows);
    for (std::size_t a = 0; a < hold_count_; ++a) {
      const Hold& h = holds_[a];
      Eigen::Vector3d moved = Eigen::Vector3d::Zero();
      for_each_response(h, [&](std::size_t slot, double weight) { moved += weight * responses.projected(slot); });
      w.gap.segment<3>(static_cast<Eigen::Index>(3 * a)) =
          contacts_[h.tool].target + h.offset - hold_displacement(h) - moved;
    }
    if (w.rows > 0) w.multipliers = w.ldlt.solve(w.gap);
    std::ptrdiff_t worst = -1;
    double pull = 0.0;
    for (std::size_t a = 0; a < hold_count_; ++a) {
      const double along = holds_[a].outward.dot(w.multipliers.segment<3>(static_cast<Eigen::Index>(3 * a)));
      if (!holds_[a].bilateral && !contacts_[holds_[a].tool].grasped && along < pull) {
        pull = along;
        worst = static_cast<std::ptrdiff_t>(a);
      }
    }
    if (worst < 0) break;
    release(static_cast<std::size_t>(worst));
    assemble_capacitance();
    released = true;
  }
  for (std::size_t a = 0; a < hold_count_; ++a) {
    const Hold& h = holds_[a];
    const Eigen::Vector3d force = w.multipliers.segment<3>(static_cast<Eigen::Index>(3 * a));
    for_each_response(h, [&](std::size_t slot, double weight) { responses.add(slot, weight * force); });
  }
  responses.finish_step(step_);
  // A kept tangent made at a state far from this one (a pressed organ the
  // tools have let go of) can give a step that inverts nothing and yet
  // throws the organ out of balance: iterated, the organ flew apart within a
  // few frames of a release. With a worker to make a tangent at this state,
  // a step must leave the out-of-balance force within kMaxImbalanceGrowth
  // times the frame's force scale (the imbalance at its start, the holds'
  // forces before and after, and a force too small to feel). One that does
  // not is not cut: its direction is wrong, not its length (shorter steps of
  // it crawl the same wrong way), and the frame gives up this tangent.
  // Without a worker there is no better tangent to wait for. Static presses
  // (Newton, a fresh tangent per iteration) take the step. psh's frames keep
  // the rest tangent, which a state far from rest can make diverge (see
  // step_fraction_): a step that would more than double the organ's
  // imbalance is cut like one that inverts, since a shorter one does
  // contract there. Doubled from at least a quarter of the frame's force
  // scale: a tool that moves leaves an imbalance of its own (the damped
  // iteration closes a part of each frame's gap), which grows from nothing
  // as it first presses without any divergence.
  for (std::size_t a = 0; a < hold_count_; ++a)
    force_scale =
        std::max(force_scale, w.multipliers.segment<3>(static_cast<Eigen::Index>(3 * a)).cwiseAbs().maxCoeff());
  const double tolerated = kMaxImbalanceGrowth * force_scale;
  const bool damped = keeps_rest_tangent();
  const double tolerated_growth =
      kMaxImbalanceGrowth * std::max(unbalanced_at_start, kRestTangentImbalanceShare * force_scale);
  // A step that would invert a tetrahedron (a tool pushed deeper than the
  // mesh can follow in one frame) is cut in halves; the organ then goes as far
  // toward the targets as it can, with the multipliers interpolated as the
  // linearization predicts: g(x + αΔ) ≈ (1 − α) g(x) + α H λ.
  // Each cut is first checked for inverted tetrahedra alone (determinants: a
  // tenth of an assembly), so that a frame that cuts its step or fails
  // assembles once, not once per try; a frame that fails gets back the
  // gradient at its start.
  const double smallest = relaxation_ / static_cast<double>(1 << kMaxStepCuts);
  saved_gradient_ = gradient_;
  for (double fraction = damped ? step_fraction_ : relaxation_; fraction >= smallest; fraction *= 0.5) {
    for (Eigen::Index j = 0; j < free; ++j)
      state_[free_dofs_[static_cast<std::size_t>(j)]] =
          saved_[free_dofs_[static_cast<std::size_t>(j)]] + fraction * step_[j];
    if (system_->first_inverted(state_) >= 0) continue;
    if (system_->assemble(state_, gradient_, false) >= 0 || !gradient_.allFinite()) continue;
    if (worker_) {
      if (out_of_balance(fraction) <= tolerated) return fraction;
      unbalanced = true;
      break;
    }
    if (!damped || out_of_balance(fraction) <= tolerated_growth) return fraction;
  }
  state_ = saved_;
  gradient_ = saved_gradient_;
  return 0.0;
}

double OrganFem::out_of_balance(double fraction) noexcept {
  // Internal forces minus the tools' forces, pressure rows in newtons.
  const Eigen::Index free = static_cast<Eigen::Index>(free_dofs_.size());
  for (Eigen::Index j = 0; j < free; ++j) {
    const std::size_t d = static_cast<std::size_t>(free_dofs_[static_cast<std::size_t>(j)]);
    rhs_[j] = gradient_[static_cast<Eigen::Index>(d)] * (d < displacement_dofs_ ? 1.0 : pressure_scale_);
  }
  const Capacitance& w = *capacitance_;
  for (std::size_t a = 0; a < hold_count_; ++a) {
    const Hold& h = holds_[a];
    // At fraction 0 the forces as they are (the multipliers may still be
    // the previous frame's, for other holds).
    const Eigen::Vector3d force =
        fraction == 0.0 ? h.force
                        : Eigen::Vector3d((1.0 - fraction) * h.force +
                                          fraction * w.multipliers.segment<3>(static_cast<Eigen::Index>(3 * a)));
    for_each_node(h, [&](std::int32_t node, double weight) {
      for (int c = 0; c < 3; ++c) {
        const std::int32_t f = system_->free_index()[static_cast<std::size_t>(3 * node + c)];
        if (f >= 0) rhs_[f] -= weight * force[c];
      }
    });
  }
  return free > 0 ? rhs_.cwiseAbs().maxCoeff() : 0.0;
}

FrameStatus OrganFem::step(const Eigen::Vector3d* displacements) noexcept {
  for (std::uint32_t t = 0; t < contacts_.size(); ++t)
    if (contacts_[t].active && !displacements[t].allFinite()) return FrameStatus::not_finite;
  if (worker_ && refresh_due_ > 0 && frame_ < refresh_due_ && !solved_this_frame_ && !stale_refresh_ &&
      worker_->ready()) {
    // A node taken after the request lacks its response in the fresh
    // tangent: solve one per frame (none in a frame that took one) while the
    // tangent waits to be adopted, rather than all of them in the frame that
    // adopts it.
    Tangent& fresh = *worker_->spare();
    for (std::size_t slot = 0; slot < node_slots_.size(); ++slot) {
      const NodeSlot& n = node_slots_[slot];
      if (n.node >= 0 && node_holds_[static_cast<std::size_t>(n.node)] > 0 && fresh.keys[slot] != n.generation) {
        respond(fresh, slot, n, patches_);
        break;
      }
    }
  }
  solved_this_frame_ = false;
  const bool untouched = std::none_of(contacts_.begin(), contacts_.end(), [](const Contact& c) { return c.active; });
  if (untouched) {
    // Nothing holds the organ and no body force loads it: its equilibrium is
    // the rest state, reached in this frame as a quasi-static frame reaches
    // any (iterated from the pressed state with a tangent made there, the
    // organ took seconds to come back after the tools let go, and could fly
    // apart). At rest the rest tangent is exact; a refresh on its way, made
    // at the pressed state, is dropped: now where the frames may wait for
    // it (so that the next press begins as the first did), else when done.
    return_to_rest();
    kept_in_a_row_ = 0;
    contact_settled_ = true;
    ++frame_;
    return FrameStatus::ok;
  }
  if (worker_ && refresh_due_ > 0 && frame_ >= refresh_due_) {
    if (reproducible_ || worker_->finished()) {
      end_refresh(!stale_refresh_);
    } else if (frame_ == refresh_due_) {
      ++late_refreshes_;
    }
  }
  // The jaws close (or open) where the tool was: what they take moves with it from there.
  const bool jaws_changed = update_jaws();
  for (std::uint32_t t = 0; t < contacts_.size(); ++t)
    if (contacts_[t].active) contacts_[t].target = displacements[t];
  const bool took = take_points() || jaws_changed;
  if (took) assemble_capacitance();

  saved_ = state_;
  bool released = false, unbalanced = false;
  double fraction = iterate(released, unbalanced);
  if (fraction == 0.0 && rest_tangent_ && !using_rest_) {
    // A refreshed tangent that fails (a state far from the one it was made
    // at: a tool let go) gives way to the rest tangent until the worker's
    // next one: in this frame when even small steps invert a tetrahedron,
    // from the next one when its step was out of balance (so that no frame
    // solves twice for a state the organ may keep a while).
    using_rest_ = true;
    respond_all(*rest_tangent_);
    assemble_capacitance();
    if (!unbalanced) {
      bool again = false;
      fraction = iterate(again, unbalanced);
      released = released || again;
    }
  }
  contact_settled_ = !took && !released;
  update_stiffness();
  if (fraction == 0.0) {
    if (keeps_rest_tangent()) adapt_step_fraction(0.0, 0.0, 0.0);
    if (++kept_in_a_row_ >= kKeptFramesBeforeRestart) {
      // Every step from this state inverts a tetrahedron, even with a
      // tangent made here: an iteration that diverged before its steps were
      // refused left the organ where no step leads out (seen in real-time
      // replays of a held lobe once the probe beside it let go, on a 2-vCPU
      // machine whose worker refreshed late). The organ starts again from
      // rest, and the frames bring it back to the tools.
      return_to_rest();
      kept_in_a_row_ = 0;
      ++restarts_;
    }
    ++frame_;
    if (worker_ && refresh_due_ == 0) request_refresh();
    // Out of balance: the kept tangents do not fit this state. The refresh
    // on its way is adopted as soon as it is done, and the next one, asked
    // for at this state, too.
    if (worker_ && unbalanced) refresh_due_ = std::min(refresh_due_, frame_);
    return FrameStatus::kept_shape;
  }
  Capacitance& w = *capacitance_;
  for (std::size_t a = 0; a < hold_count_; ++a) {
    Hold& h = holds_[a];
    h.force = (1.0 - fraction) * h.force + fraction * w.multipliers.segment<3>(static_cast<Eigen::Index>(3 * a));
  }

  kept_in_a_row_ = 0;
  step_cuts_ += fraction < relaxation_;
  const double before = unbalanced_;
  unbalanced_ = out_of_balance(0.0);
  if (keeps_rest_tangent()) adapt_step_fraction(fraction, before, unbalanced_);
  ++frame_;
  if (worker_ && refresh_due_ == 0) request_refresh();
  return FrameStatus::ok;
}

void OrganFem::return_to_rest() noexcept {
  reset();
  if (worker_ && refresh_due_ > 0) {
    if (reproducible_ || worker_->finished()) {
      end_refresh(false);
    } else {
      stale_refresh_ = true;
    }
  }
  if (rest_tangent_ && !using_rest_) {
    using_rest_ = true;
    respond_all(*rest_tangent_);
    assemble_capacitance();
  }
}

void OrganFem::adapt_step_fraction(double fraction, double before, double after) noexcept {
  const double smallest = relaxation_ / static_cast<double>(1 << kMaxStepCuts);
  if (fraction < step_fraction_) {
    step_fraction_ = std::max(fraction, smallest);  // 0: nothing contracted; begin with the shortest
    steady_frames_ = 0;
  } else if (step_fraction_ < relaxation_) {
    steady_frames_ = after < before ? steady_frames_ + 1 : 0;
    if (steady_frames_ >= kSteadyFrames) {
      step_fraction_ = std::min(2.0 * step_fraction_, relaxation_);
      steady_frames_ = 0;
    }
  }
}

void OrganFem::reset() noexcept {
  state_.setZero();
  gradient_.setZero();
  for (std::size_t k = 0; k < hold_count_; ++k) holds_[k].force.setZero();
  unbalanced_ = 0;
  step_fraction_ = relaxation_;
  steady_frames_ = 0;
}

Eigen::Vector3d OrganFem::contact_point(std::uint32_t tool) const noexcept {
  return tool < contacts_.size() ? contacts_[tool].rest_point : Eigen::Vector3d::Zero();
}

Eigen::Vector3d OrganFem::contact_displacement(std::uint32_t tool) const noexcept {
  if (tool >= contacts_.size()) return Eigen::Vector3d::Zero();
  if (contacts_[tool].tip.is_point())
    for (std::size_t k = 0; k < hold_count_; ++k)
      if (holds_[k].tool == tool) return hold_displacement(holds_[k]);
  return contacts_[tool].target;
}

Eigen::Vector3d OrganFem::contact_force(std::uint32_t tool) const noexcept {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  if (!attached(tool)) return sum;
  for (std::size_t k = 0; k < hold_count_; ++k)
    if (holds_[k].tool == tool) sum -= holds_[k].force;
  return sum;
}

Eigen::Matrix3d OrganFem::contact_stiffness(std::uint32_t tool) const noexcept {
  return attached(tool) ? contacts_[tool].stiffness : Eigen::Matrix3d::Zero();
}

void OrganFem::surface_positions(model::Point3* positions) const noexcept {
  for (std::size_t v = 0; v < surface_rest_.size(); ++v) {
    Eigen::Vector3d x = point(surface_rest_[v]);
    for (std::size_t i = 0; i < 4; ++i)
      x += embedding_.weights[v][static_cast<Eigen::Index>(i)] *
           state_.segment<3>(3 * static_cast<Eigen::Index>(embedding_.hosts[v][i]));
    positions[v] = {x[0], x[1], x[2]};
  }
}

void OrganFem::node_positions(model::Point3* positions) const noexcept {
  for (std::size_t n = 0; n < node_points_.size(); ++n) {
    const Eigen::Vector3d x = point(node_points_[n]) + state_.segment<3>(3 * static_cast<Eigen::Index>(n));
    positions[n] = {x[0], x[1], x[2]};
  }
}

Eigen::Ref<const Eigen::VectorXd> OrganFem::displacements() const noexcept {
  return state_.head(static_cast<Eigen::Index>(displacement_dofs_));
}

Eigen::Ref<const Eigen::VectorXd> OrganFem::pressures() const noexcept {
  return state_.tail(state_.size() - static_cast<Eigen::Index>(displacement_dofs_));
}

}  // namespace organsim::fem
