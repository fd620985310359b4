// The in-memory form of an `.organ` model file: everything the pipeline bakes
// and the runtime loads. Plain arrays of plain structs so that the runtime can
// map them (e.g. with Eigen::Map) without copying.
//
// Units are SI throughout: metres, kilograms, seconds, newtons, pascals.
// Coordinates are in the patient frame named by `ModelProvenance::coordinate_frame`
// ("LPS" as in ITK/DICOM, or "RAS"), in metres.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

namespace organsim::model {

using Point3 = std::array<double, 3>;              ///< x, y, z in metres
using TexCoord = std::array<double, 2>;            ///< u, v in [0, 1]
using Triangle = std::array<std::uint32_t, 3>;     ///< counter-clockwise seen from outside
using Tetrahedron = std::array<std::uint32_t, 4>;  ///< positive orientation: (b-a)·((c-a)×(d-a)) > 0

/// Material parameters. Defaults and their sources are documented in docs/model-format.md.
struct Material {
  double young_modulus = 0.0;      ///< E, Pa
  double poisson_ratio = 0.0;      ///< ν, dimensionless, in (-1, 0.5)
  double density = 0.0;            ///< ρ, kg/m³
  double attenuation_alpha = 0.0;  ///< α of s' = s / α^(β d), dimensionless, > 0
  double attenuation_beta = 0.0;   ///< β of s' = s / α^(β d), 1/m, >= 0
  /// The fast models' stiffness relative to E (> 0; 1 unless `organsim
  /// calibrate` fitted them to a FEM reference): the multi-beam model's beams
  /// use E × beam_stiffness_scale, the mass-spring model's springs
  /// E × spring_stiffness_scale × the mean edge length. The FEM models use E.
  double beam_stiffness_scale = 1.0;
  double spring_stiffness_scale = 1.0;

  bool operator==(const Material& other) const;
};

/// Healthy-liver material: the defaults of `organsim bake` (values and sources
/// in docs/model-format.md).
Material liver_default_material();

/// Cross-section properties of the organ at one beam station, in the beam's
/// local frame (see beam_frame.h): x along the beam from the fixed point to the
/// surface vertex, y and z spanning the section plane.
struct BeamSection {
  double area = 0.0;        ///< A, m²
  double i_yy = 0.0;        ///< ∫ z² dA about the section centroid, m⁴
  double i_zz = 0.0;        ///< ∫ y² dA about the section centroid, m⁴
  double i_yz = 0.0;        ///< ∫ y z dA about the section centroid, m⁴
  double torsion_j = 0.0;   ///< torsion constant J, m⁴
  double centroid_y = 0.0;  ///< section centroid minus axis point, local y, m
  double centroid_z = 0.0;  ///< section centroid minus axis point, local z, m

  bool operator==(const BeamSection& other) const;
};

/// The beam sections of a model: owned, or a read-only view into the mapped
/// model file they were loaded from (read_organ_model_file: a 100k-vertex
/// model's 112 MB are then never copied; the file stays mapped while any table
/// refers to it). Reads like a std::vector. The first change through a
/// non-const accessor copies a view into owned storage, so read through a
/// const reference: a non-const one copies on its first use.
class SectionTable {
 public:
  SectionTable() = default;
  explicit SectionTable(std::size_t count, const BeamSection& value = {}) : owned_(count, value) { sync(); }
  explicit SectionTable(std::vector<BeamSection> sections) : owned_(std::move(sections)) { sync(); }
  /// A view of `count` sections at `data`, valid while `keep_alive` is held.
  static SectionTable view(const BeamSection* data, std::size_t count, std::shared_ptr<const void> keep_alive);

  SectionTable(const SectionTable& other);
  SectionTable& operator=(const SectionTable& other);
  SectionTable(SectionTable&& other) noexcept;
  SectionTable& operator=(SectionTable&& other) noexcept;

  std::size_t size() const noexcept { return size_; }
  bool empty() const noexcept { return size_ == 0; }
  bool is_view() const noexcept { return mapping_ != nullptr; }
  const BeamSection* data() const noexcept { return data_; }
  const BeamSection& operator[](std::size_t i) const noexcept { return data_[i]; }
  const BeamSection* begin() const noexcept { return data_; }
  const BeamSection* end() const noexcept { return data_ + size_; }
  const BeamSection& front() const noexcept { return data_[0]; }
  const BeamSection& back() const noexcept { return data_[size_ - 1]; }

