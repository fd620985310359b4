// The mass-spring model (He et al., "An Improved Method on Soft Tissue
// Deformation in Virtual Surgery", 2015; docs/springs.md): point masses joined
// by damped Hooke springs, integrated in time.
//
//   m_i ẍ_i = f_ext,i + m_i g − c ẋ_i + Σ_j [ k_ij (|x_i − x_j| − l⁰_ij) + d_ij ((v_i − v_j)·l̂) ] (−l̂),
//   l̂ = (x_i − x_j)/|x_i − x_j|.
//
// Networks: springs/network.h (the paper's grid, a baked organ's surface);
// integrators and their stability limits: springs/stability.h.
//
// Shaped for real time like the multi-beam model: build the network and the
// simulation once (allocates everything); step(), the force queries and the
// state accessors allocate nothing, take no lock, throw nothing and do no I/O.
// Units: metres, kilograms, seconds, newtons.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

#include "organsim/springs/network.h"
#include "organsim/springs/stability.h"

namespace organsim::springs {

enum class Region : std::uint8_t { all, dynamic, fixed };

/// "all", "dynamic" or "fixed"; anything else is Region::all.
Region parse_region(const std::string& name) noexcept;

struct SimulationOptions {
  /// Integrators over the state (x, v) of the integrated nodes: explicit
  /// (forward) Euler, explicit midpoint (RK2), classical RK4, symplectic
  /// (semi-implicit) Euler (v first, then x with the new v), and linearly
  /// implicit Euler: one Newton step of backward Euler from (x, v),
  /// (M − dt·∂f/∂v − dt²·∂f/∂x) Δv = dt·(f + dt·∂f/∂x·v), v += Δv, x += dt·v,
  /// with ∂f/∂x from each spring's k (l̂ l̂ᵀ + max(0, 1 − l⁰/l)(I − l̂ l̂ᵀ))
  /// (the positive semi-definite part of its geometric stiffness), ∂f/∂v from
  /// the spring damping d l̂ l̂ᵀ and the point damping c I (the damping's
  /// dependence on x is left out), solved by conjugate gradients preconditioned
  /// with the inverse 3×3 diagonal blocks.
  Integrator integrator = Integrator::midpoint;
  double dt = 0.01;                                       ///< s
  Eigen::Vector3d gravity = Eigen::Vector3d(0, 0, -9.8);  ///< m/s²
  double point_damping = 0.0;                             ///< c of −c ẋ_i, N·s/m
  /// Region::all integrates every free node (neither fixed nor held).
  /// Region::dynamic integrates only the free nodes marked active:
  /// - at the start of every step, each free node with a non-zero external
  ///   force, and each free neighbour (joined by any spring) of a node with a
  ///   force or of a held node, is marked active (seeds; they are not retired
  ///   while the force or the hold lasts); a released node is marked active;
  /// - after each step, an active node whose displacement from rest exceeds
  ///   `threshold` marks its free neighbours active for the next steps;
  /// - inactive nodes keep their position and have zero velocity; gravity and
  ///   forces act only on integrated nodes.
  /// Region::fixed (He et al.'s "fixed deformation region", their Fig. 5(a))
  /// integrates only the free nodes within `region_rings` spring hops of a node
  /// with an external force or a held node, however far the deformation
  /// spreads; the rest never moves. The region is found again when a force or a
  /// hold starts or ends.
  Region region = Region::all;
  std::uint32_t region_rings = 3;  ///< Region::fixed: its size in spring hops, ≥ 1
  /// Dynamic region: a frontier node whose displacement from rest exceeds this
  /// (m) activates its neighbours; active nodes whose displacement (m) and speed
  /// (m/s) stay below it for `settle_steps` steps (and that hold no external
  /// force, are no seed and have no neighbour displaced beyond it) are retired:
  /// velocity set to zero, position kept.
  double threshold = 0.001;
  std::uint32_t settle_steps = 10;  ///< ≥ 1
  /// Blow-up: a non-finite state, or total energy above this multiple of the
  /// largest energy the external forces and gravity can have supplied so far
  /// (plus a floor), marks the simulation unstable. Precisely, after each step:
  /// E > limit · (S + E_floor), where
  /// - E is the total energy (kinetic + spring + gravity, as energy()) of the
  ///   integrated part: the integrated nodes and the springs with an integrated
  ///   end (the rest does not change in a step);
  /// - S is the largest value so far (since construction or reset()) of the
  ///   work W done on the network: per step, over the integrated nodes,
  ///   ½·dt·F_i·(v_i before + v_i after) (trapezoidal ∫F·v dt, so that a
  ///   constant force adds up to F·Δx and no more), and per held node moved to
  ///   its target, −½(r before + r after)·Δx (r its reaction_force()). Gravity
  ///   is conservative and already in E; damping only removes energy, so a
  ///   faithful integration keeps E ≤ W + E(rest);
  /// - E_floor is the springs' energy at rest plus that of every spring
  ///   stretched by a tenth of its rest length (plus 10⁻¹² J).
  /// A diverging mode grows geometrically while W grows at most linearly. The
  /// default 10 stops the paper grid's divergence (dt = 0.01, explicit Euler,
  /// 5 N) at its 4th step with the centre 11 cm deep (mass_spring_test.cpp);
  /// 10³ let a marginal divergence (dt just above the stability limit) run to
  /// 10 m before catching it.
  double energy_growth_limit = 10.0;
  /// Implicit Euler: at most this many CG iterations per step (one Newton
  /// step); CG stops earlier once the preconditioned residual norm falls below
  /// 10⁻¹⁰ of the first one. ≥ 1.
  std::uint32_t implicit_cg_iterations = 50;
};

struct Energy {
  double kinetic = 0.0;  ///< J
  double spring = 0.0;   ///< J
  double gravity = 0.0;  ///< J, relative to the rest positions (m g·(x − x_rest) summed with a minus sign)
  double total() const noexcept { return kinetic + spring + gravity; }
};

enum class StepStatus : std::uint8_t {
  ok = 0,
  blew_up,  ///< the step diverged: the state was restored to the last good one and the simulation is unstable
};

class MassSpring {
 public:
  /// Throws std::invalid_argument when the network or the options are unusable
  /// (array sizes differ, a spring index out of range or a = b, a negative or
  /// non-finite rest length, stiffness or damping, a non-positive or non-finite
  /// mass, non-finite rest positions, a triangle index out of range; dt ≤ 0,
  /// non-finite gravity, negative point damping or threshold, settle_steps 0,
  /// energy_growth_limit ≤ 0, implicit_cg_iterations 0).
  MassSpring(SpringNetwork network, const SimulationOptions& options);

