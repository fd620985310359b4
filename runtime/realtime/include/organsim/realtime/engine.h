// The real-time engine: a force loop (≥ 1 kHz) and a deformation loop (≥ 60 Hz)
// around one deformation model (multi-beam, mass-spring or FEM; deformation_model.h) (Ushiki et al., multi-beam paper,
// §3; docs/multibeam.md#references), with haptic devices, contact detection and force safety. docs/realtime.md states
// the rules.
//
// Threads: force_tick() belongs to the force loop (a 1 kHz thread, or a device's
// servo callback), deformation_step() to the deformation loop; each may run on
// its own thread. They share nothing but three wait-free triple buffers: the
// force loop publishes tool tips and releases, the deformation loop publishes
// each tool's contact (action point, normal, condensed stiffness) and the
// deformed surface. Neither call allocates, locks, throws or does I/O.
//
// Contact rule: a tool's contact begins when its tip's path since the previous
// deformation frame crosses the current deformed surface inwards (a swept test,
// so a fast tool cannot pass through a thin part), or else, for a tool whose
// shaft is known, when its shaft (from the handle, shaft_length away, to the
// tip) crosses the surface inwards, or else when the surface moved onto the
// tip (the tip lies less than 1 mm inside the deformed surface: a nearly
// incompressible organ bulging under another tool). The crossing point, mapped to the rest
// surface, is the action point and the model attaches the tool there with its
// tip (geometry/tool_tip.h: a capsule of the tool's tip radius whose axis is
// the shaft, or the surface normal where the shaft is unknown); the tool's
// contact point is the tip, or the shaft point at the crossing's distance
// from the tip. What the tip touches sticks to it (docs/realtime.md#contact-rule).
// The force loop renders the contact's linearization, F = F₀ − K (d − d₀) with
// d = contact point − action point − slip (for the multi-beam model F₀ = 0,
// d₀ = 0: F = −K d), within Coulomb's friction cone: where the tangential
// part of F exceeds μ times its normal part, the contact slips (the slip, a
// tangential shift of where the organ is held, grows until F lies on the
// cone; both loops use it). The organ pushes a probe, never pulls it (a grasp holds both ways: below). Each fresh
// linearization takes over from the previous one over one deformation period (what changed between them is felt as a
// ramp, not a step). It ends the contact as soon as the contact point is back outside the tangent plane of the rest
// surface at the action point, (contact point − action point) · n ≥ 0.
//
// Grasping (docs/realtime.md#grasping): a grasper whose jaws close while its
// contact is live holds what it touches both ways until they open: its
// contact does not end outside the tangent plane, does not slip, and its force
// may pull (the models hold the patch bilaterally, DeformationModel::set_grasp).
// Jaws closed in the air hold nothing. A grasp whose pull on the tool exceeds
// EngineOptions::grasp_limit slips: the jaws lose the tissue, the contact
// ends (the organ springs back) and the slip is counted and recorded.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "organsim/devices/force_loop.h"
#include "organsim/devices/haptic_device.h"
#include "organsim/geometry/closest_point.h"
#include "organsim/multibeam/multibeam.h"
#include "organsim/organ/organ.h"
#include "organsim/realtime/deformation_model.h"
#include "organsim/realtime/force_safety.h"
#include "organsim/realtime/model_options.h"
#include "organsim/realtime/model_registry.h"
#include "organsim/lockfree/triple_buffer.h"
#include "organsim/lockfree/spsc_ring.h"

