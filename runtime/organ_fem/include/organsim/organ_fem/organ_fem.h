// The FEM models on a baked organ, frame by frame (docs/fem.md#real-time): what
// the real-time engine runs for --model linear|corotational|stvk|psh.
//
// - Mesh: the model file's tetrahedra (P1); material E, ν from the model file
//   (psh: Mooney–Rivlin from E with its own ν and β, see OrganFemOptions).
// - Clamp: every tetrahedral node within `fixed_radius` of the model's first
//   fixed point is held in all three components; with `supports`, the
//   boundary also rests on the model's supports (an elastic foundation).
// - Tools (docs/realtime.md#contact-rule): what a tool's tip touches sticks to it.
//   A tool holds material points of the tetrahedral mesh's boundary (each a
//   barycentric combination of one boundary face's nodes), each made to follow
//   the tool's displacement from where it was taken: the point nearest the
//   action point from the first touch, and, for a tip of finite size
//   (geometry/tool_tip.h), every boundary point that enters the tip's capsule
//   (the point of each face nearest the capsule's axis: a node, a point of an
//   edge or of a face's interior), taken where it meets the capsule's surface.
//   The first touch is held both ways until the contact ends (the engine's
//   rule); a point taken in later is let go of when the tip would pull it
//   (unilateral contact). One 3-vector constraint per
//   held point, enforced exactly through its Lagrange multiplier — the force
//   the tool applies there; the tool's force is their sum.
// - Grasp (docs/realtime.md#grasping): jaws that close hold the tip's
//   footprint, the boundary within the tip's radius of the first touch, as one
//   patch: its area-weighted mean displacement follows the tool (a
//   distributing coupling: one 3-vector constraint whose force spreads over
//   the patch as a uniform traction), in place of the points the tip held.
//   Held points alone would make a pull's force depend on the mesh (a point
//   held in an elastic body carries a force that vanishes as the mesh is
//   refined); a patch of the tip's size converges. Opening holds the first
//   touch again, where it is.
// - Frame: one warm-started Newton iteration with a kept tangent (modified
//   Newton): the internal forces of the current state are evaluated with the
//   material's full nonlinearity, the correction is solved with the LDLᵀ
//   factorization of a tangent from a recent state, and the tools' constraints
//   are met exactly through the capacitance matrix W = Hᵀ A⁻¹ H (H: the
//   constraints' columns; each held node's response solved once per tangent,
//   with a supernodal factor as a sparse forward solve: contact_responses.h). For
//   corotational and stvk a worker thread refactors the tangent at the state
//   of frame k while the frames go on, and frame k + refresh_frames adopts it
//   (waiting for the worker if it is late, so that a replay is deterministic;
//   in real-time loops the first frame after that finds it done,
//   set_reproducible):
//   the asynchronous tangent of Courtecuisse et al. (2014). The iteration's
//   step is scaled by `relaxation` (½) for the nonlinear materials; a frame whose
//   iteration inverts a tetrahedron with a refreshed tangent retries with the
//   rest tangent, kept until the next refresh. With a worker, a step that would
//   throw the organ out of balance (a tangent made far from the state, as after
//   the tools let go) is not taken: the frame keeps its shape, the next ones
//   use the rest tangent, and the refresh is adopted as soon as it is done.
//   psh keeps its rest tangent. Linear material: the tangent never changes and every frame is the
//   exact static solution. A true Newton
//   iteration per frame would refactor the tangent every frame (the liver, one
//   thread: 0.29 s simplicial / 0.06 s direct for the displacement-only
//   materials, 1.5 s / 0.18 s for psh; docs/fem.md).
// - Contact force and stiffness: the sum of the tool's multipliers, and the
//   condensed stiffness Σ_ab (W⁻¹)_ab over its held points a, b (all move
//   with the tool) with the other tools held, both refreshed every frame.
// - Surface: every surface vertex is embedded in the tetrahedron that owns the
//   boundary face nearest to it (barycentric weights; the baked boundary lies
//   within the mesher's facet distance of the surface), and moves with it.
//
// Construction allocates everything (and factorizes); attach, detach, step and
// the queries allocate nothing, take no lock, throw nothing and do no I/O on
// the calling thread (the worker allocates while it factorizes).
// Units: metres, newtons, pascals.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <vector>