  const SpringNetwork& network() const noexcept { return network_; }
  const SimulationOptions& options() const noexcept { return options_; }
  std::size_t node_count() const noexcept { return network_.rest.size(); }

  /// External force on a node (N), held until changed; zero by default.
  /// Ignored for an index out of range or a non-finite force; has no effect
  /// on fixed or held nodes.
  void set_external_force(std::uint32_t node, const Eigen::Vector3d& force) noexcept;
  void clear_external_forces() noexcept;
  /// A kinematic node: it follows `position` (m) exactly from the next step on
  /// (a tool holding it), until release(). At the start of every step it is
  /// put at `position` with zero velocity. Its spring forces are still computed:
  /// reaction_force() reports them. Ignored for fixed nodes, an index out of
  /// range or a non-finite position.
  void hold(std::uint32_t node, const Eigen::Vector3d& position) noexcept;
  /// The node moves freely again from where it is (velocity zero).
  void release(std::uint32_t node) noexcept;
  /// Σ of the spring forces (Hooke and spring damping) the network exerts on
  /// a node at the current state, and its support's (N): for a held node, what
  /// the tool holding it feels. Zero for an index out of range.
  Eigen::Vector3d reaction_force(std::uint32_t node) const noexcept;
  /// The 3×3 stiffness of the springs at `node` with its neighbours held: the
  /// local linearization of reaction_force() (N/m), Σ k (l̂ l̂ᵀ + (1 − l⁰/l)(I − l̂ l̂ᵀ)),
  /// plus its support's, so that reaction_force(x + δ) ≈ reaction_force(x) − K δ.
  /// Not clamped: a compressed spring contributes a negative transverse part.
  Eigen::Matrix3d contact_stiffness(std::uint32_t node) const noexcept;
  /// The same for a node moved together with a group of nodes (those whose
  /// `group` entry equals `member`, per node): the springs to other members
  /// do not stretch and are left out. Summed over the group's nodes, the
  /// stiffness of the group moved as one.
  Eigen::Matrix3d contact_stiffness(std::uint32_t node, const std::int16_t* group, std::int16_t member) const noexcept;

  /// One time step of options().dt. Once the simulation is unstable it returns
  /// blew_up and changes nothing until reset().
  StepStatus step() noexcept;
  /// Back to rest, velocities zero, all nodes stable again, steps() zero, the
  /// dynamic region empty; forces and holds kept.
  void reset() noexcept;

  const Eigen::Vector3d& position(std::uint32_t node) const noexcept { return x_[node]; }
  const Eigen::Vector3d& velocity(std::uint32_t node) const noexcept { return v_[node]; }
  /// Of the whole network: kinetic Σ ½ m v², spring Σ ½ k (l − l⁰)², gravity.
  Energy energy() const noexcept;
  bool stable() const noexcept { return stable_; }
  /// Nodes integrated in the last step (all free nodes, i.e. neither fixed nor
  /// held, with Region::all); 0 before the first step and after reset().
  std::size_t active_count() const noexcept { return active_count_; }
  /// Those nodes (active_count() indices; valid until the next step() or reset()).
  const std::uint32_t* integrated_nodes() const noexcept { return integrated_nodes_.data(); }
  /// Steps taken since construction or reset() (a step that blew up is not counted).
  std::uint64_t steps() const noexcept { return steps_; }

