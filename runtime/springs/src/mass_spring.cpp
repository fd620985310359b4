// The mass-spring simulation (mass_spring.h): forces, the five integrators, the
// dynamic region and blow-up detection. Everything step() touches is sized in
// the constructor.
#include "organsim/springs/mass_spring.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <stdexcept>
#include <string>
#include <utility>

#include <Eigen/LU>

namespace organsim::springs {
namespace {

bool non_negative(double value) { return std::isfinite(value) && value >= 0.0; }

constexpr double kCgTolerance = 1e-10;  // preconditioned residual norm, relative to the first

// The springs' arithmetic (a square root and a division each) is most of a
// step: in the portable build it is compiled for AVX2/FMA too and picked when
// the program loads (an ifunc). Plain arrays and builtins only, so that no
// inline function is compiled for one target and linked into another.
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(__AVX2__)
#define ORGANSIM_SPRING_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define ORGANSIM_SPRING_CLONES
#endif

// Per spring of a block, f = (k (l − l⁰) + c û·Δv) û with û = d / l, as a
// multiple of d: d (the ends' difference a − b, m) becomes the force on b (N).
ORGANSIM_SPRING_CLONES void spring_forces(std::size_t count, double* __restrict__ dx, double* __restrict__ dy,
                                          double* __restrict__ dz, const double* __restrict__ dvx,
                                          const double* __restrict__ dvy, const double* __restrict__ dvz,
                                          const double* __restrict__ rest, const double* __restrict__ stiffness,
                                          const double* __restrict__ damping) noexcept {
  for (std::size_t j = 0; j < count; ++j) {
    const double squared = dx[j] * dx[j] + dy[j] * dy[j] + dz[j] * dz[j];
    const double closing = dx[j] * dvx[j] + dy[j] * dvy[j] + dz[j] * dvz[j];
    const double l2 = squared > 0.0 ? squared : 1.0;
    const double inverse_length = 1.0 / __builtin_sqrt(l2);
    const double m =
        (stiffness[j] * (l2 * inverse_length - rest[j]) + damping[j] * closing * inverse_length) * inverse_length;
    const double magnitude = squared > 0.0 ? m : 0.0;
    dx[j] *= magnitude, dy[j] *= magnitude, dz[j] *= magnitude;
  }
}

}  // namespace

MassSpring::MassSpring(SpringNetwork network, const SimulationOptions& options)
    : network_(std::move(network)), options_(options) {
  auto require = [](bool ok, const std::string& problem) {
    if (!ok) throw std::invalid_argument("MassSpring: " + problem);
  };
  const std::size_t n = network_.rest.size();
  const Springs& s = network_.springs;
  require(n > 0, "the network has no nodes");
  require(n < std::numeric_limits<std::uint32_t>::max(), "the network has too many nodes");
  require(network_.mass.size() == n && network_.fixed.size() == n, "rest, mass and fixed differ in size");
  require(network_.surface_nodes <= n, "surface_nodes exceeds the node count");
  require(s.b.size() == s.size() && s.rest_length.size() == s.size() && s.stiffness.size() == s.size() &&
              s.damping.size() == s.size() && s.kind.size() == s.size(),
          "the spring arrays differ in size");
  require(s.size() < std::numeric_limits<std::uint32_t>::max() / 2, "the network has too many springs");
  for (std::size_t i = 0; i < n; ++i) {
    require(network_.rest[i].allFinite(), "rest position of node " + std::to_string(i) + " is not finite");
    require(std::isfinite(network_.mass[i]) && network_.mass[i] > 0.0,
            "mass of node " + std::to_string(i) + " must be positive and finite");
  }
  for (std::size_t k = 0; k < s.size(); ++k) {
    require(s.a[k] < n && s.b[k] < n && s.a[k] != s.b[k], "spring " + std::to_string(k) + " has bad node indices");
    require(non_negative(s.rest_length[k]) && non_negative(s.stiffness[k]) && non_negative(s.damping[k]),
            "spring " + std::to_string(k) + " has a negative or non-finite rest length, stiffness or damping");
  }
  for (const model::Triangle& t : network_.triangles)
    require(t[0] < n && t[1] < n && t[2] < n, "a triangle's node index is out of range");
  support_of_.assign(n, -1);
  for (std::size_t k = 0; k < network_.supports.size(); ++k) {
    const NodeSupport& support = network_.supports[k];
    require(support.node < n && support_of_[support.node] < 0,
            "support " + std::to_string(k) + " has a bad or repeated node index");
    require(
        non_negative(support.stiffness) && support.normal.allFinite() && std::abs(support.normal.norm() - 1.0) < 1e-9,
        "support " + std::to_string(k) + " needs a finite stiffness >= 0 and a unit normal");
    support_of_[support.node] = static_cast<std::int32_t>(k);
  }
  require(std::isfinite(options_.dt) && options_.dt > 0.0, "dt must be positive and finite");
  require(options_.gravity.allFinite(), "gravity must be finite");
  require(non_negative(options_.point_damping), "point_damping must be non-negative and finite");
  require(non_negative(options_.threshold), "threshold must be non-negative and finite");
  require(options_.settle_steps >= 1, "settle_steps must be at least 1");
  require(std::isfinite(options_.energy_growth_limit) && options_.energy_growth_limit > 0.0,
          "energy_growth_limit must be positive and finite");
  require(options_.implicit_cg_iterations >= 1, "implicit_cg_iterations must be at least 1");
  require(options_.integrator <= Integrator::implicit_euler, "unknown integrator");
  require(options_.region <= Region::fixed, "unknown region");
  require(options_.region_rings >= 1, "region_rings must be at least 1");

  x_ = network_.rest;
  v_.assign(n, Eigen::Vector3d::Zero());
  saved_x_ = x_;
  saved_v_ = v_;
  external_.assign(n, Eigen::Vector3d::Zero());
  target_ = network_.rest;
  held_.assign(n, 0);
  inverse_mass_.resize(n);
  for (std::size_t i = 0; i < n; ++i) inverse_mass_[i] = 1.0 / network_.mass[i];

  incidence_offset_.assign(n + 1, 0);
  for (std::size_t k = 0; k < s.size(); ++k) {
    ++incidence_offset_[s.a[k] + 1];
    ++incidence_offset_[s.b[k] + 1];
  }
  for (std::size_t i = 0; i < n; ++i) incidence_offset_[i + 1] += incidence_offset_[i];
  incidence_spring_.resize(2 * s.size());
  incidence_other_.resize(2 * s.size());
  {
    std::vector<std::uint32_t> fill(incidence_offset_.begin(), incidence_offset_.end() - 1);
    for (std::size_t k = 0; k < s.size(); ++k) {
      incidence_spring_[fill[s.a[k]]] = static_cast<std::uint32_t>(k);
      incidence_other_[fill[s.a[k]]++] = s.b[k];
      incidence_spring_[fill[s.b[k]]] = static_cast<std::uint32_t>(k);
      incidence_other_[fill[s.b[k]]++] = s.a[k];
    }
  }

  for (std::uint32_t i = 0; i < n; ++i)
    if (!network_.fixed[i]) movable_nodes_.push_back(i);
  integrated_.assign(n, 0);
  active_.assign(n, 0);
  quiet_steps_.assign(n, 0);
  integrated_nodes_.assign(n, 0);
  force_springs_.assign(s.size(), 0);
  for (auto* list : {&force_a_, &force_b_}) list->assign(s.size(), 0);
  for (auto* list : {&force_rest_, &force_stiffness_, &force_damping_}) list->assign(s.size(), 0.0);
  spring_order_.resize(s.size());
  std::iota(spring_order_.begin(), spring_order_.end(), 0u);
  std::sort(spring_order_.begin(), spring_order_.end(), [&s](std::uint32_t l, std::uint32_t r) {
    return s.a[l] != s.a[r] ? s.a[l] < s.a[r] : s.b[l] != s.b[r] ? s.b[l] < s.b[r] : l < r;
  });
  spring_force_.assign(n, Eigen::Vector3d::Zero());
  forced_nodes_.assign(n, 0);
  held_nodes_.assign(n, 0);
  region_queue_.assign(n, 0);

  if (options_.integrator == Integrator::midpoint || options_.integrator == Integrator::rk4) {
    stage_x_ = x_;
    stage_v_ = v_;
  }
  if (options_.integrator == Integrator::rk4) {
    sum_x_.assign(n, Eigen::Vector3d::Zero());
    sum_v_.assign(n, Eigen::Vector3d::Zero());
  }
  accel_.assign(n, Eigen::Vector3d::Zero());
  if (options_.integrator == Integrator::implicit_euler) {
    spring_block_.assign(s.size(), Eigen::Matrix3d::Zero());
    diagonal_inverse_.assign(n, Eigen::Matrix3d::Zero());
    for (Points* p : {&rhs_, &delta_v_, &residual_, &preconditioned_, &direction_, &product_})
      p->assign(n, Eigen::Vector3d::Zero());
  }

  // Energy floor: the springs' energy at rest plus every spring stretched by a tenth of its rest length.
  double floor = 1e-12;
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double stretch = (network_.rest[s.a[k]] - network_.rest[s.b[k]]).norm() - s.rest_length[k];
    floor += 0.5 * s.stiffness[k] * (stretch * stretch + 0.01 * s.rest_length[k] * s.rest_length[k]);
  }
  energy_floor_ = floor;
}