#include <Eigen/Core>

#include "organsim/fem/elasticity_system.h"
#include "organsim/fem/material.h"
#include "organsim/geometry/closest_point.h"
#include "organsim/geometry/tetrahedral_embedding.h"
#include "organsim/geometry/tool_tip.h"
#include "organsim/model/organ_model.h"

namespace organsim::fem {

struct OrganFemOptions {
  /// Tetrahedral nodes within this distance of the model's first fixed point
  /// are clamped, m. The multi-beam model clamps every beam at the fixed point
  /// itself (a point clamp that still resists rotation); a clamped ball of
  /// nodes is the FEM's nearest equivalent.
  double fixed_radius = 0.010;
  /// Also hold the organ where the model file's supports say it rests or is
  /// attached (docs/supports.md): each boundary node on a Winkler foundation
  /// of its nearest surface vertex's modulus, bilateral at attachments,
  /// unilateral (pushing back only when pressed) at contacts. Off: the clamp
  /// alone. A model without supports is held by its clamp either way.
  bool supports = false;
  /// mooney-rivlin: ν of κ = E / (3 (1 − 2ν)) (the paper's nearly
  /// incompressible liver: 0.49) and β of the pressure-jump stabilization (the
  /// paper's 100).
  double psh_poisson_ratio = 0.49;
  double stabilization = 100.0;
  /// corotational and stvk: frames between a tangent's request and its use
  /// (0: keep the rest tangent). The worker must refactor within this many
  /// frames or the frame that adopts it waits: on the shipped liver a
  /// factorization takes 0.34 s (20 frames at 60 Hz). psh always keeps its rest
  /// tangent: the quasi-definite rest matrix converges, while tangents
  /// refreshed at pressed states (carrying the pressures' geometric stiffness)
  /// made the lagging iteration diverge once the tools let go (docs/fem.md),
  /// and one takes 1.9 s on the liver.
  std::uint32_t refresh_frames = 30;
  /// Nonlinear materials: the fraction ω of each iteration taken (damped
  /// modified Newton; linear: always 1). A kept tangent A makes the iteration
  /// contract when the eigenvalues of ω A⁻¹K(x) lie in (0, 2): ω = ½ admits a
  /// current tangent K up to four times stiffer than the kept one. With ω = 1
  /// the liver diverged after a quick press or a release (docs/fem.md); with ½
  /// the contact point closes half of its remaining gap per frame. 1 for Newton.
  double relaxation = 0.5;
  /// The tangents' factorization (null: Eigen's simplicial LDLᵀ). The frames
  /// solve only with factorizations whose solve is real-time safe; where the
  /// factory has none for the matrix kind, the simplicial one serves.
  FactorizationFactory factorization = nullptr;
  /// false: the frames may solve with factorizations whose solves allocate
  /// (MUMPS for psh), for Newton solves outside real-time loops; a frame then
  /// also takes in every node that entered a tip, not at most
  /// kJoinsPerFrame.
  bool realtime_solves = true;
  /// Boundary nodes whose responses the tangents keep for the contacts
  /// (three solved columns each per tangent; a finite tip needs those of the
  /// faces it touches); 0: 24 per tool, at most 256. Beyond them a contact
  /// point is left out (hold_overflows() counts them).
  std::size_t max_contact_nodes = 0;
};

/// The model's tetrahedra as a FEM mesh (m).
TetMesh tet_mesh_of(const model::OrganModel& model);

/// The FEM models' clamp: per displacement component (3 per tetrahedral
/// node), true for the nodes within `fixed_radius` (m) of the model's first
/// fixed point. Throws std::invalid_argument with one line when the model
/// has no fixed point or fewer than three such nodes off one line.
std::vector<bool> clamped_dofs(const model::OrganModel& model, double fixed_radius);

/// The model's supports (docs/supports.md) as springs on the tetrahedral
/// boundary's nodes (`boundary` of model.tetrahedra) that `constrained` leaves
/// free: each node takes the kind and foundation modulus of the surface
/// vertex nearest it (the baked boundary lies within the mesher's facet
/// distance of the surface), its stiffness that modulus times a third of its
/// boundary faces' area (the lumping that carries a uniform pressure
/// exactly), its normal their area-weighted outward normal; a contact is
/// unilateral, an attachment not. Empty for a model without supports.
std::vector<FoundationSpring> foundation_springs(const model::OrganModel& model, const std::vector<bool>& constrained,
                                                 const geometry::TetrahedralBoundary& boundary);

enum class FrameStatus : std::uint8_t {
  ok,
  not_finite,  ///< a tool displacement is not finite: nothing changed
  kept_shape,  ///< no step was taken: even 1/16 of the relaxed iteration would invert a tetrahedron, or the step
               ///< would throw the organ out of balance (a tangent made far from this state); the state is the previous
               ///< one
};

class OrganFem {
 public:
  /// Throws std::invalid_argument with one line when the model has no
  /// tetrahedra, too few nodes within the clamp radius, or options out of range.
  OrganFem(const model::OrganModel& model, MaterialModel material, const OrganFemOptions& options, std::size_t tools);
  ~OrganFem();
  OrganFem(const OrganFem&) = delete;
  OrganFem& operator=(const OrganFem&) = delete;

