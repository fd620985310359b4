// The mass-spring model (He et al.; organsim/springs/mass_spring.h) in the engine.
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <vector>

#include <Eigen/Eigenvalues>

#include "organsim/geometry/model_measures.h"
#include "organsim/realtime/model_registry.h"
#include "organsim/springs/mass_spring.h"

namespace organsim::realtime {
namespace {

Eigen::Vector3d vec(const model::Point3& p) { return {p[0], p[1], p[2]}; }

/// The mass-spring model on the organ's surface (docs/springs.md): a tool holds
/// the surface node nearest its action point at the action point's displaced
/// position; the node's spring forces are the contact force, their Jacobian
/// the contact stiffness.
class SpringModel final : public DeformationModel {
 public:
  SpringModel(const organ::Organ& organ, const SpringModelOptions& options, std::size_t tools)
      : organ_(organ),
        options_(options),
        simulation_(make_simulation(organ.model(), options)),
        held_(tools, kNone),
        moved_mark_(organ.vertex_count(), 0),
        moved_(organ.vertex_count()) {}

  const char* name() const noexcept override { return "springs"; }

  bool attach(std::uint32_t tool, const Eigen::Vector3d& rest_point, ContactLinearization& contact) noexcept override {
    if (tool >= held_.size() || !rest_point.allFinite()) return false;
    const geometry::SurfacePoint at = organ_.surface_tree().closest_point(rest_point);
    const model::Triangle& triangle = organ_.model().surface_triangles[at.triangle];
    Eigen::Index corner = 0;
    at.barycentric.maxCoeff(&corner);
    const std::uint32_t node = triangle[static_cast<std::size_t>(corner)];
    if (simulation_.network().fixed[node]) return false;  // a clamped node cannot be moved
    for (std::uint32_t other : held_)
      if (other == node) return false;  // one tool per node
    held_[tool] = node;
    contact.action_point = vec(organ_.model().surface_vertices[node]);
    contact.normal = geometry::triangle_normal(organ_.model(), at.triangle);
    linearize(node, contact);
    return true;
  }

  void detach(std::uint32_t tool) noexcept override {
    if (tool >= held_.size() || held_[tool] == kNone) return;
    simulation_.release(held_[tool]);
    held_[tool] = kNone;
  }

  bool step(double dt, const Eigen::Vector3d* displacements, model::Point3* positions, model::Point3* normals,
            ContactLinearization* contacts) noexcept override {
    if (!(dt > 0.0) || !std::isfinite(dt)) return false;
    for (std::size_t tool = 0; tool < held_.size(); ++tool) {
      if (held_[tool] == kNone) continue;
      if (!displacements[tool].allFinite()) return false;
      simulation_.hold(held_[tool], simulation_.network().rest[held_[tool]] + displacements[tool]);
    }
    const double steps = std::clamp(std::round(dt / simulation_.options().dt), 1.0,
                                    static_cast<double>(options_.max_steps_per_frame));
    begin_moved();
    for (int s = 0; s < static_cast<int>(steps); ++s) {
      if (simulation_.step() == springs::StepStatus::blew_up) {
        // Back to rest and on: the state before the failed step was itself
        // about to diverge. The force safety's onset limit keeps the device
        // from a kick when the contact force comes back.
        ++instabilities_;
        simulation_.reset();
        moved_all_ = true;
        break;
      }
      note_moved(simulation_.integrated_nodes(), simulation_.active_count());
      active_nodes_ = simulation_.active_count();
    }
    const std::size_t n = organ_.vertex_count();
    for (std::size_t v = 0; v < n; ++v) {
      const Eigen::Vector3d& x = simulation_.position(static_cast<std::uint32_t>(v));
      positions[v] = {x[0], x[1], x[2]};
    }
    organ::compute_vertex_normals(organ_, positions, normals, 0, n);
    for (std::size_t tool = 0; tool < held_.size(); ++tool)
      if (held_[tool] != kNone) linearize(held_[tool], contacts[tool]);
    return true;
  }

  std::uint64_t instabilities() const noexcept override { return instabilities_; }