void MassSpring::set_external_force(std::uint32_t node, const Eigen::Vector3d& force) noexcept {
  if (node >= node_count() || !force.allFinite()) return;
  if ((external_[node].isZero(0.0)) != (force.isZero(0.0))) seeds_dirty_ = true;
  external_[node] = force;
}

void MassSpring::clear_external_forces() noexcept {
  std::fill(external_.begin(), external_.end(), Eigen::Vector3d::Zero());
  seeds_dirty_ = true;
}

void MassSpring::hold(std::uint32_t node, const Eigen::Vector3d& position) noexcept {
  if (node >= node_count() || network_.fixed[node] || !position.allFinite()) return;
  if (!held_[node]) {
    held_[node] = 1;
    lists_dirty_ = seeds_dirty_ = true;
  }
  target_[node] = position;
}

void MassSpring::release(std::uint32_t node) noexcept {
  if (node >= node_count() || !held_[node]) return;
  held_[node] = 0;
  v_[node].setZero();
  if (options_.region == Region::dynamic) activate(node);
  lists_dirty_ = seeds_dirty_ = true;
}

Eigen::Vector3d MassSpring::reaction_force(std::uint32_t node) const noexcept {
  Eigen::Vector3d force = Eigen::Vector3d::Zero();
  if (node >= node_count()) return force;
  const Springs& s = network_.springs;
  for (std::uint32_t e = incidence_offset_[node]; e < incidence_offset_[node + 1]; ++e) {
    const std::uint32_t k = incidence_spring_[e], other = incidence_other_[e];
    const Eigen::Vector3d d = x_[node] - x_[other];
    const double l = d.norm();
    if (!(l > 0.0)) continue;
    const Eigen::Vector3d u = d / l;
    force -= (s.stiffness[k] * (l - s.rest_length[k]) + s.damping[k] * u.dot(v_[node] - v_[other])) * u;
  }
  if (const std::int32_t k = support_of_[node]; k >= 0)
    force += network_.supports[static_cast<std::size_t>(k)].force(x_[node] - network_.rest[node]);
  return force;
}