  /// Contact begins at the boundary point nearest `rest_point` (m), where the
  /// tool's tip touched the organ; `tip` is its end (a point by default).
  /// The tool's displacement in step() is its tip's, from `rest_point`. False
  /// (nothing changed) for a tool index out of range, a non-finite point, a
  /// boundary face with a clamped node, a node another tool holds (the two
  /// constraints would fight over it), a tip whose radius is not finite or
  /// whose axis is not a unit vector, or no room for another held point.
  bool attach(std::uint32_t tool, const Eigen::Vector3d& rest_point, const geometry::ToolTip& tip = {}) noexcept;
  void detach(std::uint32_t tool) noexcept;
  bool attached(std::uint32_t tool) const noexcept;
  /// An attached tool's jaws close on (true) or open from (false) the organ.
  /// The next step makes the change: closed, a finite tip holds its
  /// footprint's patch (the boundary within its radius of the first touch,
  /// where it lies then) both ways, a point tip its first touch; open, the
  /// first touch again (docs/realtime.md#grasping).
  void grasp(std::uint32_t tool, bool grasped) noexcept;

  /// One frame: `displacements[tool]` (m) is where each attached tool's
  /// contact point is to be, from its rest position (entries of detached tools
  /// are ignored). With no tool attached the organ is at rest (reset()): the
  /// equilibrium of an organ nothing loads.
  FrameStatus step(const Eigen::Vector3d* displacements) noexcept;
  /// Back to the rest state (contacts kept).
  void reset() noexcept;
  /// Refactors the tangent at the current state now, on this thread (true
  /// Newton when called before every step; allocates, and the fresh tangent
  /// may be one whose solves allocate too: not for real-time loops).
  /// False when the tangent there is singular or indefinite (the kept one stays).
  bool refresh_tangent();
  /// Tangents adopted since construction (the rest tangent not counted).
  std::uint64_t tangent_refreshes() const noexcept { return refreshes_; }
  /// true (the default): the frame that is to adopt a refreshed tangent waits
  /// for the worker when it is late, so that a replay is reproducible; false
  /// (real-time loops): it goes on with the kept tangent and a later frame
  /// adopts the fresh one once the worker is done (a loaded machine then
  /// refreshes less often instead of overrunning frames).
  void set_reproducible(bool reproducible) noexcept { reproducible_ = reproducible; }
  /// Frames that found the worker's tangent late and went on without it.
  std::uint64_t late_refreshes() const noexcept { return late_refreshes_; }
  /// Times the organ started again from rest because kKeptFramesBeforeRestart
  /// frames in a row kept its shape (see step()).
  std::uint64_t restarts() const noexcept { return restarts_; }
  /// Frames in a row that keep the organ's shape before it starts again from
  /// rest: one second at 60 Hz.
  static constexpr std::uint32_t kKeptFramesBeforeRestart = 60;
  /// Frames whose iteration was cut short because the whole of it would have
  /// inverted a tetrahedron or, in psh's frames, more than doubled the
  /// organ's imbalance (the organ then lags the tools).
  std::uint64_t step_cuts() const noexcept { return step_cuts_; }
  /// Boundary nodes on the supports' foundation (0 without supports).
  std::size_t supported_node_count() const noexcept { return supported_nodes_; }
  /// Boundary points the tool holds (1 for a point tool, the first touch and
  /// those a finite tip took in).
  std::size_t held_points(std::uint32_t tool) const noexcept;
  /// One held point or patch as a prescribed displacement: its nodes, its
  /// weights on them (a point's barycentric weights on a boundary face's
  /// nodes; a patch's area weights, summing to 1) and the displacement the
  /// tool holds Σ wᵢ uᵢ at (m).
  struct HeldPoint {
    std::vector<std::int32_t> nodes;
    std::vector<double> weights;
    Eigen::Vector3d displacement = Eigen::Vector3d::Zero();
  };
  /// The points `tool` holds now, as prescribed displacements: what an
  /// independent solver is given to reproduce a grasp (tests; allocates).
  std::vector<HeldPoint> held_point_displacements(std::uint32_t tool) const;
  /// True when the last step neither took nor let go of a point: the
  /// contact's active set is settled (a static solve converges only then).
  bool contact_settled() const noexcept { return contact_settled_; }
  /// Contact points left out for want of room (max_contact_nodes, kMaxHolds).
  std::uint64_t hold_overflows() const noexcept { return hold_overflows_; }
  /// Most new nodes a real-time frame solves responses for (each a sparse
  /// forward solve, or a solve of three columns without a supernodal factor);
  /// a contact point on a node without one waits for the next frame.
  static constexpr std::size_t kJoinsPerFrame = 4;
  /// Most points the tools hold together (W has three rows per point).
  static constexpr std::size_t kMaxHolds = 40;
  /// Most nodes a grasped patch spreads over (beyond them the jaws hold the
  /// points the tip holds, and hold_overflows() counts it).
  static constexpr std::size_t kMaxPatchNodes = 256;

