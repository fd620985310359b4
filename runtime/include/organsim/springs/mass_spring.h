// The mass-spring model (He et al., "An Improved Method on Soft Tissue
// Deformation in Virtual Surgery", 2015; docs/springs.md): point masses joined
// by damped Hooke springs, integrated in time.
//
//   m_i ẍ_i = f_ext,i + m_i g − c ẋ_i + Σ_j [ k_ij (|x_i − x_j| − l⁰_ij) + d_ij ((v_i − v_j)·l̂) ] (−l̂),
//   l̂ = (x_i − x_j)/|x_i − x_j|.
//
// Networks: the paper's flat quad grid (structural, shear and bending springs)
// or a baked organ's surface (edges as structural springs, the far vertices of
// adjacent triangles as bending springs); both with virtual body springs that
// tie each surface node to a fixed interior anchor (make_grid_network and
// make_organ_network say where the anchors are).
//
// Shaped for real time like the multi-beam model: build the network and the
// simulation once (allocates everything); step(), the force queries and the
// state accessors allocate nothing, take no lock, throw nothing and do no I/O.
// Units: metres, kilograms, seconds, newtons.
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

#include "organsim/model/organ_model.h"

namespace organsim::springs {

enum class SpringKind : std::uint8_t { structural, shear, bending, body, volume };

/// Springs as parallel arrays (one entry per spring).
struct Springs {
  std::vector<std::uint32_t> a, b;     ///< node indices, a < b
  std::vector<double> rest_length;     ///< l⁰, m
  std::vector<double> stiffness;       ///< k, N/m
  std::vector<double> damping;         ///< d, N·s/m (along the spring)
  std::vector<SpringKind> kind;
  std::size_t size() const noexcept { return a.size(); }
};

/// A network: nodes [0, surface_nodes) are the simulated surface (in the
/// order of the mesh they were built from); after them come the body springs'
/// anchors, which never move, and an organ's tetrahedral nodes when it has
/// volume springs.
struct SpringNetwork {
  std::vector<Eigen::Vector3d, Eigen::aligned_allocator<Eigen::Vector3d>> rest;  ///< (N) rest positions, m
  std::vector<double> mass;            ///< (N) kg (anchors: any positive value; they do not move)
  std::vector<std::uint8_t> fixed;     ///< (N) 1: the node never moves (anchors, clamped nodes)
  std::size_t surface_nodes = 0;
  std::vector<model::Triangle> triangles;  ///< surface triangles (for output and collision), may be empty
  Springs springs;
};

/// The paper's experiment grid.
struct GridOptions {
  std::uint32_t columns = 15, rows = 15;  ///< N along x, M along y (≥ 3 each)
  double spacing = 0.010;                 ///< m; vertex (i, j) at (i·spacing, j·spacing, 0), index i + N·j
  double mass = 0.01;                     ///< kg per vertex
  double structural_stiffness = 2.0, shear_stiffness = 2.0, bending_stiffness = 1.2;  ///< N/m
  double structural_damping = 0.4, shear_damping = 0.4, bending_damping = 0.24;       ///< N·s/m
  /// Body springs: one per vertex, from the vertex to an anchor one `spacing`
  /// below it (−z), rest length `spacing`, stiffness body_factor × the
  /// structural stiffness and damping body_factor × the structural damping;
  /// 0 leaves them out.
  double body_factor = 2.0;
  bool fix_border = true;  ///< fix every vertex with i ∈ {0, N−1} or j ∈ {0, M−1}
};

/// Structural (i,j)–(i+1,j), (i,j)–(i,j+1); shear (i,j)–(i+1,j+1), (i+1,j)–(i,j+1);
/// bending (i,j)–(i+2,j), (i,j)–(i,j+2); rest lengths from the flat grid.
/// Springs in that order (structural, shear, bending, body). Nodes: the N·M
/// vertices, then (body_factor > 0) the anchors, anchor of vertex v at N·M + v,
/// fixed, with `mass`. Triangles: each cell (i,j) as (i,j)(i+1,j)(i+1,j+1) and
/// (i,j)(i+1,j+1)(i,j+1), counter-clockwise seen from +z (the anchors lie at −z).
/// Throws std::invalid_argument naming the bad option.
SpringNetwork make_grid_network(const GridOptions& options);

/// A baked organ's surface as a network.
struct OrganNetworkOptions {
  double stiffness = 0.0;        ///< structural spring constant, N/m; 0: from E as k = E·ℓ̄ (ℓ̄ the mean edge length)
  double bending_factor = 0.6;   ///< bending springs: this × the structural constant (the paper's 1.2 / 2)
  /// Structural spring damping d, N·s/m; 0: `critical_fraction` × the critical
  /// damping 2·√(k·m̄) of one structural spring on the mean surface node mass m̄.
  /// Bending and body springs get d scaled like their constants (the paper's
  /// c : k = 0.4 : 2 for every kind). Proportional to k instead (the paper's
  /// 0.2 s) an organ's light nodes would be damped at rates of 10⁴–10⁵ 1/s, far
  /// beyond any explicit integrator's reach.
  double damping = 0.0;
  double critical_fraction = 0.1;
  double body_factor = 2.0;      ///< body springs: this × the structural constant and damping; 0 leaves them (and the anchors) out
  double anchor_depth = 0.0;     ///< m; 0: the mean edge length
  /// Volumetric springs (the model's tetrahedra): the tetrahedral nodes are
  /// simulated too, every tetrahedron edge is a spring (volume_factor × k and
  /// d), and since the baked tetrahedra do not share the surface's vertices,
  /// each surface vertex is tied by four springs (k, d) to the corners of the
  /// tetrahedron it is embedded in (geometry/tetrahedral_embedding.h).
  bool volume_springs = false;
  double volume_factor = 1.0;
  /// kg per node; 0: the organ's mass ρ·V (ρ the model's density; V the
  /// tetrahedra's volume, or the volume the surface encloses when the model has
  /// no tetrahedra) shared among the surface nodes: equally, or with
  /// `area_weighted_mass` in proportion to their vertex areas (a third of the
  /// area of every triangle at the vertex). Equal shares are the default: on a
  /// decimated liver surface the vertex areas span a factor of about 400, and the
  /// lightest node sets the explicit integrators' largest stable step.
  double uniform_mass = 0.0;
  bool area_weighted_mass = false;
  double clamp_radius = 0.0;     ///< m; surface nodes within this of the first fixed point are fixed (0: none)
};

/// Nodes: the model's surface vertices in order, then (body_factor > 0) one
/// anchor per surface vertex, anchor i at surface_nodes + i, fixed, with its
/// vertex's mass, then (volume_springs) the tetrahedral nodes in order, which
/// move; with masses from ρV, every surface and tetrahedral node gets an equal
/// share. Springs, in this order: every surface edge once as a
/// structural spring (k, d); for each edge shared by exactly
/// two triangles, a bending spring between the two vertices opposite it
/// (bending_factor·k, bending_factor·d; edges on a border or on
/// more than two triangles get none); per surface vertex a body spring to its
/// anchor, `anchor_depth` inside along the inward area-weighted vertex normal
/// (−Σ of the adjacent triangles' (b − a) × (c − a), normalized), rest length
/// anchor_depth, body_factor × the structural constant and damping. Anchors of
/// thin parts may lie outside the organ: choose anchor_depth below half the
/// thickness; then (volume_springs) every tetrahedron edge once, in the
/// order of its sorted node pair, and per surface vertex the four ties to its
/// host tetrahedron's corners (kind volume). The clamp fixes tetrahedral nodes
/// within clamp_radius too. Rest lengths are the rest distances. Every spring
/// has a < b.
/// Throws std::invalid_argument on a model without surface triangles, a
/// surface vertex on no triangle, bad indices, bad options, a zero structural
/// constant (stiffness 0 and E = 0), a non-positive density or volume when the
/// masses come from them, clamp_radius > 0 without fixed points, or
/// volume_springs on a model without tetrahedra or with area_weighted_mass.
SpringNetwork make_organ_network(const model::OrganModel& model, const OrganNetworkOptions& options);

enum class Integrator : std::uint8_t { explicit_euler, midpoint, rk4, symplectic_euler, implicit_euler };
enum class Region : std::uint8_t { all, dynamic };

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
  double dt = 0.01;                                        ///< s
  Eigen::Vector3d gravity = Eigen::Vector3d(0, 0, -9.8);   ///< m/s²
  double point_damping = 0.0;                              ///< c of −c ẋ_i, N·s/m
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
  Region region = Region::all;
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

/// The stiffest motion of a network linearized at rest, over its free nodes:
/// ω² the largest eigenvalue of M⁻¹K (K the springs' axial stiffness) and γ
/// that of M⁻¹D (their damping) plus the point damping over the lightest free
/// mass. Power iterations: ω and γ are approached from below (within about
/// 10⁻⁴ relative; take a margin).
struct StiffestMode {
  double omega = 0.0;         ///< rad/s
  double damping_rate = 0.0;  ///< 1/s
};
StiffestMode stiffest_mode(const SpringNetwork& network, double point_damping);

/// The largest dt (s) at which `integrator` is stable on the mode
/// ẍ = −ω²x − γẋ: |R(dt·μ)| ≤ 1 at its eigenvalues μ for the explicit ones,
/// dt²ω² + 2·dt·γ < 4 and dt·γ < 2 for symplectic Euler; infinite for implicit
/// Euler, 0 when no step is stable (explicit Euler without damping). Taking ω
/// and γ of different modes together (stiffest_mode) errs on the safe side.
double largest_stable_step(Integrator integrator, const StiffestMode& mode);

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
  /// a node at the current state (N): for a held node, what the tool holding it
  /// feels. Zero for an index out of range.
  Eigen::Vector3d reaction_force(std::uint32_t node) const noexcept;
  /// The 3×3 stiffness of the springs at `node` with its neighbours held: the
  /// local linearization of reaction_force() (N/m), Σ k (l̂ l̂ᵀ + (1 − l⁰/l)(I − l̂ l̂ᵀ)),
  /// so that reaction_force(x + δ) ≈ reaction_force(x) − K δ. Not clamped: a
  /// compressed spring contributes a negative transverse part.
  Eigen::Matrix3d contact_stiffness(std::uint32_t node) const noexcept;

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
  void end_region() noexcept;
  void activate(std::uint32_t node) noexcept;
  /// Accelerations of the integrated nodes at the state (x, v); other entries untouched.
  void accelerations(const Points& x, const Points& v, Points& a) noexcept;
  void step_implicit_euler() noexcept;
  void sync_stage() noexcept;
  void apply_implicit_matrix(const Points& p, Points& q) noexcept;
  bool freely_movable(std::uint32_t node) const noexcept { return !network_.fixed[node] && !held_[node]; }

  SpringNetwork network_;
  SimulationOptions options_;
  // State: one 3-vector per node, all nodes (fixed and held ones included).
  Points x_, v_;
  Points saved_x_, saved_v_;  // the state before the current step (last good state), movable nodes
  std::vector<std::uint32_t> movable_nodes_;  // the nodes that are not fixed
  // Per node inputs.
  Points external_, target_;
  std::vector<std::uint8_t> held_;
  std::vector<double> inverse_mass_;
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
