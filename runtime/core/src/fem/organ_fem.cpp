#include "organsim/fem/organ_fem.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>
#include <thread>
#include <atomic>
#include <pthread.h>
#include <sched.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/LU>

namespace organsim::fem {
namespace {

constexpr std::size_t kMaxContacts = 16;
constexpr int kMaxStepCuts = 4;  // the smallest step tried: 1/16 of the iteration's
using SmallMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 3 * kMaxContacts,
                                  3 * kMaxContacts>;
using SmallVector = Eigen::Matrix<double, Eigen::Dynamic, 1, Eigen::ColMajor, 3 * kMaxContacts, 1>;

Eigen::Vector3d point(const model::Point3& p) { return {p[0], p[1], p[2]}; }

}  // namespace

/// A factorized tangent and, per tool, the response A⁻¹ H_t of the contact
/// it was solved for.
struct OrganFem::Tangent {
  std::unique_ptr<Factorization> factorization;
  std::vector<Eigen::MatrixX3d> responses;  ///< per tool: free dofs × 3
  std::vector<std::uint64_t> keys;          ///< per tool: the contact generation of its response (0: none)
  Eigen::VectorXd warm_up;
  Eigen::MatrixX3d loads, warm_up3;  ///< a contact's three unit loads (one per direction)

  Tangent(const SparseMatrix& pattern, std::size_t tools, std::unique_ptr<Factorization> made)
      : factorization(std::move(made)),
        responses(tools, Eigen::MatrixX3d::Zero(pattern.rows(), 3)),
        keys(tools, 0),
        warm_up(pattern.rows()),
        loads(Eigen::MatrixX3d::Zero(pattern.rows(), 3)),
        warm_up3(pattern.rows(), 3) {
    factorization->analyze(pattern);
  }

  /// Factorizes `tangent` (same pattern); false when a pivot is zero or not
  /// finite, or when the inertia is not that of a stable equilibrium's tangent:
  /// positive definite, or for psh quasi-definite with exactly one negative
  /// pivot per pressure (Sylvester: LDLᵀ keeps the inertia under any ordering).
  /// A tangent that fails (a buckling or unstable state) would drive the next
  /// iterations away from equilibrium; the kept one serves instead. A first
  /// solve of each width readies the factorization's real-time solves.
  bool factorize(const SparseMatrix& tangent, Eigen::Index negative_pivots) {
    std::fill(keys.begin(), keys.end(), 0);  // the responses were solved with another factorization
    if (!factorization->factorize(tangent) || factorization->negative_pivots() != negative_pivots) return false;
    solve(loads.col(0), warm_up);
    factorization->solve3(loads, warm_up3);
    return true;
  }

  void solve(const Eigen::Ref<const Eigen::VectorXd>& rhs, Eigen::Ref<Eigen::VectorXd> solution) noexcept {
    factorization->solve(rhs, solution);
  }
};

/// The contacts' capacitance matrix W (active tools in `order`) and its factorization.
struct OrganFem::Capacitance {
  std::array<std::uint32_t, kMaxContacts> order{};
  std::size_t active = 0;
  SmallMatrix matrix, unit, inverse;
  Eigen::LDLT<SmallMatrix> ldlt;
  SmallVector gap, multipliers;
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
        contacts_(owner.contacts_.size()),
        spare_(std::move(spare)),
        thread_([this] { run(); }) {
    system_.set_definite_tangent(true);
  }
  ~Worker() {
    stop_.store(true, std::memory_order_release);
    thread_.join();
  }

