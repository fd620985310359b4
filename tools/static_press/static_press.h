// Static presses of a baked organ with any deformation model: each tool's
// contact point moved by a prescribed displacement, the organ held where the
// model holds it, and what came of it (forces, the deformed surface, timings).
// A static press holds the organ where the tool touched it and lets it slip
// under the tool where the force leaves Coulomb's friction cone, as the
// engine's contact rule does (docs/realtime.md#contact-rule); a slip depends
// on the way the tool went, and a press goes the straight way, in the load
// steps of a finite tip.
// What `poke` prints for one or two models and `compare` tabulates for all.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <Eigen/Core>

#include "command_line/model_tuning.h"
#include "organsim/fem/displacement_difference.h"
#include "organsim/geometry/tool_tip.h"
#include "organsim/organ/organ.h"

namespace organsim::cli {

/// One --tool X,Y,Z/DX,DY,DZ: a point on or near the surface and its
/// prescribed displacement (model frame, mm).
struct ToolSpec {
  std::string text;
  Eigen::Vector3d point_mm;
  Eigen::Vector3d displacement_mm;
};

/// Parses X,Y,Z/DX,DY,DZ; throws std::runtime_error naming the text.
ToolSpec parse_tool(const std::string& text);

/// How a press is set up beyond the model's name.
struct PressOptions {
  std::string command = "poke";    ///< for warnings
  double snap_distance_mm = 10.0;  ///< farthest a tool point may be from the surface
  double settle_seconds = 2.0;     ///< a model settled in time: how long the press is held before the force is read
  /// > 0: a grasp (docs/realtime.md#grasping). Each tool first presses this
  /// far in along the inward normal at its point (mm), closes its jaws on what
  /// it holds, then moves to its displacement (outward: a pull), the organ
  /// held both ways and never slipping.
  double grasp_bite_mm = 0.0;
  ModelTuning tuning;
};

/// What one press gave, whatever the model.
struct ToolResult {
  Eigen::Vector3d action_point = Eigen::Vector3d::Zero();  ///< m, rest surface
  double snap_distance = 0.0;                              ///< m, from the tool point to the action point
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double beam_length = 0.0;                                ///< m (multi-beam model only)
  Eigen::Vector3d force = Eigen::Vector3d::Zero();         ///< N on the tool
  Eigen::Vector3d action_moved = Eigen::Vector3d::Zero();  ///< m: how far the organ moved the action point
  /// FEM models: the boundary points the tool holds at equilibrium (the first
  /// touch and those its tip took in; how finely the contact is resolved).
  std::size_t held_points = 0;
  /// m: how far the organ slipped under the tool (Coulomb's friction cone,
  /// --friction), within the tangent plane at the action point; the organ is
  /// held displaced by the press less this.
  Eigen::Vector3d slip = Eigen::Vector3d::Zero();
};

struct PressResult {
  std::string model;    ///< the deformation model's name
  std::string summary;  ///< one line on how the model was set up and solved
  std::vector<ToolResult> tools;
  std::vector<model::Point3> positions, normals;
  /// The tetrahedral nodes' positions (m, the model's node order) when the
  /// model moves them: the multi-beam model (its space distortion of every
  /// point), the FEM models, the mass-spring model with volume springs; empty otherwise.
  std::vector<model::Point3> node_positions;
  double attach_seconds = 0.0;  ///< per tool
  double force_seconds = 0.0;   ///< per tool and force evaluation
  double deform_seconds = 0.0;  ///< per deformation frame (FEM: per Newton iteration)
  double frame_seconds = 0.0;   ///< one real-time frame at the pressed state (FEM: one iteration with the kept factor)
  double setup_seconds = 0.0;   ///< FEM: building the system and factorizing the rest tangent
  int frames = 1;               ///< deformation frames (FEM: Newton iterations) to equilibrium
  /// FEM models: contact points a tip would have taken but found no room for
  /// (OrganFem::hold_overflows); non-zero means the contact is truncated.
  std::uint64_t contact_points_left_out = 0;
};

/// Registers --tool (repeatable, required; into `tools`), --snap-distance,
/// the model tuning options (every model's parameters) and --settle.
void add_press_options(CLI::App& app, std::vector<std::string>& tools, PressOptions& o);

/// The rest-surface point a tool presses: the nearest one, within the snap
/// distance (m). Throws std::runtime_error naming the tool (its 0-based
/// `index` is printed 1-based) when it is farther or not finite.
Eigen::Vector3d snap_to_surface(const organ::Organ& organ, const ToolSpec& tool, std::size_t index,
                                const PressOptions& o);

/// The end of a tool pressing at `rest_point` (m) by `displacement` (m): a
/// capsule of --tip-radius whose shaft trails the press (the probe pushed
/// along its shaft), or lies along the surface normal where the press does
/// not go into the organ.
geometry::ToolTip press_tip(const organ::Organ& organ, const Eigen::Vector3d& rest_point,
                            const Eigen::Vector3d& displacement, const PressOptions& o);

/// How far behind the hemisphere's centre the shaft of `tip`, seated at the
/// organ's surface point `rest_point` (m), first enters the organ at rest
/// (m), along its axis; infinity where it stays outside. A press whose shaft would have to pierce the organ elsewhere
/// cannot be made (press() refuses it).
double shaft_entry(const organ::Organ& organ, const Eigen::Vector3d& rest_point, const geometry::ToolTip& tip);

/// The same for `tool` seated where press() seats it (the surface point
/// nearest its point): infinity also for a tool press() leaves to the model to
/// refuse (not finite, beyond `o`'s snap distance). press() refuses a tool
/// with a finite value.
double shaft_entry(const organ::Organ& organ, const ToolSpec& tool, const PressOptions& o);

/// Presses the organ with the registered model `model`, as its entry's
/// static_press says: the multi-beam model's one deformation, a FEM model's
/// static equilibrium by Newton's method, any other model (the mass-spring
/// model) settled over `settle_seconds`. Throws std::runtime_error with a one-line reason (also for a tool
/// whose shaft passes through the organ: shaft_entry).
PressResult press(const std::string& model, const organ::Organ& organ, const std::vector<ToolSpec>& tools,
                  const PressOptions& o);

/// How the deformed organ of a press looks, in numbers.
struct Deformation {
  double max_displacement = 0.0;  ///< m
  std::size_t max_vertex = 0;     ///< runtime numbering
  double rest_volume = 0.0,
         deformed_volume = 0.0;  ///< m³: of the tetrahedra when the press moved them, else enclosed by the surface
  bool volume_of_tetrahedra = false;
};

Deformation measure(const organ::Organ& organ, const PressResult& press);

/// Where two presses of the same organ differ: the surfaces vertex by vertex
/// (m) and the tools' forces (N).
struct Difference {
  double rms = 0.0, max = 0.0;  ///< vertex distance between the two deformed surfaces, m
  std::vector<double> force;    ///< per tool |F_a − F_b|, N
};

Difference difference(const PressResult& a, const PressResult& b);

/// The measure on the tetrahedral nodes when both presses moved them, else on
/// the surface vertices (`on_nodes` says which), and always on the surface.
struct Comparison {
  fem::DisplacementDifference measure, surface;
  bool on_nodes = false;
};

/// The organ's bounding box extent (m) along x, y, z.
Eigen::Vector3d bounding_box_extent(const std::vector<model::Point3>& points);

Comparison compare_presses(const PressResult& press, const PressResult& reference, const Eigen::Vector3d& extent);

/// The factor by which a press's tool forces are typically off the
/// reference's, exp(√mean ln²(|F| / |F_ref|)) over the tools (1: the same;
/// 2: twice or half); NaN where a force is zero.
double force_factor(const PressResult& press, const PressResult& reference);

}  // namespace organsim::cli