Eigen::Matrix3d MassSpring::contact_stiffness(std::uint32_t node) const noexcept {
  return contact_stiffness(node, nullptr, 0);
}

Eigen::Matrix3d MassSpring::contact_stiffness(std::uint32_t node, const std::int16_t* group,
                                              std::int16_t member) const noexcept {
  Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();
  if (node >= node_count()) return stiffness;
  const Springs& s = network_.springs;
  for (std::uint32_t e = incidence_offset_[node]; e < incidence_offset_[node + 1]; ++e) {
    if (group != nullptr && group[incidence_other_[e]] == member) continue;
    const std::uint32_t k = incidence_spring_[e];
    const Eigen::Vector3d d = x_[node] - x_[incidence_other_[e]];
    const double l = d.norm();
    if (l > 0.0) {
      const Eigen::Matrix3d p = (d / l) * (d / l).transpose();
      stiffness += s.stiffness[k] * (p + (1.0 - s.rest_length[k] / l) * (Eigen::Matrix3d::Identity() - p));
    } else if (s.rest_length[k] == 0.0) {
      stiffness += s.stiffness[k] * Eigen::Matrix3d::Identity();  // a zero-length spring at zero length
    }
  }
  if (const std::int32_t k = support_of_[node]; k >= 0)
    stiffness += network_.supports[static_cast<std::size_t>(k)].stiffness_at(x_[node] - network_.rest[node]);
  return stiffness;
}

Energy MassSpring::energy() const noexcept {
  Energy e;
  const Springs& s = network_.springs;
  for (std::size_t i = 0; i < x_.size(); ++i) {
    e.kinetic += 0.5 * network_.mass[i] * v_[i].squaredNorm();
    e.gravity -= network_.mass[i] * options_.gravity.dot(x_[i] - network_.rest[i]);
  }
  for (std::size_t k = 0; k < s.size(); ++k) {
    const double stretch = (x_[s.a[k]] - x_[s.b[k]]).norm() - s.rest_length[k];
    e.spring += 0.5 * s.stiffness[k] * stretch * stretch;
  }
  for (const NodeSupport& support : network_.supports) {
    // ½ K |u|², or ½ K ⟨u·n⟩₊² on a contact: the work of force() from rest.
    const Eigen::Vector3d u = x_[support.node] - network_.rest[support.node];
    e.spring += 0.5 * u.dot(-support.force(u));
  }
  return e;
}

