// The mass-spring model (He et al.; organsim/springs/mass_spring.h) in the engine.
#include <algorithm>
#include <cmath>
#include <iterator>
#include <string>
#include <stdexcept>
#include <vector>

#include <Eigen/Eigenvalues>

#include "organsim/organ/site_law.h"
#include "organsim/realtime/model_registry.h"
#include "organsim/springs/mass_spring.h"

namespace organsim::realtime {
namespace {

/// The mass-spring model on the organ's surface (docs/springs.md): a tool
/// holds the surface node nearest its action point at the action point's
/// displaced position until the contact ends and, with a tip of finite size,
/// every free surface node that enters the tip's capsule, where it met the
/// capsule's surface, letting go of such a node when it pulls on it
/// (docs/realtime.md#contact-rule). The held nodes' spring
/// forces are the contact force, the Jacobian of the group moved as one the
/// contact stiffness.
class SpringModel final : public DeformationModel {
 public:
  SpringModel(const organ::Organ& organ, const SpringModelOptions& options, std::size_t tools)
      : organ_(organ),
        options_(held_as_the_fem_models(options)),
        simulation_(make_simulation(organ.model(), options_)),
        tools_(tools),
        holds_(kHoldsPerTool * tools),
        holder_(simulation_.node_count(), kFree),
        moved_mark_(organ.vertex_count(), 0),
        moved_(organ.vertex_count()) {}

  const char* name() const noexcept override { return "springs"; }

  bool attach(std::uint32_t tool, const Eigen::Vector3d& rest_point, const geometry::ToolTip& tip,
              ContactLinearization& contact) noexcept override {
    if (tool >= tools_.size() || !rest_point.allFinite() || !std::isfinite(tip.radius) || tip.radius < 0.0)
      return false;
    if (!tip.is_point() && !(std::abs(tip.axis.norm() - 1.0) < 1e-6)) return false;
    const geometry::SurfacePoint at = organ_.surface_tree().closest_point(rest_point);
    const model::Triangle& triangle = organ_.model().surface_triangles[at.triangle];
    Eigen::Index corner = 0;
    at.barycentric.maxCoeff(&corner);
    const std::uint32_t node = triangle[static_cast<std::size_t>(corner)];
    if (simulation_.network().fixed[node]) return false;  // a clamped node cannot be moved
    if (holder_[node] != kFree && holder_[node] != static_cast<std::int16_t>(tool)) return false;  // one tool per node
    detach(tool);
    Tool& t = tools_[tool];
    t.attached = true;
    t.tip = tip;
    t.origin = simulation_.network().rest[node];
    t.displacement = simulation_.position(node) - t.origin;
    t.matched = options_.match_sites && t.law.set(organ_, at, tip.radius, options_.network.supports);
    t.grasped = false;
    t.grasp.open();
    hold(tool, node, Eigen::Vector3d::Zero(), -tip.axis, true);
    contact.action_point = t.origin;
    contact.normal = organ_.rest_normal_at(at);
    linearize(tool, contact);
    return true;
  }

  void detach(std::uint32_t tool) noexcept override {
    if (tool >= tools_.size() || !tools_[tool].attached) return;
    for (Hold& h : holds_)
      if (h.used && h.tool == tool) let_go(h);
    tools_[tool].attached = false;
    tools_[tool].grasped = false;
    tools_[tool].grasp.open();
  }

  /// Closing, a finite tip takes hold of its footprint, the free surface
  /// nodes within its radius of the first touch, each where it lies (the FEM
  /// models' patch, node by node); held, it keeps every node it holds, also
  /// those it pulls. A matched contact goes on past the rest surface with the
  /// site's bonded stiffness.
  void set_grasp(std::uint32_t tool, bool grasped) noexcept override {
    if (tool >= tools_.size() || !tools_[tool].attached) return;
    Tool& t = tools_[tool];
    const bool closing = grasped && !t.grasped;
    t.grasped = grasped;
    if (!grasped)
      t.grasp.open();
    else if (t.matched && !t.grasp.held)
      t.grasp.close(t.law, t.displacement);
    if (closing && !t.tip.is_point()) hold_footprint(tool);
  }