 private:
  using Points = std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>>;
  using Blocks = std::vector<Eigen::Matrix3d, Eigen::aligned_allocator<Eigen::Matrix3d>>;

  void rebuild_lists() noexcept;
  void rebuild_seeds() noexcept;
  void mark_seeds() noexcept;
  void begin_region() noexcept;
  void mark_fixed_region() noexcept;
  void end_region() noexcept;
  void activate(std::uint32_t node) noexcept;
  /// Accelerations of the integrated nodes at the state (x, v); other entries untouched.
  void accelerations(const Points& x, const Points& v, Points& a) noexcept;
  /// The state's arrays as plain pointers for the integrators' loops.
  struct StepArrays {
    Eigen::Vector3d *x, *v, *stage_x, *stage_v, *sum_x, *sum_v;
    const Eigen::Vector3d* accel;
    const std::uint32_t* nodes;  // the integrated nodes
    std::size_t count;
    double h;  // s
  };
  StepArrays step_arrays() noexcept;
  double move_held_nodes() noexcept;  // the held nodes' jumps; returns the tool's work on them (J)
  void step_explicit_euler() noexcept;
  void step_symplectic_euler() noexcept;
  void step_midpoint() noexcept;
  void step_rk4() noexcept;
  void step_implicit_euler() noexcept;
  /// After a step: a non-finite state or the energy beyond the limit; adds the
  /// external forces' work of the step to `work`.
  bool blew_up(double& work) const noexcept;
  void sync_stage() noexcept;
  void apply_implicit_matrix(const Points& p, Points& q) noexcept;
  bool freely_movable(std::uint32_t node) const noexcept { return !network_.fixed[node] && !held_[node]; }

  SpringNetwork network_;
  SimulationOptions options_;
  // State: one 3-vector per node, all nodes (fixed and held ones included).
  Points x_, v_;
  Points saved_x_, saved_v_;                  // the state before the current step (last good state), movable nodes
  std::vector<std::uint32_t> movable_nodes_;  // the nodes that are not fixed
  // Per node inputs.
  Points external_, target_;
  std::vector<std::uint8_t> held_;
  std::vector<double> inverse_mass_;
  std::vector<std::int32_t> support_of_;  // per node: its entry in network_.supports, or −1
  // Node → incident springs and the other end (CSR, 2 entries per spring).
  std::vector<std::uint32_t> incidence_offset_, incidence_spring_, incidence_other_;
  // What is integrated: flags, the node list and the springs with an integrated end.
  std::vector<std::uint8_t> integrated_, active_;
  std::vector<std::uint32_t> quiet_steps_;
  std::vector<std::uint32_t> integrated_nodes_, force_springs_;
  std::size_t integrated_count_ = 0, force_spring_count_ = 0;
  // The springs of force_springs_ in that order, as arrays: the force pass
  // reads them in blocks, the block's square roots and divisions vectorized.
  std::vector<std::uint32_t> force_a_, force_b_;
  std::vector<double> force_rest_, force_stiffness_, force_damping_;
  // All springs ordered by (first end, second end): consecutive springs share
  // their first end, whose force sum then stays in a register.
  std::vector<std::uint32_t> spring_order_;
  Points spring_force_;  // per node Σ of the spring forces of one evaluation
  // Nodes with a non-zero external force, and held nodes.
  std::vector<std::uint32_t> forced_nodes_, held_nodes_;
  std::vector<std::uint32_t> region_queue_;  // Region::fixed: the breadth-first search's nodes
  bool region_dirty_ = true;                 // Region::fixed: the seeds changed since the region was found
  std::size_t forced_count_ = 0, held_count_ = 0;
  bool lists_dirty_ = true, seeds_dirty_ = true;
  bool stage_stale_ = true;  // the stage state's unwritten nodes may differ from the state
  // Integrator scratch: stage state, RK4 sums, accelerations.
  Points stage_x_, stage_v_, sum_x_, sum_v_, accel_;
  // Implicit Euler: per-spring blocks dt·d·l̂l̂ᵀ + dt²·K_s, inverse diagonal
  // blocks, and the CG vectors (sized only for that integrator).
  Blocks spring_block_, diagonal_inverse_;
  Points rhs_, delta_v_, residual_, preconditioned_, direction_, product_;
  // Blow-up detection.
  double work_ = 0.0;      // work of the external forces and the tools since construction or reset()
  double supplied_ = 0.0;  // the largest work_ so far
  double energy_floor_ = 0.0;
  bool stable_ = true;
  std::size_t active_count_ = 0;
  std::uint64_t steps_ = 0;
};

}  // namespace organsim::springs