  /// The contact's first-touch point on the tetrahedral boundary (m).
  Eigen::Vector3d contact_point(std::uint32_t tool) const noexcept;
  /// Where the force the tool feels holds (m): a point tool's point's
  /// displacement; a finite tip's displacement in the last step.
  Eigen::Vector3d contact_displacement(std::uint32_t tool) const noexcept;
  /// The force the organ exerts on the tool (N) after the last step (zero right after attach).
  Eigen::Vector3d contact_force(std::uint32_t tool) const noexcept;
  /// The contact's condensed stiffness (N/m): dF/dd with the other tools held.
  Eigen::Matrix3d contact_stiffness(std::uint32_t tool) const noexcept;

  /// The surface vertices' positions (m) in the model's vertex order.
  void surface_positions(model::Point3* positions) const noexcept;
  /// The tetrahedral nodes' positions (m) in the model's node order.
  void node_positions(model::Point3* positions) const noexcept;
  /// Node displacements (m, 3 per tetrahedral node) and, for psh, pressures (Pa, per tetrahedron).
  Eigen::Ref<const Eigen::VectorXd> displacements() const noexcept;
  Eigen::Ref<const Eigen::VectorXd> pressures() const noexcept;
  /// The largest nodal force out of balance after the last step (N): the
  /// internal force minus what the tools apply, on the free nodes. Zero at
  /// equilibrium; for the linear material, round-off.
  double unbalanced_force() const noexcept { return unbalanced_; }