  bool step(double dt, const Eigen::Vector3d* displacements, model::Point3* positions, model::Point3* normals,
            ContactLinearization* contacts) noexcept override {
    if (!(dt > 0.0) || !std::isfinite(dt)) return false;
    for (std::uint32_t tool = 0; tool < tools_.size(); ++tool) {
      if (!tools_[tool].attached) continue;
      if (!displacements[tool].allFinite()) return false;
      tools_[tool].displacement = displacements[tool];
    }
    update_holds();
    for (const Hold& h : holds_)
      if (h.used) simulation_.hold(h.node, simulation_.network().rest[h.node] + tools_[h.tool].displacement + h.offset);
    const double steps =
        std::clamp(std::round(dt / simulation_.options().dt), 1.0, static_cast<double>(options_.max_steps_per_frame));
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
    for (std::uint32_t tool = 0; tool < tools_.size(); ++tool)
      if (tools_[tool].attached) linearize(tool, contacts[tool]);
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
  static constexpr double kStableFraction = 0.8;
  static constexpr std::int16_t kFree = -1;
  /// Nodes one tool may hold (a 2.5 mm tip buried 5 mm in a surface of 1 mm
  /// edges holds about 80); a node beyond them is not held.
  static constexpr std::size_t kHoldsPerTool = 128;
  /// N: a finite tip lets go of a node it pulls on by more than this.
  static constexpr double kPullTolerance = 1e-9;

  struct Tool {
    bool attached = false;
    geometry::ToolTip tip;
    Eigen::Vector3d origin = Eigen::Vector3d::Zero();  ///< m: the first node's rest position (the action point)
    bool matched = false;  ///< the contact's force is the site law's (SpringModelOptions::match_sites)
    organ::SiteLaw law;
    Eigen::Vector3d displacement = Eigen::Vector3d::Zero();  ///< m: the tip's, from origin
    bool grasped = false;    ///< the jaws hold what the tip holds (docs/realtime.md#grasping)
    organ::SiteGrasp grasp;  ///< a matched contact's grasp law
  };
  struct Hold {
    bool used = false;
    bool first = false;  ///< the node the tip touched first: held until the contact ends
    std::uint32_t tool = 0, node = 0;
    Eigen::Vector3d offset = Eigen::Vector3d::Zero();   ///< m: the node's target displacement less the tool's
    Eigen::Vector3d outward = Eigen::Vector3d::Zero();  ///< unit: where the tip pushes it
  };

  void hold(std::uint32_t tool, std::uint32_t node, const Eigen::Vector3d& offset, const Eigen::Vector3d& outward,
            bool first = false) noexcept {
    for (Hold& h : holds_)
      if (!h.used) {
        h = {true, first, tool, node, offset, outward};
        holder_[node] = static_cast<std::int16_t>(tool);
        return;
      }
  }
  void let_go(Hold& h) noexcept {
    simulation_.release(h.node);
    holder_[h.node] = kFree;
    h.used = false;
  }
  std::size_t holds_of(std::uint32_t tool) const noexcept {
    std::size_t count = 0;
    for (const Hold& h : holds_) count += h.used && h.tool == tool;
    return count;
  }

  void hold_footprint(std::uint32_t tool) noexcept {
    const Tool& t = tools_[tool];
    const Hold* first = nullptr;
    for (const Hold& h : holds_)
      if (h.used && h.first && h.tool == tool) first = &h;
    if (!first) return;
    const Eigen::Vector3d centre = simulation_.position(first->node);
    const auto& rest = simulation_.network().rest;
    std::size_t held = holds_of(tool);
    for (std::uint32_t node = 0; node < organ_.vertex_count() && held < kHoldsPerTool; ++node) {
      if (holder_[node] != kFree || simulation_.network().fixed[node]) continue;
      const Eigen::Vector3d& x = simulation_.position(node);
      if ((x - centre).norm() > t.tip.radius) continue;
      hold(tool, node, x - rest[node] - t.displacement, -t.tip.axis);
      ++held;
    }
  }

  /// Finite tips: let go of the nodes they pull on, take in the free surface
  /// nodes inside them.
  void update_holds() noexcept {
    for (Hold& h : holds_)
      if (h.used && !h.first && !tools_[h.tool].grasped &&
          -simulation_.reaction_force(h.node).dot(h.outward) < -kPullTolerance)
        let_go(h);
    const auto& rest = simulation_.network().rest;
    for (std::uint32_t tool = 0; tool < tools_.size(); ++tool) {
      const Tool& t = tools_[tool];
      if (!t.attached || t.tip.is_point()) continue;
      const Eigen::Vector3d tip_now = t.origin + t.tip.seat + t.displacement;
      std::size_t held = holds_of(tool);
      for (std::uint32_t node = 0; node < organ_.vertex_count() && held < kHoldsPerTool; ++node) {
        if (holder_[node] != kFree || simulation_.network().fixed[node]) continue;
        Eigen::Vector3d normal;
        const Eigen::Vector3d& x = simulation_.position(node);
        const double distance = t.tip.signed_distance(tip_now, x, normal);
        if (distance >= 0.0) continue;
        hold(tool, node, (x - distance * normal) - rest[node] - t.displacement, normal);
        ++held;
      }
    }
  }

  /// With volume springs, the organ held at the FEM models' clamp instead of
  /// by body springs (SpringModelOptions::volume_clamp_radius).
  static SpringModelOptions held_as_the_fem_models(SpringModelOptions options) {
    if (options.network.volume_springs && options.volume_clamp_radius > 0.0) {
      options.network.body_factor = 0.0;
      options.network.clamp_radius = options.volume_clamp_radius;
    }
    return options;
  }

  /// The simulation at options.simulation.dt, or at a smaller step where the
  /// network's stiffest mode needs one (kStableFraction of the integrator's limit).
  static springs::MassSpring make_simulation(const model::OrganModel& model, const SpringModelOptions& options) {
    springs::SpringNetwork network = springs::make_organ_network(model, options.network);
    springs::SimulationOptions simulation = options.simulation;
    const double limit =
        springs::largest_stable_step(simulation.integrator, springs::stiffest_mode(network, simulation.point_damping));
    simulation.dt = std::min(simulation.dt, kStableFraction * limit);
    if (!(simulation.dt > 0.0))
      throw std::invalid_argument(
          "the springs' integrator is unstable at any step on this network: use symplectic "
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
    for (const Hold& h : holds_)
      if (h.used) note_moved(&h.node, 1);
  }
  void note_moved(const std::uint32_t* nodes, std::size_t count) noexcept {
    if (moved_all_) return;
    for (std::size_t k = 0; k < count; ++k)
      if (nodes[k] < moved_mark_.size() && !moved_mark_[nodes[k]]) {
        moved_mark_[nodes[k]] = 1;
        moved_[moved_count_++] = nodes[k];
      }
  }

  /// The tool's held nodes as one: the sum of their reactions, the stiffness
  /// of the group moved together, and the tool displacement their places
  /// agree with.
  void linearize(std::uint32_t tool, ContactLinearization& contact) const noexcept {
    if (const Tool& t = tools_[tool]; t.matched) {
      contact.displacement = t.displacement;
      contact.force = t.grasp.held ? t.grasp.force(t.law, t.displacement) : t.law.force(t.displacement);
      contact.stiffness = t.grasp.held ? t.grasp.tangent(t.law, t.displacement) : t.law.tangent(t.displacement);
      return;
    }
    Eigen::Vector3d force = Eigen::Vector3d::Zero(), displacement = Eigen::Vector3d::Zero();
    Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();
    int count = 0;
    for (const Hold& h : holds_)
      if (h.used && h.tool == tool) {
        force += simulation_.reaction_force(h.node);
        stiffness += simulation_.contact_stiffness(h.node, holder_.data(), static_cast<std::int16_t>(tool));
        displacement += simulation_.position(h.node) - simulation_.network().rest[h.node] - h.offset;
        ++count;
      }
    contact.force = force;
    contact.displacement = count > 0 ? Eigen::Vector3d(displacement / count) : tools_[tool].displacement;
    // Compressed springs make the Jacobian indefinite (their geometric term
    // 1 − l⁰/l is negative); rendered as is, such a direction would push the
    // hand further in. The device gets the positive part.
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eigen(0.5 * (stiffness + stiffness.transpose()));
    contact.stiffness =
        eigen.eigenvectors() * eigen.eigenvalues().cwiseMax(0.0).asDiagonal() * eigen.eigenvectors().transpose();
  }

  const organ::Organ& organ_;
  SpringModelOptions options_;
  springs::MassSpring simulation_;
  std::vector<Tool> tools_;
  std::vector<Hold> holds_;           // slots, kHoldsPerTool per tool
  std::vector<std::int16_t> holder_;  // per network node: the tool holding it, or kFree
  std::uint64_t instabilities_ = 0;
  std::vector<std::uint8_t> moved_mark_;  // per surface vertex
  std::vector<std::uint32_t> moved_;
  std::size_t moved_count_ = 0, active_nodes_ = 0;
  bool moved_all_ = true;
};

const char* region_name(springs::Region region) {
  switch (region) {
    case springs::Region::dynamic: return "dynamic";
    case springs::Region::fixed: return "fixed";
    case springs::Region::all: break;
  }
  return "all";
}

const ModelParameter kSpringParameters[] = {
    {"volume-springs", ModelParameter::Kind::flag,
     "springs: also a spring on every tetrahedron edge, the surface tied to the tetrahedra, held at the clamp like "
     "the FEM models (--fixed-radius) instead of by body springs (docs/springs.md)",
     nullptr,
     [](ModelOptions& o, const ParameterValue& v) -> std::string {
       o.edit<SpringModelOptions>().network.volume_springs = v.number != 0.0;
       return "";
     },
     [](const ModelOptions& o) {
       return ParameterValue{o.of<SpringModelOptions>().network.volume_springs ? 1.0 : 0.0, {}};
     }},
    {"fixed-radius", ModelParameter::Kind::length,
     "FEM models (and springs with --volume-springs): clamp the tetrahedral nodes within this distance of the fixed "
     "point (docs/fem.md)",
     nullptr,
     [](ModelOptions& o, const ParameterValue& v) -> std::string {
       if (!(v.number > 0.0) || !std::isfinite(v.number)) return "the clamp's radius must be a positive length";
       o.edit<SpringModelOptions>().volume_clamp_radius = v.number;
       return "";
     },
     [](const ModelOptions& o) {
       return ParameterValue{o.of<SpringModelOptions>().volume_clamp_radius, {}};
     }},
    {"region", ModelParameter::Kind::choice,
     "springs: integrate all nodes, only a dynamic region around the tools, or a fixed one (--region-rings)",
     "all|dynamic|fixed",
     [](ModelOptions& o, const ParameterValue& v) -> std::string {
       if (v.text != "all" && v.text != "dynamic" && v.text != "fixed") return "unknown region";
       o.edit<SpringModelOptions>().simulation.region = springs::parse_region(std::string(v.text));
       return "";
     },
     [](const ModelOptions& o) {
       return ParameterValue{0.0, region_name(o.of<SpringModelOptions>().simulation.region)};
     }},
    {"region-rings", ModelParameter::Kind::count, "springs, fixed region: its size in springs from each tool", nullptr,
     [](ModelOptions& o, const ParameterValue& v) -> std::string {
       if (!(v.number >= 1.0 && v.number <= 1e6) || v.number != std::floor(v.number))
         return "the region's size must be a whole number of springs from 1 to 1000000";
       o.edit<SpringModelOptions>().simulation.region_rings = static_cast<std::uint32_t>(v.number);
       return "";
     },
     [](const ModelOptions& o) {
       return ParameterValue{static_cast<double>(o.of<SpringModelOptions>().simulation.region_rings), {}};
     }},
    {"region-threshold", ModelParameter::Kind::length,
     "springs, dynamic region: a node displaced beyond this activates its neighbours", nullptr,
     [](ModelOptions& o, const ParameterValue& v) -> std::string {
       if (!(v.number > 0.0) || !std::isfinite(v.number)) return "the threshold must be a positive length";
       o.edit<SpringModelOptions>().simulation.threshold = v.number;
       return "";
     },
     [](const ModelOptions& o) {
       return ParameterValue{o.of<SpringModelOptions>().simulation.threshold, {}};
     }},
    {"unmatched", ModelParameter::Kind::flag,
     "beam, springs: the model's own contact force, not the FEM reference's site law that a model with site "
     "compliances gives a tool of finite size (docs/matching.md)",
     nullptr,
     [](ModelOptions& o, const ParameterValue& v) -> std::string {
       o.edit<SpringModelOptions>().match_sites = v.number == 0.0;
       return "";
     },
     [](const ModelOptions& o) {
       return ParameterValue{o.of<SpringModelOptions>().match_sites ? 0.0 : 1.0, {}};
     }},
    {"supports", ModelParameter::Kind::choice, kSupportsHelp, kSupportsChoices,
     [](ModelOptions& o, const ParameterValue& v) {
       return read_supports(v, o.edit<SpringModelOptions>().network.supports);
     },
     [](const ModelOptions& o) { return supports_value(o.of<SpringModelOptions>().network.supports); }},
};

}  // namespace

extern const RegisteredModel springs_model{
    "springs",
    "mass-spring (He et al.): the surface (and optionally the tetrahedra) as a damped spring network",
    /*needs_beam_tables=*/false,
    /*needs_tetrahedra=*/false,
    /*fem_material=*/std::nullopt,
    StaticPress::settled,
    [](const ModelOptions& options) { return options.of<SpringModelOptions>().match_sites; },
    /*calibration=*/{&model::Material::spring_stiffness_scale, /*attenuated=*/false},
    kSpringParameters,
    std::size(kSpringParameters),
    [](const organ::Organ& organ, const ModelOptions& options, std::size_t tools) -> std::unique_ptr<DeformationModel> {
      return std::make_unique<SpringModel>(organ, options.of<SpringModelOptions>(), tools);
    }};

}  // namespace organsim::realtime