  /// Owner: starts a refresh at `state` for `contacts`.
  void request(const Eigen::VectorXd& state, const std::vector<Contact>& contacts) noexcept {
    snapshot_ = state;  // same sizes: copies, no allocation
    std::copy(contacts.begin(), contacts.end(), contacts_.begin());
    phase_.store(kRequested, std::memory_order_release);
  }
  /// Owner: waits for the requested refresh; true with `spare()` holding the
  /// fresh tangent, false when the tangent at the snapshot was unusable.
  bool wait() noexcept {
    // Sleep, not yield: the deformation loop runs with real-time priority,
    // and a yielding real-time thread would keep the worker off its CPU.
    while (phase_.load(std::memory_order_acquire) == kRequested) std::this_thread::sleep_for(std::chrono::microseconds(100));
    return phase_.load(std::memory_order_acquire) == kReady;
  }
  /// Owner: true when the requested refresh is done and usable (the owner
  /// may then work on `spare()`), without waiting.
  bool ready() const noexcept { return phase_.load(std::memory_order_acquire) == kReady; }
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
      bool ok = system_.assemble(snapshot_, gradient_, true) < 0 && spare_->factorize(system_.tangent_free(), owner_.pressure_count());
      if (ok)
        for (std::uint32_t t = 0; t < contacts_.size(); ++t)
          if (contacts_[t].active) owner_.respond(*spare_, t, contacts_[t]);
      phase_.store(ok ? kReady : kFailed, std::memory_order_release);
    }
  }

  const OrganFem& owner_;
  ElasticitySystem system_;  // its own: assembling the tangent writes the system's matrices
  Eigen::VectorXd snapshot_, gradient_;
  std::vector<Contact> contacts_;
  std::unique_ptr<Tangent> spare_;
  std::atomic<int> phase_{kIdle};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

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
  if (tools == 0 || tools > kMaxContacts) throw std::invalid_argument("the FEM model takes 1 to 16 tools");

  TetMesh mesh;
  mesh.nodes.reserve(model.volume_vertices.size());
  for (const model::Point3& p : model.volume_vertices) mesh.nodes.push_back(point(p));
  mesh.tetrahedra.reserve(model.tetrahedra.size());
  for (const model::Tetrahedron& t : model.tetrahedra)
    mesh.tetrahedra.push_back({static_cast<std::int32_t>(t[0]), static_cast<std::int32_t>(t[1]),
                               static_cast<std::int32_t>(t[2]), static_cast<std::int32_t>(t[3])});

  // The clamp: a ball of nodes; three of them not on one line hold the body.
  const Eigen::Vector3d fixed_point = point(model.fixed_points[0]);
  std::vector<bool> constrained(3 * mesh.nodes.size(), false);
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::vector<std::size_t> clamped;
  for (std::size_t n = 0; n < mesh.nodes.size(); ++n)
    if ((mesh.nodes[n] - fixed_point).norm() <= options.fixed_radius) {
      clamped.push_back(n);
      mean += mesh.nodes[n];
      constrained[3 * n] = constrained[3 * n + 1] = constrained[3 * n + 2] = true;
    }
  clamped_nodes_ = clamped.size();
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
  if (!clamped.empty()) mean /= static_cast<double>(clamped.size());
  for (std::size_t n : clamped) spread += (mesh.nodes[n] - mean) * (mesh.nodes[n] - mean).transpose();
  const Eigen::Vector3d spread_eigen = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(spread).eigenvalues();
  if (clamped.size() < 3 || !(std::sqrt(std::max(spread_eigen[1], 0.0)) > 1e-3 * options.fixed_radius))
    throw std::invalid_argument("only " + std::to_string(clamped.size()) +
                                " tetrahedral node(s) lie within the clamp radius of the fixed point, not three off "
                                "one line: raise the clamp radius (--fixed-radius)");

  const double young = model.material.young_modulus, poisson = model.material.poisson_ratio;
  const Material law = material == MaterialModel::mooney_rivlin
                           ? Material::mooney_rivlin_from_young(young, options.psh_poisson_ratio, options.stabilization)
                           : Material::from_young(material, young, poisson);
  system_ = std::make_unique<ElasticitySystem>(mesh, law, constrained);
  factorization_ = options.factorization;
  realtime_solves_ = options.realtime_solves;
  if (system_->has_pressure()) pressure_scale_ = law.bulk_modulus / system_->mean_diameter();

  const std::size_t dofs = static_cast<std::size_t>(system_->dof_count());
  const Eigen::Index free = system_->free_count();
  free_dofs_.resize(static_cast<std::size_t>(free));
  for (std::size_t d = 0; d < dofs; ++d)
    if (system_->free_index()[d] >= 0) free_dofs_[static_cast<std::size_t>(system_->free_index()[d])] = static_cast<std::int32_t>(d);
  state_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(dofs));
  saved_ = state_;
  gradient_ = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(dofs));
  system_->assemble(state_, gradient_, true);
  gradient_.setZero();  // the rest state is in equilibrium (no loads)

  displacement_dofs_ = 3 * mesh.nodes.size();
  contacts_.resize(tools);
  tangent_ = make_tangent(true);
  const auto start = std::chrono::steady_clock::now();
  if (!tangent_->factorize(system_->tangent_free(), pressure_count()))
    throw std::invalid_argument("the FEM stiffness at rest is singular: the clamp does not hold the organ (raise "
                                "--fixed-radius)");
  factorization_seconds_ = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();

  boundary_ = geometry::tetrahedral_boundary(model.tetrahedra);
  node_points_ = model.volume_vertices;
  boundary_tree_ = std::make_unique<geometry::SurfaceBvh>(node_points_, boundary_.faces);
  surface_rest_ = model.surface_vertices;
  embedding_ = geometry::embed_surface_in_tetrahedra(model, boundary_);

  rhs_.resize(free);
  step_.resize(free);
  refresh_frames_ =
      material == MaterialModel::corotational || material == MaterialModel::stvk ? options.refresh_frames : 0;
  relaxation_ = material == MaterialModel::linear ? 1.0 : options.relaxation;
  if (refresh_frames_ > 0) {
    // The rest factorization stays as the fallback; the frames use it until
    // the worker's first tangent takes the place of the empty one.
    rest_tangent_ = std::move(tangent_);
    using_rest_ = true;
    tangent_ = make_tangent(true);
    worker_ = std::make_unique<Worker>(*this, *system_, make_tangent(true));
  }
  update_capacitance();
}