Region parse_region(const std::string& name) noexcept {
  return name == "dynamic" ? Region::dynamic : name == "fixed" ? Region::fixed : Region::all;
}

void MassSpring::reset() noexcept {
  std::copy(network_.rest.begin(), network_.rest.end(), x_.begin());
  std::fill(v_.begin(), v_.end(), Eigen::Vector3d::Zero());
  std::fill(active_.begin(), active_.end(), std::uint8_t{0});
  std::fill(quiet_steps_.begin(), quiet_steps_.end(), 0u);
  lists_dirty_ = seeds_dirty_ = stage_stale_ = true;
  supplied_ = work_ = 0.0;
  stable_ = true;
  active_count_ = 0;
  steps_ = 0;
}

void MassSpring::activate(std::uint32_t node) noexcept {
  if (!active_[node]) {
    active_[node] = 1;
    lists_dirty_ = true;
  }
  quiet_steps_[node] = 0;
}

void MassSpring::rebuild_seeds() noexcept {
  forced_count_ = held_count_ = 0;
  for (std::uint32_t i = 0; i < node_count(); ++i) {
    if (held_[i])
      held_nodes_[held_count_++] = i;
    else if (!network_.fixed[i] && !external_[i].isZero(0.0))
      forced_nodes_[forced_count_++] = i;
  }
  seeds_dirty_ = false;
  region_dirty_ = true;
}

void MassSpring::rebuild_lists() noexcept {
  const bool all = options_.region == Region::all;
  integrated_count_ = 0;
  for (std::uint32_t i = 0; i < node_count(); ++i) {
    const bool integrate = freely_movable(i) && (all || active_[i]);
    integrated_[i] = integrate;
    if (integrate) integrated_nodes_[integrated_count_++] = i;
  }
  const Springs& s = network_.springs;
  force_spring_count_ = 0;
  for (const std::uint32_t k : spring_order_)
    if (integrated_[s.a[k]] || integrated_[s.b[k]]) {
      const std::size_t j = force_spring_count_++;
      force_a_[j] = s.a[k];
      force_b_[j] = s.b[k];
      force_rest_[j] = s.rest_length[k];
      force_stiffness_[j] = s.stiffness[k];
      force_damping_[j] = s.damping[k];
      force_springs_[j] = k;
    }
  lists_dirty_ = false;
  stage_stale_ = true;
}

void MassSpring::sync_stage() noexcept {
  // The stage state's nodes that no stage writes (fixed, held, not integrated)
  // must hold the state's values; of those only the held ones change from step
  // to step while the lists stay as they are.
  if (stage_stale_) {
    std::copy(x_.begin(), x_.end(), stage_x_.begin());
    std::copy(v_.begin(), v_.end(), stage_v_.begin());
    stage_stale_ = false;
    return;
  }
  for (std::size_t k = 0; k < held_count_; ++k) {
    const std::uint32_t i = held_nodes_[k];
    stage_x_[i] = x_[i];
    stage_v_[i] = v_[i];
  }
}

void MassSpring::mark_seeds() noexcept {
  if (seeds_dirty_) rebuild_seeds();
  auto activate_neighbours = [this](std::uint32_t node) {
    for (std::uint32_t e = incidence_offset_[node]; e < incidence_offset_[node + 1]; ++e)
      if (freely_movable(incidence_other_[e])) activate(incidence_other_[e]);
  };
  for (std::size_t k = 0; k < forced_count_; ++k) {
    activate(forced_nodes_[k]);
    activate_neighbours(forced_nodes_[k]);
  }
  for (std::size_t k = 0; k < held_count_; ++k) activate_neighbours(held_nodes_[k]);
}

void MassSpring::mark_fixed_region() noexcept {
  if (seeds_dirty_) rebuild_seeds();
  region_dirty_ = false;
  std::fill(active_.begin(), active_.end(), std::uint8_t{0});
  std::size_t end = 0;
  const auto visit = [&](std::uint32_t node) {
    if (active_[node] || network_.fixed[node]) return;
    active_[node] = 1;
    region_queue_[end++] = node;
  };
  for (std::size_t k = 0; k < forced_count_; ++k) visit(forced_nodes_[k]);
  for (std::size_t k = 0; k < held_count_; ++k) visit(held_nodes_[k]);
  std::size_t next = 0;
  for (std::uint32_t ring = 0; ring < options_.region_rings; ++ring)
    for (const std::size_t ring_end = end; next < ring_end; ++next)
      for (std::uint32_t e = incidence_offset_[region_queue_[next]]; e < incidence_offset_[region_queue_[next] + 1];
           ++e)
        visit(incidence_other_[e]);
  lists_dirty_ = true;
}

