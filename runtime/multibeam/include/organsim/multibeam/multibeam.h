// The multi-beam deformation model (Ushiki et al., multi-beam paper, eqs. 4–8;
// docs/multibeam.md#references): one clamped beam per tool from the organ's
// fixed point to the tool's action point on the surface; the force on each tool
// from its beam; the whole organ moved by the space distortion of all beams,
// merged by the influence function or by superposition.
//
// Shaped for real time: construct once (allocates everything for max_tools
// tools); attach() builds a beam when a contact begins (tables interpolated,
// stiffness assembled, factorized and condensed: microseconds); force() is one
// 3×3 product (haptic rate); deform() moves every vertex and recomputes normals
// (frame rate). None of these allocates, locks, throws or does I/O.
//
// Units: metres, newtons. Frame: the model's (LPS or RAS, see the model file).
//
// Rules (docs/multibeam.md):
// - action point: the surface point closest to the tool point; refused
//   (far_from_organ) beyond `snap_distance`;
// - beam: from the fixed point to the action point, `stations` elements; its
//   sections are the baked tables of the action point's triangle, interpolated
//   with its barycentric weights as frame-independent section tensors;
//   refused (at_fixed_point) when shorter than `min_beam_length`;
// - force on the tool for a tip displacement d: −K d, K the condensed tip
//   stiffness (the organ pushes back); for a tool of finite size on a model
//   with site compliances, the FEM reference's site law instead
//   (organ/site_law.h, docs/matching.md);
// - distortion of vertex x by beam i: t = projection of x on the beam axis,
//   clamped to [0, 1]; s(x) = u(t) + θ(t) × q + ½ θ(t) × (θ(t) × q), q = x − b(t)
//   (plane sections stay plane and, to second order, rigid); u(t) Hermite
//   between nodes (axial part linear), θ(t) linear; attenuated by α^(−β d), d =
//   |x − action point|;
// - merging: `influence` weights beam i by f_i(x) (eq. 7), tools whose action
//   points lie within `merge_distance` of an earlier tool's share one weight
//   equally; `sum` adds the fields (eq. 5).
#pragma once

#include <atomic>
#include <cstdint>
#include <string_view>
#include <vector>

#include <Eigen/Core>
#include <Eigen/StdVector>

#include "organsim/geometry/closest_point.h"
#include "organsim/organ/organ.h"
#include "organsim/multibeam/clamped_beam.h"
#include "organsim/multibeam/influence.h"
#include "organsim/multibeam/status.h"
#include "organsim/organ/site_law.h"

namespace organsim::multibeam {

struct MultiBeamOptions {
  std::uint32_t max_tools = 4;  ///< 1..kMaxTools
  BeamBuildOptions beam;        ///< Euler–Bernoulli, eccentric sections
  MergeRule merge = MergeRule::influence;
  double snap_distance = 0.010;    ///< m: farthest a tool point may be from the surface
  double merge_distance = 0.001;   ///< m: action points closer than this share one influence weight
  double min_beam_length = 0.002;  ///< m: shorter beams (action point at the clamp) are refused
  /// A tool of finite size on a model with site compliances gets the FEM
  /// reference's force (organsim/organ/site_law.h, docs/matching.md) instead
  /// of its beam's; false: always the beam's.
  bool match_sites = true;
  /// The organ resting on its supports where the model has them
  /// (docs/supports.md): a press meets the site law's compliance on the
  /// supports (a grasped patch drawn out, the organ held by its clamp), and
  /// each beam node rests on the supports of its section's rim (a beam on an
  /// elastic foundation; contacts as pressed).
  bool supports = false;
};

/// One tool's beam, fixed from attach() to detach().
struct ToolBeam {
  bool attached = false;
  geometry::SurfacePoint action;                        ///< action point on the rest surface
  double length = 0.0;                                  ///< beam length, m
  Eigen::Matrix3d frame = Eigen::Matrix3d::Identity();  ///< columns: beam x, y, z (world)
  /// K (world, N/m): the beam's condensed tip stiffness, or the site law's
  /// at small depth when `matched`.
  Eigen::Matrix3d stiffness = Eigen::Matrix3d::Zero();
  bool matched = false;  ///< the force is the site law's (MultiBeamOptions::match_sites)
  organ::SiteLaw law;    ///< valid when `matched`
};

/// The names the command line and the Python module use: "influence" or
/// "sum" (MergeRule); "euler-bernoulli" or "timoshenko" (BeamTheory). False
/// (nothing changed) for any other name.
bool parse_merge_rule(std::string_view name, MergeRule& rule) noexcept;
bool parse_beam_theory(std::string_view name, BeamTheory& theory) noexcept;

class MultiBeam {
 public:
  /// Throws std::invalid_argument with a one-line reason when the organ has no
  /// beam tables (a model baked with --no-beam-tables) or the options are out
  /// of range.
  MultiBeam(const organ::Organ& organ, const MultiBeamOptions& options);