namespace organsim::realtime {

using lockfree::TripleBuffer;
using multibeam::kMaxTools;

struct EngineOptions {
  std::string model = default_model().name;  ///< which deformation model runs: a name in model_registry.h
  ModelOptions models;                       ///< each model's own options (model_options.h)
  double force_period = 1e-3;                ///< s
  double deformation_period = 1.0 / 60.0;    ///< s
  double shaft_length = 0.30;                ///< m, tip to handle (laparoscopic instruments: 30–36 cm)
  /// m: the radius of every tool's hemispherical end (a 5 mm laparoscopic
  /// probe); 0 is a point tool.
  double tip_radius = 2.5e-3;
  /// m, per tool: overrides tip_radius where given and ≥ 0 (a session file's tip lines).
  std::vector<double> tool_tip_radii;
  /// Coulomb's friction coefficient μ between the tool and the organ's
  /// surface (wet serosa on steel: about 0.1–0.3; docs/realtime.md#contact-rule);
  /// infinity: the organ never slips under the tool.
  double friction = 0.2;
  /// N: the largest pull a grasp holds; pulled harder, the tissue slips out
  /// of the jaws. An engineering choice, not a measured tissue property
  /// (docs/realtime.md#grasping): above the 3.3 N a PHANToM Touch renders, so
  /// that every pull a trainee can feel is held. Separate from the device's
  /// force clamp (SafetyLimits::max_force).
  double grasp_limit = 4.0;
  /// Force-tick records kept per tool for a reader (Engine::take_tick_record);
  /// 0: none are kept.
  std::size_t tick_records = 0;
  /// The tip radius of `tool` (m).
  double tip_radius_of(std::size_t tool) const noexcept {
    return tool < tool_tip_radii.size() && tool_tip_radii[tool] >= 0.0 ? tool_tip_radii[tool] : tip_radius;
  }
};

/// A tool's contact as the deformation loop publishes it.
struct ToolContact {
  bool active = false;
  std::uint32_t generation = 0;                            ///< counts this tool's contacts
  Eigen::Vector3d action_point = Eigen::Vector3d::Zero();  ///< rest surface, m
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();        ///< outward, rest surface
  Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();     ///< K, N/m, device-limited
  Eigen::Vector3d reference = Eigen::Vector3d::Zero();     ///< d₀, m: the displacement where `force` holds
  Eigen::Vector3d force = Eigen::Vector3d::Zero();         ///< F₀, N on the tool at d₀
  double shaft_offset = 0.0;  ///< m from the tip along the shaft to the tool's contact point (0: the tip)
  /// m along `normal`: the contact ends once the tool's displacement from the
  /// action point has more than this outward part. Where the contact began
  /// (the displacement's outward part then, when the organ had moved out onto
  /// the tool; 0 otherwise).
  double release_height = 0.0;
};

struct ContactFrame {
  std::array<ToolContact, kMaxTools> tools{};
  double time = -1.0;  ///< s, when the deformation loop published it
};

/// The force loop's view of the tools, published every tick.
struct ToolFrame {
  std::array<Eigen::Vector3d, kMaxTools> tips{};
  std::array<Eigen::Vector3d, kMaxTools> shafts{};  ///< unit, tip to handle; zero when unknown
  std::array<bool, kMaxTools> tip_valid{};
  std::array<std::uint32_t, kMaxTools> released{};         ///< generation of the last contact the force loop ended
  std::array<Eigen::Vector3d, kMaxTools> slips{};          ///< m: how far each contact has slipped (friction)
  std::array<std::uint32_t, kMaxTools> slip_generation{};  ///< the contact each slip belongs to
  std::array<bool, kMaxTools> grasped{};                   ///< the jaws hold the contact of slip_generation (grasping)
  double time = -1.0;
};

/// The deformed organ for viewers (model's vertex order of organ::Organ).
struct SurfaceFrame {
  std::vector<model::Point3> positions;  ///< m
  std::vector<model::Point3> normals;    ///< unit
  /// Per tool: whether its jaws hold the organ in this frame, the rest-surface
  /// point they hold (m) and the tool's tip radius (m): where a viewer marks
  /// the held patch (docs/realtime.md#grasping).
  std::array<bool, kMaxTools> holding{};
  std::array<Eigen::Vector3d, kMaxTools> held_point{};
  std::array<double, kMaxTools> held_radius{};
  std::uint64_t frame = 0;
  double time = 0.0;
};

/// What the force loop saw of one tool (read after the loops have stopped).
struct ToolTelemetry {
  std::uint32_t contacts = 0;  ///< contacts begun
  /// Times the device stopped giving a valid pose (an error, a disconnected
  /// device): its force then fades from the last one sent to zero over the
  /// device's ramp_down_time, and comes back through the onset ramp when
  /// the pose does. The other tools go on.
  std::uint32_t pose_faults = 0;
  double peak_force = 0.0;        ///< N, after safety
  std::uint32_t grasps = 0;       ///< grasps begun: jaws closed on a live contact
  std::uint32_t grasp_slips = 0;  ///< grasps that slipped: pulled beyond EngineOptions::grasp_limit
  double peak_pull = 0.0;         ///< N: the largest force a grasp pulled the tool with, before safety
  bool in_contact = false;
  Eigen::Vector3d last_force = Eigen::Vector3d::Zero();
};

/// One force tick of one tool, for whoever records the session (a training
/// report): what was sent, what the model asked for, and where the tool was.
struct TickRecord {
  double time = 0.0;                                      ///< s
  Eigen::Vector3d sent_force = Eigen::Vector3d::Zero();   ///< N, to the device, after the safety rules
  Eigen::Vector3d model_force = Eigen::Vector3d::Zero();  ///< N, what the model computed, before them
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();          ///< m, model frame (zero when the pose was invalid)
  double depth = 0.0;  ///< m: how far the tool's contact point is pushed in along the rest surface's inward normal
  bool in_contact = false, pose_valid = false;
  bool jaws_closed = false;    ///< the device's jaws (a probe's are always open)
  bool grasped = false;        ///< the jaws hold the organ
  bool grasp_slipped = false;  ///< this tick the grasp slipped (pulled beyond the holding limit)
};

class Engine final : public devices::ForceLoop {
 public:
  /// Devices are not owned and must outlive the engine; at most kMaxTools.
  Engine(const organ::Organ& organ, const std::vector<devices::HapticDevice*>& devices, const EngineOptions& options);