void MassSpring::begin_region() noexcept {
  if (options_.region == Region::dynamic) mark_seeds();
  if (options_.region == Region::fixed && (seeds_dirty_ || region_dirty_)) mark_fixed_region();
  if (lists_dirty_) rebuild_lists();
  active_count_ = integrated_count_;
}

void MassSpring::end_region() noexcept {
  if (options_.region != Region::dynamic) return;
  // Over the nodes integrated in this step (the list is not rebuilt here).
  const double threshold2 = options_.threshold * options_.threshold;
  for (std::size_t k = 0; k < integrated_count_; ++k) {
    const std::uint32_t i = integrated_nodes_[k];
    const bool quiet = (x_[i] - network_.rest[i]).squaredNorm() < threshold2 && v_[i].squaredNorm() < threshold2;
    quiet_steps_[i] = quiet ? std::min(quiet_steps_[i] + 1, options_.settle_steps) : 0;
  }
  // Seeds stay active; the neighbours of a node displaced beyond the threshold become (or stay) active.
  mark_seeds();
  for (std::size_t k = 0; k < integrated_count_; ++k) {
    const std::uint32_t i = integrated_nodes_[k];
    if ((x_[i] - network_.rest[i]).squaredNorm() > threshold2)
      for (std::uint32_t e = incidence_offset_[i]; e < incidence_offset_[i + 1]; ++e)
        if (freely_movable(incidence_other_[e])) activate(incidence_other_[e]);
  }
  for (std::size_t k = 0; k < integrated_count_; ++k) {
    const std::uint32_t i = integrated_nodes_[k];
    if (active_[i] && quiet_steps_[i] >= options_.settle_steps) {
      active_[i] = 0;
      quiet_steps_[i] = 0;
      v_[i].setZero();
      lists_dirty_ = true;
    }
  }
}

void MassSpring::accelerations(const Points& x, const Points& v, Points& a) noexcept {
  // Accumulate into every node without asking which end is integrated (no
  // branch in the loop); only the integrated nodes' sums are read below, so
  // only theirs start from zero (the others, anchors above all, are never read).
  for (std::size_t k = 0; k < integrated_count_; ++k) spring_force_[integrated_nodes_[k]].setZero();
  // Blocks of springs in three passes: gather the ends' differences, then the
  // block's arithmetic (square roots and divisions included) in a loop the
  // compiler vectorizes, then scatter the forces. Springs are ordered by their
  // first end a: its sum stays in a register until a changes, instead of a
  // read-modify-write of memory that every next spring would wait for.
  constexpr std::size_t kBlock = 64;
  alignas(64) double dx[kBlock], dy[kBlock], dz[kBlock], dvx[kBlock], dvy[kBlock], dvz[kBlock];
  // Local pointers: the stores into the sums could alias the vectors' own
  // members as far as the compiler knows, which would reload them per spring.
  const std::uint32_t* const ends_a = force_a_.data();
  const std::uint32_t* const ends_b = force_b_.data();
  const Eigen::Vector3d* const positions = x.data();
  const Eigen::Vector3d* const velocities = v.data();
  Eigen::Vector3d* const sums = spring_force_.data();
  std::uint32_t current = force_spring_count_ > 0 ? ends_a[0] : 0;
  Eigen::Vector3d current_sum = Eigen::Vector3d::Zero();
  for (std::size_t first = 0; first < force_spring_count_; first += kBlock) {
    const std::size_t count = std::min(kBlock, force_spring_count_ - first);
    for (std::size_t j = 0; j < count; ++j) {
      const std::uint32_t ia = ends_a[first + j], ib = ends_b[first + j];
      const Eigen::Vector3d d = positions[ia] - positions[ib];
      const Eigen::Vector3d dv = velocities[ia] - velocities[ib];
      dx[j] = d.x(), dy[j] = d.y(), dz[j] = d.z();
      dvx[j] = dv.x(), dvy[j] = dv.y(), dvz[j] = dv.z();
    }
    spring_forces(count, dx, dy, dz, dvx, dvy, dvz, force_rest_.data() + first, force_stiffness_.data() + first,
                  force_damping_.data() + first);
    for (std::size_t j = 0; j < count; ++j) {
      const std::uint32_t ia = ends_a[first + j];
      if (ia != current) {
        sums[current] += current_sum;
        current = ia;
        current_sum.setZero();
      }
      const Eigen::Vector3d f(dx[j], dy[j], dz[j]);
      current_sum -= f;
      sums[ends_b[first + j]] += f;
    }
  }
  if (force_spring_count_ > 0) sums[current] += current_sum;
  for (const NodeSupport& support : network_.supports)
    sums[support.node] += support.force(positions[support.node] - network_.rest[support.node]);
  const double c = options_.point_damping;
  for (std::size_t k = 0; k < integrated_count_; ++k) {
    const std::uint32_t i = integrated_nodes_[k];
    a[i] = (spring_force_[i] + external_[i] - c * v[i]) * inverse_mass_[i] + options_.gravity;
  }
}