  BeamSection* data() { return owned().data(); }
  BeamSection& operator[](std::size_t i) { return owned()[i]; }
  BeamSection* begin() { return owned().data(); }
  BeamSection* end() { return owned().data() + size_; }
  void resize(std::size_t count) {
    owned().resize(count);
    sync();
  }
  void reserve(std::size_t count) {
    owned().reserve(count);
    sync();
  }
  void assign(std::size_t count, const BeamSection& value) {
    owned().assign(count, value);
    sync();
  }
  void push_back(const BeamSection& value) {
    owned().push_back(value);
    sync();
  }
  void pop_back() {
    owned().pop_back();
    sync();
  }
  /// The owned storage (a view is copied into it first), for bulk writes; call
  /// sync() after changing its size.
  std::vector<BeamSection>& owned();
  void sync() noexcept {
    data_ = owned_.data();
    size_ = owned_.size();
  }

  bool operator==(const SectionTable& other) const;

 private:
  std::vector<BeamSection> owned_;
  const BeamSection* data_ = nullptr;
  std::size_t size_ = 0;
  std::shared_ptr<const void> mapping_;  // set for a view
};

/// Beam tables: for each surface vertex v, `stations_per_beam` sections of the
/// organ along the beam from the (first) fixed point to v. Station s lies at the
/// beam parameter t = (s + 0.5) / stations_per_beam, the midpoint of element s
/// when the beam is cut into `stations_per_beam` equal elements.
struct BeamTables {
  std::uint32_t stations_per_beam = 0;  ///< 0 when the model has no beam tables
  SectionTable sections;                ///< (surface vertices × stations_per_beam), vertex-major

  const BeamSection& at(std::size_t vertex, std::size_t station) const {
    return sections[vertex * stations_per_beam + station];
  }
  bool empty() const { return stations_per_beam == 0; }
  bool operator==(const BeamTables& other) const;
};

/// The FEM reference's contact law at every surface site, for the fast models
/// to give its force (docs/matching.md). A tool of radius R pressing at a site
/// meets two compliances in series: the organ's, as a body held at its clamp
/// (how far the surface patch under the tool moves per newton: a lobe
/// bending, the clamp near or far), and the local indentation of the patch by
/// a rigid end of radius R (Boussinesq's and Mindlin's punch), which depends
/// on R alone. The file keeps the first, so that any tip radius gets its law;
/// the second is added at run time (organsim/organ/site_law.h).
struct SiteCompliance {
  double young_modulus = 0.0;  ///< E of the reference material, Pa (> 0)
  double poisson_ratio = 0.0;  ///< ν of the reference material, in (0, 0.5)
  /// Per surface vertex, the organ's compliance under a tool there without
  /// the tip's local indentation: a symmetric positive semi-definite 3×3
  /// matrix (m/N, model frame) stored as xx, yy, zz, xy, xz, yz. Empty: the
  /// model has no site data.
  std::vector<std::array<double, 6>> compliance;
  /// Per surface vertex, the same compliance with the organ also resting on
  /// its supports (format 1.7; docs/supports.md): every contact pressed,
  /// holding along the surface's normal, and every attachment holding, as a
  /// press finds them. Empty: the model has no supports, or was baked
  /// before they were.
  std::vector<std::array<double, 6>> supported;
  /// The reference's force relative to the linear law, as pairs (depth m,
  /// factor > 0), depths increasing from 0: F(d) = g(|d|) F_linear(d), g
  /// linear between the pairs and held beyond the last. Empty: g = 1.
  /// Fitted by `organsim calibrate` for a tip of radius `curve_tip_radius`.
  std::vector<std::array<double, 2>> depth_curve;
  double curve_tip_radius = 0.0;  ///< m; 0 when there is no depth curve
  /// The depth curve of presses that meet the organ resting on its supports
  /// (format 1.8), as `depth_curve`: fitted by `organsim calibrate --supports
  /// baked` for a tip of radius `supported_curve_tip_radius`, read wherever
  /// the law meets the organ on its supports (organ::SiteLaw::set). The
  /// organ pressed against what lies behind it deepens differently from one
  /// bending about its clamp, so each holding has its own curve. Empty:
  /// presses on the supports read `depth_curve`.
  std::vector<std::array<double, 2>> supported_depth_curve;
  double supported_curve_tip_radius = 0.0;  ///< m; 0 when there is no such curve
  /// How much softer a patch held in a grasper's jaws is than a bonded punch
  /// of the tip's radius, as pairs (distance u in m the jaws have drawn the
  /// patch since they closed, softening s > 0), distances increasing from 0:
  /// the held patch's compliance is C_organ + s(u) C_punch, s linear between
  /// the pairs and held beyond the last (format 1.6). Empty: s = 1. Fitted by
  /// `organsim calibrate --pull` for a tip of radius `pull_tip_radius`.
  std::vector<std::array<double, 2>> pull_curve;
  double pull_tip_radius = 0.0;  ///< m; 0 when there is no pull curve
  /// The largest softening a file may hold.
  static constexpr double kMaxSoftening = 1e3;
  /// Per surface vertex, the surface's principal curvatures κ₁ ≥ κ₂ (1/m),
  /// positive where the surface curves away from its outward normal (a
  /// sphere's outside is convex: +1/radius): fitted at bake time over the
  /// tip's neighbourhood (format 1.3), so that the tip's Hertz contact is that
  /// of two curved bodies. Empty: the law takes the surface as flat at the
  /// tip's scale (1.2 files).
  std::vector<std::array<double, 2>> curvature;
  /// 1/m: the largest curvature a file may hold (a radius of 10 µm, far
  /// below any CT's voxel).
  static constexpr double kMaxCurvature = 1e5;
  bool empty() const { return compliance.empty(); }
  bool operator==(const SiteCompliance& other) const;
};

/// How the tetrahedra were meshed (format 1.4), so that a program that meshes
/// the organ again (calibrate's refined reference) meshes it as the bake did.
/// All zero when the file does not say (an older file, or tetrahedra made
/// elsewhere).
struct Meshing {
  double tet_size = 0.0;         ///< m: the mesher's cell and facet size away from refinements; 0: unknown
  double clamp_radius = 0.0;     ///< m: the ball around fixed_points[0] that is meshed finer; 0: none
  double clamp_cell_size = 0.0;  ///< m: the cell size within that ball; 0: not refined