  bool volume_node_positions(model::Point3* positions, std::size_t capacity) const noexcept override {
    // The network's nodes: the surface vertices, then (volume springs) the tetrahedral nodes.
    const std::size_t surface = organ_.vertex_count(), nodes = organ_.model().volume_vertices.size();
    if (simulation_.network().rest.size() != surface + nodes || nodes == 0 || capacity < nodes) return false;
    for (std::size_t i = 0; i < nodes; ++i) {
      const Eigen::Vector3d& x = simulation_.position(static_cast<std::uint32_t>(surface + i));
      positions[i] = {x[0], x[1], x[2]};
    }
    return true;
  }

  const std::uint32_t* moved_vertices(std::size_t& count) const noexcept override {
    count = moved_all_ ? 0 : moved_count_;
    return moved_all_ ? nullptr : moved_.data();
  }

  std::size_t active_nodes() const noexcept override { return active_nodes_; }

 private:
  static constexpr std::uint32_t kNone = std::numeric_limits<std::uint32_t>::max();
  static constexpr double kStableFraction = 0.8;

  /// The simulation at options.simulation.dt, or at a smaller step where the
  /// network's stiffest mode needs one (kStableFraction of the integrator's limit).
  static springs::MassSpring make_simulation(const model::OrganModel& model, const SpringModelOptions& options) {
    springs::SpringNetwork network = springs::make_organ_network(model, options.network);
    springs::SimulationOptions simulation = options.simulation;
    const double limit = springs::largest_stable_step(simulation.integrator,
                                                      springs::stiffest_mode(network, simulation.point_damping));
    simulation.dt = std::min(simulation.dt, kStableFraction * limit);
    if (!(simulation.dt > 0.0))
      throw std::invalid_argument("the springs' integrator is unstable at any step on this network: use symplectic "
                                  "or implicit Euler, or add damping");
    return springs::MassSpring(std::move(network), simulation);
  }

  /// A frame's moved surface vertices: those integrated in any of its steps,
  /// and the held ones (they jump to the tool). Every free node moves in a
  /// step unless the region is dynamic.
  void begin_moved() noexcept {
    for (std::size_t k = 0; k < moved_count_; ++k) moved_mark_[moved_[k]] = 0;
    moved_count_ = 0;
    moved_all_ = options_.simulation.region != springs::Region::dynamic;
    for (std::uint32_t node : held_)
      if (node != kNone) note_moved(&node, 1);
  }
  void note_moved(const std::uint32_t* nodes, std::size_t count) noexcept {
    if (moved_all_) return;
    for (std::size_t k = 0; k < count; ++k)
      if (nodes[k] < moved_mark_.size() && !moved_mark_[nodes[k]]) {
        moved_mark_[nodes[k]] = 1;
        moved_[moved_count_++] = nodes[k];
      }
  }

  void linearize(std::uint32_t node, ContactLinearization& contact) const noexcept {
    contact.displacement = simulation_.position(node) - simulation_.network().rest[node];
    contact.force = simulation_.reaction_force(node);
    // Compressed springs make the Jacobian indefinite (their geometric term
    // 1 − l⁰/l is negative); rendered as is, such a direction would push the
    // hand further in. The device gets the positive part.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(
        0.5 * (simulation_.contact_stiffness(node) + simulation_.contact_stiffness(node).transpose()));
    contact.stiffness = eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() *
                        eigen.eigenvectors().transpose();
  }

  const organ::Organ& organ_;
  SpringModelOptions options_;
  springs::MassSpring simulation_;
  std::vector<std::uint32_t> held_;  // per tool: the node it holds, or kNone
  std::uint64_t instabilities_ = 0;
  std::vector<std::uint8_t> moved_mark_;  // per surface vertex
  std::vector<std::uint32_t> moved_;
  std::size_t moved_count_ = 0, active_nodes_ = 0;
  bool moved_all_ = true;
};

}  // namespace

extern const RegisteredModel springs_model{
    "springs", "mass-spring (He et al.): the surface (and optionally the tetrahedra) as a damped spring network",
    /*needs_beam_tables=*/false, /*needs_tetrahedra=*/false, std::nullopt,
    [](const organ::Organ& organ, const ModelOptions& options, std::size_t tools) -> std::unique_ptr<DeformationModel> {
      return std::make_unique<SpringModel>(organ, options.springs, tools);
    }};

}  // namespace organsim::realtime