void MassSpring::apply_implicit_matrix(const Points& p, Points& q) noexcept {
  const Springs& s = network_.springs;
  const double diagonal_damping = options_.dt * options_.point_damping;
  for (std::size_t k = 0; k < integrated_count_; ++k) {
    const std::uint32_t i = integrated_nodes_[k];
    q[i] = (network_.mass[i] + diagonal_damping) * p[i];
  }
  for (std::size_t j = 0; j < force_spring_count_; ++j) {
    const std::uint32_t k = force_springs_[j], ia = s.a[k], ib = s.b[k];
    const bool in_a = integrated_[ia], in_b = integrated_[ib];
    Eigen::Vector3d difference = Eigen::Vector3d::Zero();
    if (in_a) difference += p[ia];
    if (in_b) difference -= p[ib];
    const Eigen::Vector3d w = spring_block_[k] * difference;
    if (in_a) q[ia] += w;
    if (in_b) q[ib] -= w;
  }
}

void MassSpring::step_implicit_euler() noexcept {
  const double h = options_.dt, h2 = h * h;
  const Springs& s = network_.springs;
  accelerations(x_, v_, accel_);
  const double diagonal_damping = h * options_.point_damping;
  Eigen::Matrix3d* diagonal = diagonal_inverse_.data();  // holds the blocks first, inverted below
  for (std::size_t k = 0; k < integrated_count_; ++k) {
    const std::uint32_t i = integrated_nodes_[k];
    rhs_[i] = h * network_.mass[i] * accel_[i];
    diagonal[i] = (network_.mass[i] + diagonal_damping) * Eigen::Matrix3d::Identity();
  }
  for (std::size_t j = 0; j < force_spring_count_; ++j) {
    const std::uint32_t k = force_springs_[j], ia = s.a[k], ib = s.b[k];
    const Eigen::Vector3d d = x_[ia] - x_[ib];
    const double l = d.norm();
    Eigen::Matrix3d stiffness;
    Eigen::Matrix3d& block = spring_block_[k];
    if (l > 0.0) {
      const Eigen::Vector3d u = d / l;
      const Eigen::Matrix3d p = u * u.transpose();
      const double geometric = std::max(0.0, 1.0 - s.rest_length[k] / l);
      stiffness = s.stiffness[k] * (p + geometric * (Eigen::Matrix3d::Identity() - p));
      block = h * s.damping[k] * p + h2 * stiffness;
    } else {
      stiffness = s.rest_length[k] == 0.0 ? Eigen::Matrix3d(s.stiffness[k] * Eigen::Matrix3d::Identity())
                                          : Eigen::Matrix3d::Zero();
      block = h2 * stiffness;
    }
    // rhs = h f − h² K v (∂f/∂x = −K).
    const Eigen::Vector3d w = h2 * (stiffness * (v_[ia] - v_[ib]));
    if (integrated_[ia]) {
      rhs_[ia] -= w;
      diagonal[ia] += block;
    }
    if (integrated_[ib]) {
      rhs_[ib] += w;
      diagonal[ib] += block;
    }
  }
  for (std::size_t k = 0; k < integrated_count_; ++k) {
    const std::uint32_t i = integrated_nodes_[k];
    diagonal[i] = diagonal[i].inverse().eval();
  }

  // Preconditioned conjugate gradients from Δv = 0.
  double rz = 0.0;
  for (std::size_t k = 0; k < integrated_count_; ++k) {
    const std::uint32_t i = integrated_nodes_[k];
    delta_v_[i].setZero();
    residual_[i] = rhs_[i];
    preconditioned_[i] = diagonal[i] * residual_[i];
    direction_[i] = preconditioned_[i];
    rz += residual_[i].dot(preconditioned_[i]);
  }
  const double stop = kCgTolerance * kCgTolerance * rz;
  for (std::uint32_t iteration = 0; iteration < options_.implicit_cg_iterations && rz > stop; ++iteration) {
    apply_implicit_matrix(direction_, product_);
    double pq = 0.0;
    for (std::size_t k = 0; k < integrated_count_; ++k) {
      const std::uint32_t i = integrated_nodes_[k];
      pq += direction_[i].dot(product_[i]);
    }
    if (!(pq > 0.0)) break;
    const double alpha = rz / pq;
    double rz_next = 0.0;
    for (std::size_t k = 0; k < integrated_count_; ++k) {
      const std::uint32_t i = integrated_nodes_[k];
      delta_v_[i] += alpha * direction_[i];
      residual_[i] -= alpha * product_[i];
      preconditioned_[i] = diagonal[i] * residual_[i];
      rz_next += residual_[i].dot(preconditioned_[i]);
    }
    const double beta = rz_next / rz;
    rz = rz_next;
    for (std::size_t k = 0; k < integrated_count_; ++k) {
      const std::uint32_t i = integrated_nodes_[k];
      direction_[i] = preconditioned_[i] + beta * direction_[i];
    }
  }
  for (std::size_t k = 0; k < integrated_count_; ++k) {
    const std::uint32_t i = integrated_nodes_[k];
    v_[i] += delta_v_[i];
    x_[i] += h * v_[i];
  }
}