OrganFem::~OrganFem() = default;

std::unique_ptr<OrganFem::Tangent> OrganFem::make_tangent(bool realtime_solve) const {
  const MatrixKind kind = system_->has_pressure() ? MatrixKind::quasi_definite : MatrixKind::positive_definite;
  return std::make_unique<Tangent>(system_->tangent_free(), contacts_.size(),
                                   make_factorization(factorization_, kind,
                                                      realtime_solve && realtime_solves_ ? SolveUse::realtime : SolveUse::newton));
}

const char* OrganFem::linear_solver() const noexcept {
  return (using_rest_ ? *rest_tangent_ : *tangent_).factorization->name();
}

bool OrganFem::attached(std::uint32_t tool) const noexcept { return tool < contacts_.size() && contacts_[tool].active; }

Eigen::Vector3d OrganFem::gather(const Contact& contact, const Eigen::Ref<const Eigen::VectorXd>& free_values) const noexcept {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < 3; ++i)
    for (int k = 0; k < 3; ++k) {
      const std::int32_t f = system_->free_index()[static_cast<std::size_t>(3 * contact.nodes[i] + k)];
      if (f >= 0) sum[k] += contact.weights[static_cast<Eigen::Index>(i)] * free_values[f];
    }
  return sum;
}

void OrganFem::respond(Tangent& tangent, std::uint32_t tool, const Contact& contact) const noexcept {
  tangent.loads.setZero();
  for (int k = 0; k < 3; ++k)
    for (std::size_t i = 0; i < 3; ++i)
      tangent.loads(system_->free_index()[static_cast<std::size_t>(3 * contact.nodes[i] + k)], k) =
          contact.weights[static_cast<Eigen::Index>(i)];
  tangent.factorization->solve3(tangent.loads, tangent.responses[tool]);
  tangent.keys[tool] = contact.generation;
}

bool OrganFem::attach(std::uint32_t tool, const Eigen::Vector3d& rest_point) noexcept {
  if (tool >= contacts_.size() || !rest_point.allFinite()) return false;
  const geometry::SurfacePoint nearest = boundary_tree_->closest_point(rest_point);
  const model::Triangle& face = boundary_.faces[nearest.triangle];
  for (std::uint32_t node : face) {
    if (system_->free_index()[3 * node] < 0) return false;  // a clamped node cannot follow a tool
    for (std::size_t other = 0; other < contacts_.size(); ++other)
      if (other != tool && contacts_[other].active &&
          std::find(contacts_[other].nodes.begin(), contacts_[other].nodes.end(), static_cast<std::int32_t>(node)) !=
              contacts_[other].nodes.end())
        return false;
  }
  Contact& c = contacts_[tool];
  c.nodes = {static_cast<std::int32_t>(face[0]), static_cast<std::int32_t>(face[1]), static_cast<std::int32_t>(face[2])};
  c.weights = nearest.barycentric;
  c.rest_point = nearest.position;
  c.generation = ++generations_;
  c.active = true;
  c.multiplier.setZero();
  c.target = contact_displacement(tool);
  respond(kept(), tool, c);
  solved_this_frame_ = true;
  update_capacitance();
  return true;
}

void OrganFem::detach(std::uint32_t tool) noexcept {
  if (!attached(tool)) return;
  contacts_[tool].active = false;
  contacts_[tool].multiplier.setZero();
  update_capacitance();
}