  bool empty() const { return !(tet_size > 0.0); }
  bool operator==(const Meshing& other) const;
};

/// Where the organ rests on, or is attached to, what surrounds it in the body
/// (format 1.5): found by the bake in the patient's CT (docs/supports.md).
/// Empty: the organ is held by its clamp alone (older files, `--supports none`).
struct Supports {
  enum class Kind { kFree = 0, kContact = 1, kAttachment = 2 };
  /// Per surface vertex: {kind, foundation modulus k (Pa/m: the pressure
  /// per metre the support gives when the surface moves into it)}. A
  /// contact pushes back only when pressed (unilateral); an attachment
  /// holds both ways (bilateral). k is 0 exactly where the kind is free.
  std::vector<std::array<double, 2>> vertices;
  static constexpr double kMaxModulus = 1e12;  ///< Pa/m: steel on a 0.2 mm layer; far above any tissue's

  bool empty() const { return vertices.empty(); }
  Kind kind(std::size_t vertex) const { return static_cast<Kind>(static_cast<int>(vertices[vertex][0])); }
  double modulus(std::size_t vertex) const { return vertices[vertex][1]; }
  bool operator==(const Supports& other) const { return vertices == other.vertices; }
};

/// Where the model came from. Never holds patient-identifying information: the
/// input image is identified only by the SHA-256 of its voxel values.
struct ModelProvenance {
  std::string coordinate_frame = "LPS";           ///< "LPS" or "RAS"
  std::string program_version;                    ///< organsim version that wrote the model
  std::string input_sha256;                       ///< 64 lowercase hex digits, or empty for synthetic models
  std::map<std::string, std::string> parameters;  ///< every parameter the model was made with

  bool operator==(const ModelProvenance& other) const;
};

/// A complete organ model.
struct OrganModel {
  ModelProvenance provenance;
  std::vector<Point3> surface_vertices;     ///< (Ns × 3) rest positions of the simulation surface, m
  std::vector<Triangle> surface_triangles;  ///< (Mt × 3) indices into surface_vertices, closed and outward
  std::vector<TexCoord> surface_texcoords;  ///< (Ns × 2) or empty
  std::vector<Point3> volume_vertices;      ///< (Nv × 3) tetrahedral mesh nodes, m (may be empty)
  std::vector<Tetrahedron> tetrahedra;      ///< (Nt × 4) indices into volume_vertices
  std::vector<Point3> fixed_points;         ///< (Nf × 3), Nf >= 1; beams are clamped at fixed_points[0]
  Material material;
  BeamTables beams;
  SiteCompliance sites;  ///< per-site contact law of the FEM reference (format 1.2; curvatures 1.3), or empty
  Meshing meshing;       ///< how the tetrahedra were meshed (format 1.4), or empty
  Supports supports;     ///< what the organ rests on and is attached to (format 1.5), or empty

  bool operator==(const OrganModel& other) const;
};

/// Checks every invariant the file format promises (finite values, index
/// ranges, consistent counts, physical parameter ranges). Returns an empty
/// string when the model is valid, otherwise one sentence naming the part and
/// the problem.
std::string validate_organ_model(const OrganModel& model);

}  // namespace organsim::model