double MassSpring::move_held_nodes() noexcept {
  // Held nodes jump to their targets: the tool does the work −½(r₀ + r₁)·Δx
  // (r the reaction before and after the jump).
  double work = 0.0;
  for (std::size_t k = 0; k < held_count_; ++k) {
    const std::uint32_t i = held_nodes_[k];
    const Eigen::Vector3d jump = target_[i] - x_[i];
    if (jump.isZero(0.0)) {
      v_[i].setZero();
      continue;
    }
    const Eigen::Vector3d before = reaction_force(i);
    x_[i] = target_[i];
    v_[i].setZero();
    work -= 0.5 * (before + reaction_force(i)).dot(jump);
  }
  return work;
}

// The explicit integrators over the integrated nodes, through local pointers
// (StepArrays): a store through one vector's data could alias another vector's
// members as far as the compiler knows (reloaded per node).

MassSpring::StepArrays MassSpring::step_arrays() noexcept {
  return {x_.data(),     v_.data(),     stage_x_.data(),          stage_v_.data(),   sum_x_.data(),
          sum_v_.data(), accel_.data(), integrated_nodes_.data(), integrated_count_, options_.dt};
}

void MassSpring::step_explicit_euler() noexcept {
  const StepArrays a = step_arrays();
  accelerations(x_, v_, accel_);
  for (std::size_t k = 0; k < a.count; ++k) {
    const std::uint32_t i = a.nodes[k];
    a.x[i] += a.h * a.v[i];
    a.v[i] += a.h * a.accel[i];
  }
}

void MassSpring::step_symplectic_euler() noexcept {
  const StepArrays a = step_arrays();
  accelerations(x_, v_, accel_);
  for (std::size_t k = 0; k < a.count; ++k) {
    const std::uint32_t i = a.nodes[k];
    a.v[i] += a.h * a.accel[i];
    a.x[i] += a.h * a.v[i];
  }
}

void MassSpring::step_midpoint() noexcept {
  const StepArrays a = step_arrays();
  sync_stage();
  accelerations(x_, v_, accel_);
  for (std::size_t k = 0; k < a.count; ++k) {
    const std::uint32_t i = a.nodes[k];
    a.stage_x[i] = a.x[i] + 0.5 * a.h * a.v[i];
    a.stage_v[i] = a.v[i] + 0.5 * a.h * a.accel[i];
  }
  accelerations(stage_x_, stage_v_, accel_);
  for (std::size_t k = 0; k < a.count; ++k) {
    const std::uint32_t i = a.nodes[k];
    a.x[i] += a.h * a.stage_v[i];
    a.v[i] += a.h * a.accel[i];
  }
}