void OrganFem::update_capacitance() noexcept {
  Capacitance& w = *capacitance_;
  w.active = 0;
  for (std::uint32_t t = 0; t < contacts_.size(); ++t)
    if (contacts_[t].active) w.order[w.active++] = t;
  const Eigen::Index n = static_cast<Eigen::Index>(3 * w.active);
  w.matrix.resize(n, n);
  if (n == 0) return;
  for (std::size_t a = 0; a < w.active; ++a)
    for (std::size_t b = 0; b < w.active; ++b)
      for (int k = 0; k < 3; ++k)
        w.matrix.block<3, 1>(static_cast<Eigen::Index>(3 * a), static_cast<Eigen::Index>(3 * b) + k) =
            gather(contacts_[w.order[a]], kept().responses[w.order[b]].col(k));
  // W is symmetric in exact arithmetic (and for a nonlinear tangent, nearly);
  // the multipliers and stiffness use its symmetric part.
  w.matrix = (0.5 * (w.matrix + w.matrix.transpose())).eval();
  w.ldlt.compute(w.matrix);
  w.unit.setIdentity(n, n);
  w.inverse = w.ldlt.solve(w.unit);
  for (std::size_t a = 0; a < w.active; ++a)
    contacts_[w.order[a]].stiffness =
        w.inverse.block<3, 3>(static_cast<Eigen::Index>(3 * a), static_cast<Eigen::Index>(3 * a));
}

void OrganFem::adopt(std::unique_ptr<Tangent>& fresh) noexcept {
  std::swap(tangent_, fresh);
  using_rest_ = false;
  for (std::uint32_t t = 0; t < contacts_.size(); ++t)
    if (contacts_[t].active && tangent_->keys[t] != contacts_[t].generation) respond(*tangent_, t, contacts_[t]);
  update_capacitance();
  ++refreshes_;
}

void OrganFem::request_refresh() noexcept {
  worker_->request(state_, contacts_);
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
    if (ok || system_->has_pressure()) break;
  }
  system_->set_definite_tangent(false);
  if (ok) adopt(fresh);
  newton_spare_ = std::move(fresh);
  return ok;
}

double OrganFem::iterate() noexcept {
  // Unconstrained correction Δ₀ = −A⁻¹ g, then the multipliers that make the
  // contact points land on their targets: W λ = d − Hᵀ(u + Δ₀).
  Capacitance& w = *capacitance_;
  Tangent& tangent = kept();
  const Eigen::Index free = static_cast<Eigen::Index>(free_dofs_.size());
  for (Eigen::Index j = 0; j < free; ++j) rhs_[j] = -gradient_[free_dofs_[static_cast<std::size_t>(j)]];
  tangent.solve(rhs_, step_);
  const Eigen::Index n = static_cast<Eigen::Index>(3 * w.active);
  w.gap.resize(n);
  for (std::size_t a = 0; a < w.active; ++a) {
    const std::uint32_t t = w.order[a];
    w.gap.segment<3>(static_cast<Eigen::Index>(3 * a)) =
        contacts_[t].target - contact_displacement(t) - gather(contacts_[t], step_);
  }
  if (n > 0) w.multipliers = w.ldlt.solve(w.gap);
  for (std::size_t a = 0; a < w.active; ++a)
    step_.noalias() += tangent.responses[w.order[a]] * w.multipliers.segment<3>(static_cast<Eigen::Index>(3 * a));
  // A step that would invert a tetrahedron (a tool pushed deeper than the
  // mesh can follow in one frame) is cut in halves; the organ then goes as far
  // toward the targets as it can, with the multipliers interpolated as the
  // linearization predicts: g(x + αΔ) ≈ (1 − α) g(x) + α H λ.
  double fraction = relaxation_;
  for (int cut = 0; cut <= kMaxStepCuts; ++cut, fraction *= 0.5) {
    for (Eigen::Index j = 0; j < free; ++j)
      state_[free_dofs_[static_cast<std::size_t>(j)]] = saved_[free_dofs_[static_cast<std::size_t>(j)]] + fraction * step_[j];
    if (system_->assemble(state_, gradient_, false) < 0 && gradient_.allFinite()) return fraction;
  }
  state_ = saved_;
  system_->assemble(state_, gradient_, false);
  return 0.0;
}