  const organ::Organ& organ() const noexcept { return organ_; }
  const MultiBeamOptions& options() const noexcept { return options_; }
  std::uint32_t max_tools() const noexcept { return options_.max_tools; }
  /// Stations (elements) per beam: the model file's beam tables'.
  std::uint32_t stations() const noexcept { return stations_; }
  /// The beams' elastic constants: the model's E × beam_stiffness_scale and ν.
  const BeamElasticity& elasticity() const noexcept { return elasticity_; }
  /// κ of the attenuation exp(−κ d) = α^(−β d): κ = β ln α, 1/m.
  double attenuation_rate() const noexcept { return attenuation_rate_; }
  /// Rest positions relative to the fixed point (m), in single precision
  /// (about 10 nm here), padded like Organ::rest_x(): what the distortion loops
  /// read (twice the lanes per register).
  const float* offset_x() const noexcept { return offset_[0].data(); }
  const float* offset_y() const noexcept { return offset_[1].data(); }
  const float* offset_z() const noexcept { return offset_[2].data(); }

  /// Contact begins: snaps `point` (m) to the surface and builds tool's beam;
  /// a tool end of radius `tip_radius` (m; 0: a point) gets the site law
  /// where the model has one (MultiBeamOptions::match_sites).
  Status attach(std::uint32_t tool, const Eigen::Vector3d& point, double tip_radius = 0.0) noexcept;
  /// Contact ends.
  void detach(std::uint32_t tool) noexcept;
  const ToolBeam& beam(std::uint32_t tool) const noexcept { return tools_[tool]; }

  /// Force on the tool (N, world) when its action point is displaced by
  /// `tip_displacement` (m, world): −K d, or the site law's −g(|d|) K d when
  /// matched. Zero force unless the status is ok.
  Status force(std::uint32_t tool, const Eigen::Vector3d& tip_displacement,
               Eigen::Vector3d& force_on_tool) const noexcept;

  /// Deformed vertex positions (m) and unit normals for the tip displacements of
  /// the attached tools (`tip_displacements[tool]`, m, world; entries of detached
  /// tools are ignored). Both buffers hold vertex_count() points. Equivalent to
  /// prepare() + distort(0, n) + normals(0, n).
  Status deform(const Eigen::Vector3d* tip_displacements, model::Point3* positions, model::Point3* normals,
                std::size_t capacity) noexcept;

  /// The steps of deform(), for callers that split the vertices over threads:
  /// prepare() once, then distort() on disjoint ranges, then (after all
  /// distort() calls have finished) normals() on disjoint ranges: the normals
  /// of the surface the distort() calls left, from a single-precision copy of
  /// its points that distort() keeps (16 bytes a vertex: one load each):
  /// unit to 10⁻⁷, and off compute_vertex_normals() on the double positions
  /// by about float's 4 nm at a decimetre over the vertex's shortest edge
  /// (4·10⁻⁶ rad for 2 mm; docs/multibeam.md). Before any distort(), those of
  /// the rest shape. Vertex
  /// indices are the organ's (see organ::Organ::file_vertex_index); range
  /// bounds other than 0 and vertex_count() must be multiples of
  /// organ::Organ::kPadding (vector loops read whole registers).
  ///
  /// Each vertex's weight per tool (attenuation and influence) does not change
  /// while the contacts stay the same; it is computed by the first distort()
  /// after a contact began or ended, so that frame costs about twice a steady
  /// one. The distortion runs in single precision: displacements within about
  /// 10⁻⁷ of themselves plus a few nanometres (docs/multibeam.md).
  Status prepare(const Eigen::Vector3d* tip_displacements) noexcept;
  void distort(std::size_t first, std::size_t last, model::Point3* positions) noexcept;
  void normals(std::size_t first, std::size_t last, model::Point3* normals) const noexcept;