  /// One force-loop iteration at time `now` (s).
  void force_tick(double now) noexcept override;
  /// One deformation-loop iteration at time `now` (s).
  void deformation_step(double now) noexcept;
  /// Whether a tool held the organ in the last deformation step (the FEM
  /// models solve only then; without a tool they are at rest). From the
  /// deformation loop's thread.
  bool touched_in_last_step() const noexcept { return touched_; }
  /// Whether the model waits for its late background work (reproducible runs:
  /// run_fast) or goes on without it (real-time loops: run_realtime, the
  /// viewer's and the devices' loops); DeformationModel::set_reproducible.
  /// Before the loops run.
  void set_reproducible(bool reproducible) noexcept { model_->set_reproducible(reproducible); }

  std::size_t tool_count() const noexcept { return devices_.size(); }
  const EngineOptions& options() const noexcept { return options_; }
  const organ::Organ& organ() const noexcept { return organ_; }
  /// The latest deformed surface: call update() then read() from one reader thread.
  TripleBuffer<SurfaceFrame>& surfaces() noexcept { return surfaces_; }
  /// Force-loop telemetry; read when the force loop is not running.
  const ToolTelemetry& telemetry(std::size_t tool) const noexcept { return telemetry_[tool]; }
  const ForceSafety& safety(std::size_t tool) const noexcept { return safety_[tool]; }
  /// Contacts the model refused (far from organ, at the clamp…).
  std::uint64_t refused_contacts() const noexcept { return refused_; }
  /// The deformation model (read its counters when the loops are not running).
  const DeformationModel& model() const noexcept { return *model_; }
  /// With EngineOptions::tick_records > 0, every force tick leaves one record
  /// per tool in a wait-free ring of that capacity; one reader thread takes
  /// them in order while the loops run. False when none is held.
  bool take_tick_record(std::size_t tool, TickRecord& out) noexcept { return tick_records_[tool].take(out); }
  /// Tick records that found the tool's ring full (the reader fell behind).
  std::size_t dropped_tick_records(std::size_t tool) const noexcept { return tick_records_[tool].dropped(); }