FrameStatus OrganFem::step(const Eigen::Vector3d* displacements) noexcept {
  Capacitance& w = *capacitance_;
  for (std::size_t a = 0; a < w.active; ++a)
    if (!displacements[w.order[a]].allFinite()) return FrameStatus::not_finite;
  if (worker_ && refresh_due_ > 0 && frame_ < refresh_due_ && !solved_this_frame_ && worker_->ready()) {
    // A contact attached after the request lacks its response in the fresh
    // tangent: solve one per frame (none in a frame that attached one) while
    // the tangent waits to be adopted, rather than all of them in the frame
    // that adopts it.
    Tangent& fresh = *worker_->spare();
    for (std::uint32_t t = 0; t < contacts_.size(); ++t)
      if (contacts_[t].active && fresh.keys[t] != contacts_[t].generation) {
        respond(fresh, t, contacts_[t]);
        break;
      }
  }
  solved_this_frame_ = false;
  if (worker_ && refresh_due_ > 0 && frame_ >= refresh_due_) {
    if (worker_->wait()) adopt(worker_->spare());
    worker_->release();
    refresh_due_ = 0;
  }
  for (std::size_t a = 0; a < w.active; ++a) contacts_[w.order[a]].target = displacements[w.order[a]];

  const Eigen::Index free = static_cast<Eigen::Index>(free_dofs_.size());
  saved_ = state_;
  double fraction = iterate();
  if (fraction == 0.0 && rest_tangent_ && !using_rest_) {
    // A refreshed tangent that fails even in small steps (a state far from
    // the one it was made at: a tool let go) gives way to the rest tangent
    // until the worker's next one.
    using_rest_ = true;
    for (std::uint32_t t = 0; t < contacts_.size(); ++t)
      if (contacts_[t].active && rest_tangent_->keys[t] != contacts_[t].generation)
        respond(*rest_tangent_, t, contacts_[t]);
    update_capacitance();
    fraction = iterate();
  }
  if (fraction == 0.0) {
    ++frame_;
    if (worker_ && refresh_due_ == 0) request_refresh();
    return FrameStatus::inverted;
  }
  std::array<Eigen::Vector3d, kMaxContacts> multipliers;
  for (std::size_t a = 0; a < w.active; ++a)
    multipliers[a] = (1.0 - fraction) * contacts_[w.order[a]].multiplier +
                     fraction * w.multipliers.segment<3>(static_cast<Eigen::Index>(3 * a));

  // Out of balance: internal forces minus the tools' forces, pressure rows in newtons.
  for (Eigen::Index j = 0; j < free; ++j) {
    const std::size_t d = static_cast<std::size_t>(free_dofs_[static_cast<std::size_t>(j)]);
    rhs_[j] = gradient_[static_cast<Eigen::Index>(d)] * (d < displacement_dofs_ ? 1.0 : pressure_scale_);
  }
  for (std::size_t a = 0; a < w.active; ++a) {
    const Contact& c = contacts_[w.order[a]];
    for (std::size_t i = 0; i < 3; ++i)
      for (int k = 0; k < 3; ++k)
        rhs_[system_->free_index()[static_cast<std::size_t>(3 * c.nodes[i] + k)]] -=
            c.weights[static_cast<Eigen::Index>(i)] * multipliers[a][k];
  }
  for (std::size_t a = 0; a < w.active; ++a) contacts_[w.order[a]].multiplier = multipliers[a];
  step_cuts_ += fraction < relaxation_;
  unbalanced_ = free > 0 ? rhs_.cwiseAbs().maxCoeff() : 0.0;
  ++frame_;
  if (worker_ && refresh_due_ == 0) request_refresh();
  return FrameStatus::ok;
}

void OrganFem::reset() noexcept {
  state_.setZero();
  gradient_.setZero();
  for (Contact& c : contacts_) c.multiplier.setZero();
  unbalanced_ = 0;
}

Eigen::Vector3d OrganFem::contact_point(std::uint32_t tool) const noexcept {
  return tool < contacts_.size() ? contacts_[tool].rest_point : Eigen::Vector3d::Zero();
}

Eigen::Vector3d OrganFem::contact_displacement(std::uint32_t tool) const noexcept {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  if (tool >= contacts_.size()) return sum;
  const Contact& c = contacts_[tool];
  for (std::size_t i = 0; i < 3; ++i)
    sum += c.weights[static_cast<Eigen::Index>(i)] * state_.segment<3>(3 * static_cast<Eigen::Index>(c.nodes[i]));
  return sum;
}

Eigen::Vector3d OrganFem::contact_force(std::uint32_t tool) const noexcept {
  return attached(tool) ? Eigen::Vector3d(-contacts_[tool].multiplier) : Eigen::Vector3d::Zero();
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