  const ElasticitySystem& system() const noexcept { return *system_; }
  std::size_t clamped_node_count() const noexcept { return clamped_nodes_; }
  /// The kept tangent's factorization, for reports.
  const char* linear_solver() const noexcept;
  /// Seconds the factorization of the rest tangent took (at construction).
  double factorization_seconds() const noexcept { return factorization_seconds_; }
  /// What a real-time frame's iteration is expected to take on this machine
  /// (s): one gradient assembly and one solve with the frames' tangent, timed
  /// at construction (the fastest of three). A frame that takes in contact
  /// points adds a response per new node (kJoinsPerFrame at most; with a
  /// supernodal factor a sparse forward solve, 0.5 ms for PSH on the liver).
  /// 0 without real-time solves (OrganFemOptions::realtime_solves false).
  double estimated_frame_seconds() const noexcept { return estimated_frame_seconds_; }

 private:
  /// A boundary node whose response A⁻¹ e (three columns, one per direction)
  /// the tangents keep: what every contact constraint on it is solved from.
  /// Or, for a first touch, the response A⁻¹ Σ wᵢ eᵢ of its hold's point as a
  /// whole (`point`): one solve where its three nodes' would take three.
  struct NodeSlot {
    std::int32_t node = -1;   ///< the node; for a point or patch, its first weighted node (-1: free)
    bool point = false;       ///< the load is the point's or the patch's, not the node's
    std::int32_t patch = -1;  ///< the tool whose grasped patch (patches_) the load is, or -1
    std::array<std::int32_t, 3> point_nodes{};
    Eigen::Vector3d point_weights = Eigen::Vector3d::Zero();
    std::uint64_t generation = 0;  ///< keys its responses in a tangent
    std::uint64_t used_frame = 0;  ///< the last frame a constraint used it
    bool held = false;             ///< a hold weighs it (set when a refresh is requested)
  };
  /// A material point of the boundary a tool holds: barycentric on a
  /// boundary face's nodes (a weight 0 leaves a node out: a point of an edge,
  /// or a node).
  struct Hold {
    std::uint32_t tool = 0;
    bool bilateral = false;   ///< the first touch or a grasped patch: held both ways
    std::int32_t patch = -1;  ///< the tool whose grasped patch this is (its nodes in patches_; `nodes` unused), or -1
    std::array<std::int32_t, 3> nodes{};
    std::array<std::int32_t, 3> slots{};  ///< their NodeSlots (-1 for a weight 0, and with `point_slot`)
    std::int32_t point_slot = -1;         ///< the NodeSlot of the point's own response (first touch), or -1
    Eigen::Vector3d weights = Eigen::Vector3d::Zero();
    Eigen::Vector3d offset = Eigen::Vector3d::Zero();   ///< m: its target displacement less the tool's
    Eigen::Vector3d outward = Eigen::Vector3d::Zero();  ///< unit: the direction the tip pushes it
    Eigen::Vector3d force = Eigen::Vector3d::Zero();    ///< N the tool applies to the organ there
    double depth = 0.0;                                 ///< m inside the tip (a candidate's)
  };
  struct Contact {
    bool active = false;
    geometry::ToolTip tip;
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();      ///< m: the tip at first touch (attach's rest point, seated)
    Eigen::Vector3d rest_point = Eigen::Vector3d::Zero();  ///< m: the first-touch point on the boundary
    Eigen::Vector3d target = Eigen::Vector3d::Zero();      ///< the tool displacement of the last step
    Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();
    bool grasped = false;                       ///< the jaws are closed
    bool patch_held = false;                    ///< a hold of its footprint's patch replaces its points
    bool patch_refused = false;                 ///< closed, but the patch found no room: the points are held both ways
    std::array<std::int32_t, 3> first_nodes{};  ///< the first touch's face
    Eigen::Vector3d first_weights = Eigen::Vector3d::Zero();  ///< and its place on it
  };
  /// A grasped patch: nodes and their area weights (summing to 1).
  struct Patch {
    std::array<std::int32_t, kMaxPatchNodes> nodes{};
    std::array<double, kMaxPatchNodes> weights{};
    std::size_t count = 0;
  };
  struct Tangent;
  struct Capacitance;
  class Worker;