 private:
  void publish_linearization(std::size_t tool) noexcept;

  const organ::Organ& organ_;
  std::vector<devices::HapticDevice*> devices_;
  EngineOptions options_;

  // Force loop only.
  std::array<ForceSafety, kMaxTools> safety_{};
  std::array<std::uint32_t, kMaxTools> released_{};
  std::array<ToolTelemetry, kMaxTools> telemetry_{};
  std::array<std::uint32_t, kMaxTools> seen_generation_{};
  std::array<double, kMaxTools> fault_start_{};              // s, when the pose went invalid; < 0 while valid
  std::array<Eigen::Vector3d, kMaxTools> fault_force_{};     // N, the force sent just before
  std::array<Eigen::Vector3d, kMaxTools> last_valid_tip_{};  // m, the tip where the pose was last valid
  std::array<Eigen::Vector3d, kMaxTools> slip_{};            // m, of the current contact
  std::array<bool, kMaxTools> grasped_{};                    // the jaws hold the current contact
  std::array<bool, kMaxTools> jaws_were_closed_{};           // the jaws at the last valid pose
  std::array<Eigen::Vector3d, kMaxTools> letting_go_{};      // N: the force fading out after a grasp let go
  // Blending a fresh linearization in: the one it replaces, the force that
  // one gave at the switch less the fresh one's, when, and for which frame and contact.
  struct HeldLinearization {
    Eigen::Vector3d force = Eigen::Vector3d::Zero();      // F₀, N
    Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();  // K, N/m
    Eigen::Vector3d reference = Eigen::Vector3d::Zero();  // d₀, m
  };
  std::array<HeldLinearization, kMaxTools> held_{};
  std::array<Eigen::Vector3d, kMaxTools> blend_offset_{};
  // What of `tool`'s blend offset is still felt at `now`: 1 at the switch, 0 a deformation period later.
  double blend_left(std::size_t tool, double now) const noexcept;
  std::array<double, kMaxTools> blend_start_{}, blend_frame_{};
  std::array<std::uint32_t, kMaxTools> blend_generation_{};
  double previous_tick_ = -1.0;
  std::array<lockfree::SpscRing<TickRecord>, kMaxTools> tick_records_;

  // Deformation loop only.
  std::unique_ptr<DeformationModel> model_;
  std::array<ContactLinearization, kMaxTools> linearizations_{};
  double previous_step_ = -1.0;
  bool touched_ = false;  // a contact was active in the last deformation step
  geometry::SurfaceBvh deformed_tree_;
  const model::Point3* tree_positions_ = nullptr;  // the last published surface
  bool tree_stale_ = false;                        // the tree does not describe it yet
  // The surface vertices moved since the tree's last refit (per vertex mark
  // and list), unless all may have moved.
  std::vector<std::uint8_t> moved_mark_;
  std::vector<std::uint32_t> moved_list_;
  std::size_t moved_count_ = 0;
  bool all_moved_ = true;
  void note_moved_vertices() noexcept;
  void refit_contact_tree() noexcept;
  ContactFrame contacts_;
  std::array<Eigen::Vector3d, kMaxTools> previous_tip_{};
  std::array<bool, kMaxTools> previous_valid_{};
  std::array<Eigen::Vector3d, kMaxTools> displacement_{};
  std::array<Eigen::Vector3d, kMaxTools> refused_at_{};  // where a contact was last refused
  std::array<bool, kMaxTools> refused_valid_{};
  std::array<bool, kMaxTools> held_in_jaws_{};  // the model was last told that the jaws hold the contact
  std::uint64_t frame_ = 0;
  std::uint64_t refused_ = 0;

  // Hand-offs.
  TripleBuffer<ContactFrame> contact_frames_;
  TripleBuffer<ToolFrame> tool_frames_;
  TripleBuffer<SurfaceFrame> surfaces_;
};

}  // namespace organsim::realtime
