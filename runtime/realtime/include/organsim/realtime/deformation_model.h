// The seam between the real-time engine and a deformation model. The engine
// finds contacts, runs the force loop and publishes frames; a model only
// answers three questions, all on the deformation loop's thread:
//   attach  — a tool with this tip (geometry/tool_tip.h) touches the rest
//             surface here: can you take it, and how stiff is the contact?
//   step    — the attached tools' contact points are displaced so: move the
//             surface (and say, per contact, the force and stiffness now);
//   detach  — the tool left.
//
// The 1 kHz force loop never calls a model. It renders, per contact, the local
// linearization the last step published:
//     F(d) = force − stiffness · (d − displacement),
// d being the contact point's displacement from its action point. For the
// multi-beam model this is exact (force = −K·displacement, so F = −K d); for
// a dynamic model (mass-spring) it is the first-order model of the reaction
// around the last simulated state, refreshed at the deformation rate. It is
// stable on the device when the stiffness is within the device's renderable
// stiffness (the engine scales it down to that limit, as for the beam) and the
// linearization changes little between two deformation frames (docs/realtime.md).
//
// Every call is noexcept and allocates nothing, takes no lock and does no I/O;
// models allocate everything in their constructor.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include <Eigen/Core>

#include "organsim/geometry/tool_tip.h"
#include "organsim/model/organ_model.h"
#include "organsim/springs/mass_spring.h"

namespace organsim::realtime {

/// One contact as the force loop renders it (see the file comment).
struct ContactLinearization {
  Eigen::Vector3d action_point = Eigen::Vector3d::Zero();  ///< on the rest surface, m
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();        ///< outward, rest surface, unit
  Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();     ///< N/m
  Eigen::Vector3d displacement = Eigen::Vector3d::Zero();  ///< m: where `force` holds
  Eigen::Vector3d force = Eigen::Vector3d::Zero();         ///< N on the tool at `displacement`
};

class DeformationModel {
 public:
  virtual ~DeformationModel() = default;
  /// The registered name (model_registry.h): "beam", "psh", …
  virtual const char* name() const noexcept = 0;
  /// Contact begins: the tip of `tool` touches the rest surface at
  /// `rest_point` (m); the tool's displacements in step() are its tip's from
  /// there. Every model holds the organ by the same rule
  /// (docs/realtime.md#contact-rule): what the tip touches sticks to it. Fills the
  /// linearization at zero displacement; false (nothing changed) when the
  /// model cannot take the contact (too near the clamp, …).
  virtual bool attach(std::uint32_t tool, const Eigen::Vector3d& rest_point, const geometry::ToolTip& tip,
                      ContactLinearization& contact) noexcept = 0;
  virtual void detach(std::uint32_t tool) noexcept = 0;
  /// An attached tool's jaws close on (true) or let go of (false) what it
  /// holds (docs/realtime.md#grasping). While grasped, the contact holds the
  /// organ both ways: the points the tip holds are not let go when they would
  /// pull, and a matched contact's force goes on linearly past the rest
  /// surface (the site law's bonded-punch stiffness) instead of vanishing
  /// there. detach() ends a grasp too.
  virtual void set_grasp(std::uint32_t tool, bool grasped) noexcept = 0;
  /// Advances the model by `dt` s with the attached tools' contact-point
  /// displacements (`displacements[tool]`, m; detached tools' entries are
  /// ignored); writes the surface vertex positions and unit normals (the
  /// organ's vertex order, organ::Organ) and refreshes `contacts[tool]` of every attached
  /// tool. False when the positions could not be computed (the buffers then
  /// keep the previous frame).
  virtual bool step(double dt, const Eigen::Vector3d* displacements, model::Point3* positions, model::Point3* normals,
                    ContactLinearization* contacts) noexcept = 0;
  /// Steps that diverged and were undone (dynamic models); 0 for static ones.
  virtual std::uint64_t instabilities() const noexcept { return 0; }
  /// The surface vertices whose positions the last successful step() may have
  /// changed (`count` of them, valid until the next step()), when the model
  /// knows a smaller set than all: the mass-spring model in a dynamic region.
  /// The engine then refits its contact tree only above them. nullptr: any
  /// vertex may have moved.
  virtual const std::uint32_t* moved_vertices(std::size_t& count) const noexcept {
    count = 0;
    return nullptr;
  }
  /// Where the model's tetrahedral nodes are now (m, the model file's node
  /// order; `capacity` ≥ the model's volume vertices), for a model that moves
  /// them: the FEM models, the mass-spring model with volume springs. False
  /// (nothing written) for a model that moves only the surface.
  virtual bool volume_node_positions(model::Point3* positions, std::size_t capacity) const noexcept {
    (void)positions;
    (void)capacity;
    return false;
  }
  /// Nodes the last step() integrated (the mass-spring model's active
  /// region); 0 for models that have no such notion.
  virtual std::size_t active_nodes() const noexcept { return 0; }
  /// true (the default): background work a step takes up (the FEM tangent
  /// worker's refactorization) is waited for when it is late, so that a run
  /// gives the same forces every time (fast replays); false: a step goes on
  /// with what it has and takes the work up when it is done (the real-time
  /// loops, where waiting would overrun the frame). Between runs only.
  virtual void set_reproducible(bool reproducible) noexcept { (void)reproducible; }
  /// What one step() is expected to take on this machine (s), measured when
  /// the model was set up, so that a caller can say before a session starts
  /// that the frames will not fit the deformation period; 0 when the model
  /// makes no such estimate (the multi-beam and mass-spring models bound
  /// their own work per frame).
  virtual double estimated_frame_seconds() const noexcept { return 0.0; }
};

/// How the mass-spring model runs inside the engine (docs/springs.md).
struct SpringModelOptions {
  springs::OrganNetworkOptions network;
  springs::SimulationOptions simulation = default_simulation();
  /// At most this many simulation steps per deformation frame (the model falls
  /// behind real time beyond it rather than overrun the frame).
  std::uint32_t max_steps_per_frame = 40;
  /// A tool of finite size on a model with site compliances gets the FEM
  /// reference's force (organsim/organ/site_law.h, docs/matching.md) instead
  /// of the network's reaction; false: always the network's.
  bool match_sites = true;
  /// m, with network.volume_springs: the tetrahedral nodes within this of the
  /// model's fixed point are clamped, as the FEM models clamp theirs
  /// (fem::OrganFemOptions::fixed_radius), and the body springs are left out:
  /// they stand in for the interior a surface network lacks and pin each vertex
  /// in space, while with the interior's springs there the organ is held where
  /// the FEM models hold it and moves about the clamp as theirs does
  /// (docs/springs.md#organ-networks-make_organ_network). 0: the network
  /// options as given (the volume springs beside the body springs).
  double volume_clamp_radius = 0.010;

  /// Symplectic Euler at 1 ms, and no gravity: the CT shows the organ under
  /// its own weight, so its shape is the rest state (as for the multi-beam
  /// model); gravity from that shape would make the organ sag a second time.
  static springs::SimulationOptions default_simulation() {
    springs::SimulationOptions s;
    s.integrator = springs::Integrator::symplectic_euler;
    s.dt = 1e-3;
    s.gravity.setZero();
    return s;
  }
};

}  // namespace organsim::realtime