  /// Σ_i w_i u_{node i}: the displacement of a boundary point now (m).
  Eigen::Vector3d displacement_at(const std::array<std::int32_t, 3>& nodes,
                                  const Eigen::Vector3d& weights) const noexcept;
  /// Σ_i w_i x_{node i}: where that boundary point is at rest (m).
  Eigen::Vector3d rest_at(const std::array<std::int32_t, 3>& nodes, const Eigen::Vector3d& weights) const noexcept;
  /// An empty tangent with the options' factorization, analyzed.
  std::unique_ptr<Tangent> make_tangent(bool realtime_solve) const;
  /// A⁻¹ e of `node` (held in `slot`) with `tangent` (contact_responses.h);
  /// a patch's nodes are read from `patches`.
  void respond(Tangent& tangent, std::size_t slot, const NodeSlot& node,
               const std::vector<Patch>& patches) const noexcept;
  /// Solves the responses `tangent` lacks for the used node slots.
  void respond_all(Tangent& tangent) const noexcept;
  /// The slot of `node`'s responses, solving them when it has none and the
  /// frame may still afford a solve (`solves` counts them); -1 otherwise.
  std::int32_t node_slot(std::int32_t node, std::size_t& solves) noexcept;
  /// Adds a hold (its node responses solved, `solves` counting them; with
  /// `as_point`, the point's one response instead); false when there is no
  /// room or no response this frame.
  bool add_hold(Hold hold, std::size_t& solves, bool as_point = false) noexcept;
  /// A free slot, or the one least recently used by no hold; node_slots_.size() when none.
  std::size_t free_slot() const noexcept;
  /// Calls `term(response slot, weight)` for each response a hold is made of.
  template <typename Term>
  static void for_each_response(const Hold& hold, Term term) noexcept {
    if (hold.point_slot >= 0) {
      term(static_cast<std::size_t>(hold.point_slot), 1.0);
      return;
    }
    for (std::size_t j = 0; j < 3; ++j)
      if (hold.slots[j] >= 0) term(static_cast<std::size_t>(hold.slots[j]), hold.weights[static_cast<Eigen::Index>(j)]);
  }
  void release(std::size_t index) noexcept;
  /// Calls `visit(node, weight)` for each node a hold weighs.
  template <typename Visit>
  void for_each_node(const Hold& hold, Visit visit) const noexcept {
    if (hold.patch >= 0) {
      const Patch& patch = patches_[static_cast<std::size_t>(hold.patch)];
      for (std::size_t i = 0; i < patch.count; ++i) visit(patch.nodes[i], patch.weights[i]);
      return;
    }
    for (std::size_t i = 0; i < 3; ++i)
      if (hold.weights[static_cast<Eigen::Index>(i)] != 0.0)
        visit(hold.nodes[i], hold.weights[static_cast<Eigen::Index>(i)]);
  }
  /// A boundary face's corners where they are now (m).
  std::array<Eigen::Vector3d, 3> face_now(const model::Triangle& face) const noexcept;
  /// A hold's point (or patch mean) displaced now, and at rest (m).
  Eigen::Vector3d hold_displacement(const Hold& hold) const noexcept;
  Eigen::Vector3d hold_rest(const Hold& hold) const noexcept;
  /// Fills patches_[tool] with the boundary within the tool's tip radius of
  /// its first touch (where both lie now): each face's area there, found by
  /// 8 × 8 sub-triangles, spread on its nodes by their barycentric weights,
  /// less clamped nodes and other tools' nodes. False when empty or too large.
  bool build_patch(std::uint32_t tool) noexcept;
  /// The jaws' changes since the last step (grasp()): closed, the patch's hold
  /// replaces the tool's points; opened, the first touch's replaces the
  /// patch's. Each held where it lies, with the force of what it replaces.
  /// True when the holds changed.
  bool update_jaws() noexcept;
  /// Finite tips: takes the boundary points inside them that weigh a node
  /// the tool does not hold yet, deepest first. True when it took one.
  bool take_points() noexcept;
  /// Whether a boundary point a tip would take in (its place on the tip:
  /// its offset) would come nearer a point the tool holds than half their
  /// distance in the organ now: the tip is rigid and its held points move
  /// with it, so the tissue between the two would be crushed. It happens where
  /// a held point lags behind its place on the tip (a kept tangent's step on a
  /// fine mesh) and a neighbour enters the tip where that place is: taken,
  /// the two fought (opposite forces of 0.3 N on a 15 mN press) and inverted
  /// the tetrahedron between them within a few frames.
  bool crowds_a_hold(const Hold& candidate) const noexcept;
  /// W of the holds, factorized.
  void assemble_capacitance() noexcept;
  /// Per tool, the condensed stiffness Σ_ab (W⁻¹)_ab over its holds.
  void update_stiffness() noexcept;
  /// The fastest of three timings of a frame's assembly and solve (s).
  double time_frame_work();
  /// Adopts `fresh` as the kept tangent: responses of nodes it lacks solved.
  void adopt(std::unique_ptr<Tangent>& fresh) noexcept;
  /// Back to the rest state and the rest tangent; a refresh on its way, made
  /// away from rest, is dropped (now where the frames wait for it, else when done).
  void return_to_rest() noexcept;
  /// Waits for the worker's refresh, adopts it when `adopt_it` and it succeeded, and frees the worker.
  void end_refresh(bool adopt_it) noexcept;
  void request_refresh() noexcept;
  /// One iteration from saved_ with the kept tangent: the fraction of it taken
  /// (ω, ω/2 … ω/16; psh's frames begin at step_fraction_), or 0 (state
  /// restored) when even ω/16 would invert a tetrahedron, or, with a worker,
  /// when the step would more than double the frame's out-of-balance force
  /// scale (`unbalanced`; such a step is not cut), or, in psh's frames, when
  /// every step would more than double the organ's imbalance.
  /// `released`: a finite tip let go of a point it would pull.
  double iterate(bool& released, bool& unbalanced) noexcept;
  /// Real-time frames that solve with the rest tangent throughout (psh; no
  /// worker and no Newton refresh): the iteration's length adapts to the state.
  bool keeps_rest_tangent() const noexcept { return realtime_solves_ && !worker_ && refreshes_ == 0; }
  /// Real-time frames with the rest tangent: a frame that took `fraction` and
  /// left the organ `after` out of balance (N) from `before` sets where the
  /// next one begins (step_fraction_).
  void adapt_step_fraction(double fraction, double before, double after) noexcept;
  /// The largest out-of-balance force component (N; pressure rows in
  /// newtons) at the current gradient, the holds' forces taken a `fraction`
  /// of the way from theirs to the multipliers; writes the rows into rhs_.
  double out_of_balance(double fraction) noexcept;
  Tangent& kept() noexcept { return using_rest_ ? *rest_tangent_ : *tangent_; }
  Eigen::Index pressure_count() const noexcept {
    return system_->dof_count() - static_cast<Eigen::Index>(displacement_dofs_);
  }