void MassSpring::step_rk4() noexcept {
  const StepArrays a = step_arrays();
  const double h = a.h;
  sync_stage();
  accelerations(x_, v_, accel_);  // k1 = (v, a1)
  for (std::size_t k = 0; k < a.count; ++k) {
    const std::uint32_t i = a.nodes[k];
    a.sum_x[i] = a.v[i];
    a.sum_v[i] = a.accel[i];
    a.stage_x[i] = a.x[i] + 0.5 * h * a.v[i];
    a.stage_v[i] = a.v[i] + 0.5 * h * a.accel[i];
  }
  for (int stage = 2; stage <= 3; ++stage) {  // k2, k3
    accelerations(stage_x_, stage_v_, accel_);
    const double reach = stage == 2 ? 0.5 * h : h;
    for (std::size_t k = 0; k < a.count; ++k) {
      const std::uint32_t i = a.nodes[k];
      const Eigen::Vector3d stage_velocity = a.stage_v[i];
      a.sum_x[i] += 2.0 * stage_velocity;
      a.sum_v[i] += 2.0 * a.accel[i];
      a.stage_x[i] = a.x[i] + reach * stage_velocity;
      a.stage_v[i] = a.v[i] + reach * a.accel[i];
    }
  }
  accelerations(stage_x_, stage_v_, accel_);  // k4
  for (std::size_t k = 0; k < a.count; ++k) {
    const std::uint32_t i = a.nodes[k];
    a.x[i] += (h / 6.0) * (a.sum_x[i] + a.stage_v[i]);
    a.v[i] += (h / 6.0) * (a.sum_v[i] + a.accel[i]);
  }
}

bool MassSpring::blew_up(double& work) const noexcept {
  // A non-finite state, or the integrated part's energy beyond the limit
  // (SimulationOptions::energy_growth_limit); `work` gains the external forces'.
  const double h = options_.dt;
  double energy = 0.0;
  bool finite = true;
  for (std::size_t k = 0; k < integrated_count_; ++k) {
    const std::uint32_t i = integrated_nodes_[k];
    finite = finite && x_[i].allFinite() && v_[i].allFinite();
    work += 0.5 * h * external_[i].dot(saved_v_[i] + v_[i]);  // trapezoidal ∫ F·v dt
    energy += 0.5 * network_.mass[i] * v_[i].squaredNorm() -
              network_.mass[i] * options_.gravity.dot(x_[i] - network_.rest[i]);
  }
  // Single-precision lengths (the test below needs the energy's size, not its
  // last digits) and a block's square roots at once; the block's terms are
  // summed in eight lanes so that the additions vectorize and do not wait for
  // each other.
  constexpr std::size_t kBlock = 64, kLanes = 8;
  alignas(64) float squared[kBlock];
  alignas(64) double term[kBlock];
  alignas(64) double partial[kLanes] = {};
  for (std::size_t first = 0; first < force_spring_count_; first += kBlock) {
    const std::size_t block = std::min(kBlock, force_spring_count_ - first);
    for (std::size_t j = 0; j < block; ++j)
      squared[j] = static_cast<float>((x_[force_a_[first + j]] - x_[force_b_[first + j]]).squaredNorm());
    const double* rest = force_rest_.data() + first;
    const double* stiffness = force_stiffness_.data() + first;
    for (std::size_t j = 0; j < block; ++j) {
      const double stretch = std::sqrt(squared[j]) - rest[j];
      term[j] = 0.5 * stiffness[j] * stretch * stretch;
    }
    for (std::size_t j = block; j < kBlock; ++j) term[j] = 0.0;
    for (std::size_t j = 0; j < kBlock; j += kLanes)
      for (std::size_t lane = 0; lane < kLanes; ++lane) partial[lane] += term[j + lane];
  }
  for (const double lane : partial) energy += lane;
  const double supplied = std::max(supplied_, work_ + work);
  return !finite || !(energy <= options_.energy_growth_limit * (supplied + energy_floor_));
}

StepStatus MassSpring::step() noexcept {
  if (!stable_) return StepStatus::blew_up;
  // Only movable nodes change in a step (anchors and clamped nodes never do).
  for (const std::uint32_t i : movable_nodes_) saved_x_[i] = x_[i], saved_v_[i] = v_[i];
  if (seeds_dirty_) rebuild_seeds();
  double work = move_held_nodes();
  begin_region();
  switch (options_.integrator) {
    case Integrator::explicit_euler: step_explicit_euler(); break;
    case Integrator::symplectic_euler: step_symplectic_euler(); break;
    case Integrator::midpoint: step_midpoint(); break;
    case Integrator::rk4: step_rk4(); break;
    case Integrator::implicit_euler: step_implicit_euler(); break;
  }
  if (blew_up(work)) {
    for (const std::uint32_t i : movable_nodes_) x_[i] = saved_x_[i], v_[i] = saved_v_[i];
    stable_ = false;
    return StepStatus::blew_up;
  }
  work_ += work;
  supplied_ = std::max(supplied_, work_);
  end_region();
  ++steps_;
  return StepStatus::ok;
}

}  // namespace organsim::springs