  /// The displacement (m) that the space distortion of the last prepare()
  /// gives any rest point `rest` (m), not only a surface vertex: an interior
  /// node of the tetrahedral mesh, a point of a plot. The rules of distort()
  /// (the same beam coefficients), evaluated in double precision one point at a
  /// time, so at the surface vertices it agrees with distort() to distort()'s
  /// single-precision tolerance. For offline use (compare, calibrate): each
  /// call costs a square root and an exponential per tool and the influence
  /// function's distances.
  Eigen::Vector3d displacement_at(const Eigen::Vector3d& rest) const noexcept;

 private:
  // Per active tool, per element: cubic coefficients of half the displacement
  // u(ξ)/2 = c0 + c1 ξ + c2 ξ² + c3 ξ³ (3 components each) and of half the
  // rotation θ(ξ)/2 = r0 + r1 ξ, world frame, then the terms that continue
  // them into the next element (organsim/vertex_kernels/vertex_kernels.h); 30 consecutive
  // values per element, single precision like the rest of the distortion.
  static constexpr int kCoefficients = 30;  // = kernels::kCoefficients
  float* coefficients(std::uint32_t slot, std::uint32_t element) noexcept {
    return coefficient_data_.data() + (static_cast<std::size_t>(slot) * stations_ + element) * kCoefficients;
  }
  const float* coefficients(std::uint32_t slot, std::uint32_t element) const noexcept {
    return coefficient_data_.data() + (static_cast<std::size_t>(slot) * stations_ + element) * kCoefficients;
  }
  // Per active tool, per vertex (valid between contact changes): the weight
  // α^(−βd)·f(x)/group size, the only per-vertex term that costs more to
  // compute (a square root and an exponential per tool, and the influence
  // function's distances) than to read.
  float* vertex_weight(std::uint32_t slot) noexcept {
    return vertex_weights_.data() + static_cast<std::size_t>(slot) * vertex_stride_;
  }
  // Per active tool, per chunk of eight vertices (valid between contact
  // changes): the beam elements the chunk's vertices lie in (vertex_kernels.h).
  std::uint16_t* chunk_elements(std::uint32_t slot) noexcept {
    return chunk_elements_.data() + static_cast<std::size_t>(slot) * chunk_stride_;
  }
  void build_vertex_weights(std::size_t first, std::size_t last) noexcept;

  const organ::Organ& organ_;
  MultiBeamOptions options_;
  std::uint32_t stations_;
  BeamElasticity elasticity_;
  double attenuation_rate_;
  std::vector<float> offset_[3];
  std::vector<ToolBeam> tools_;
  std::vector<ClampedBeam> solvers_;          // per tool
  std::vector<model::BeamSection> sections_;  // scratch for attach(): stations entries
  /// The supported surface vertices (MultiBeamOptions::supports): each one's
  /// foundation stiffness k A (N/m) and whether it is a contact.
  struct SupportedVertex {
    std::uint32_t vertex;
    double stiffness;
    bool unilateral;
  };
  std::vector<SupportedVertex> supported_;
  std::vector<Eigen::Matrix3d> foundation_;  // scratch for attach(): per beam node, local frame

  // Filled by prepare(): the active tools in slot order and their merge data.
  std::uint32_t active_count_ = 0;
  std::uint32_t active_tool_[kMaxTools] = {};
  Eigen::Vector3d active_point_[kMaxTools];
  std::uint32_t active_group_[kMaxTools] = {};  // index into the influence function's points
  double group_share_[kMaxTools] = {};          // 1 / members of the tool's group
  InfluenceFunction influence_;
  std::vector<float> coefficient_data_;
  std::uint64_t contact_generation_ = 0;  // bumped by every attach and detach
  std::uint64_t prepared_generation_ = ~std::uint64_t{0};
  bool vertex_weights_stale_ = true;
  std::atomic<bool> distorted_{false};  // a distort() ran since the last prepare() (any thread)
  std::size_t vertex_stride_ = 0;
  std::vector<float> vertex_weights_;
  std::size_t chunk_stride_ = 0;
  std::vector<std::uint16_t> chunk_elements_;
  std::vector<float>
      packed_positions_;  // x, y, z, 0 per vertex, relative to the fixed point (m): distort()'s, for normals()
};

}  // namespace organsim::multibeam