  std::unique_ptr<ElasticitySystem> system_;
  FactorizationFactory factorization_ = nullptr;
  bool realtime_solves_ = true;
  std::size_t clamped_nodes_ = 0;
  std::size_t supported_nodes_ = 0;
  double factorization_seconds_ = 0;
  double estimated_frame_seconds_ = 0;
  std::vector<std::int32_t> free_dofs_;  ///< per free index, its dof
  std::size_t displacement_dofs_ = 0;
  std::vector<model::Point3> node_points_;
  geometry::TetrahedralBoundary boundary_;
  std::unique_ptr<geometry::SurfaceBvh> boundary_tree_;  ///< refers into node_points_ and boundary_.faces
  std::vector<model::Point3> surface_rest_;
  geometry::SurfaceEmbedding embedding_;  ///< each surface vertex in a tetrahedron
  // State and scratch (sized at construction).
  Eigen::VectorXd state_, saved_, gradient_, saved_gradient_, rhs_, step_;
  std::vector<Contact> contacts_;             ///< per tool
  std::vector<NodeSlot> node_slots_;          ///< max_contact_nodes
  std::vector<std::int32_t> slot_of_node_;    ///< per node: its NodeSlot, or -1
  std::vector<std::int32_t> boundary_faces_;  ///< the boundary faces with a free node
  double longest_boundary_edge_ = 0.0;        ///< m, at rest
  std::vector<Hold> holds_;                   ///< capacity kMaxHolds
  std::size_t hold_count_ = 0;
  std::vector<Hold> candidates_;           ///< scratch for take_points
  std::vector<Patch> patches_;             ///< per tool: its grasped patch
  std::vector<double> patch_weight_;       ///< per node: scratch for build_patch (zero between calls)
  std::vector<std::int16_t> node_tool_;    ///< per node: the tool whose holds weigh it, or -1
  std::vector<std::uint16_t> node_holds_;  ///< per node: how many holds weigh it
  std::uint64_t generations_ = 0;
  bool contact_settled_ = true;
  std::uint64_t hold_overflows_ = 0;
  std::unique_ptr<Tangent> tangent_;  ///< the kept tangent
  /// corotational and stvk: the rest tangent, kept for when a refreshed one fails
  std::unique_ptr<Tangent> rest_tangent_;
  std::unique_ptr<Tangent> newton_spare_;  ///< refresh_tangent(): the tangent it replaced, analyzed, for its next call
  bool using_rest_ = false;
  std::unique_ptr<Capacitance> capacitance_;
  std::unique_ptr<Worker> worker_;  ///< null when the tangent is never refreshed
  std::uint32_t refresh_frames_ = 0;
  std::uint64_t frame_ = 0, refresh_due_ = 0;
  bool solved_this_frame_ = false;  // a contact's response was solved since the last step
  bool stale_refresh_ = false;      // the refresh on its way was asked for before the organ came to rest
  std::uint64_t refreshes_ = 0, step_cuts_ = 0, late_refreshes_ = 0, restarts_ = 0;
  std::uint32_t kept_in_a_row_ = 0;  ///< frames in a row that kept the organ's shape
  bool reproducible_ = true;
  double unbalanced_ = 0;
  double relaxation_ = 1;
  /// Real-time frames without a worker (psh): the fraction of the iteration
  /// a frame tries first, in [ω/16, ω]. The kept rest tangent can be many
  /// times softer than the organ held far out of its rest shape (a lobe
  /// lifted 20 mm by a small patch): there the damped iteration grows the
  /// imbalance by |1 − f λ| per frame for the stiffening's λ, and only a
  /// shorter step f contracts. It halves when a frame had to cut its step and
  /// doubles back after kSteadyFrames frames that shrank the imbalance.
  double step_fraction_ = 1;
  std::uint32_t steady_frames_ = 0;
  double pressure_scale_ = 1;  ///< κ / h̄: pressure rows (m³) to newtons in unbalanced_force()
};

}  // namespace organsim::fem
