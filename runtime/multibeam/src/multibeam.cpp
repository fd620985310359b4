#include "organsim/multibeam/multibeam.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "organsim/model/beam_frame.h"
#include "organsim/vertex_kernels/vertex_kernels.h"

// force() runs in the 1 kHz loop for every tool: in the portable build it is
// compiled for AVX2/FMA too and picked when the program loads (an ifunc), which
// saves about a fifth of its 2–3 ns (multibeam_bench BM_ForcePerTool).
#if defined(__GNUC__) && !defined(__clang__) && defined(__x86_64__) && !defined(__AVX2__)
#define ORGANSIM_FORCE_CLONES __attribute__((target_clones("arch=x86-64-v3", "default")))
#else
#define ORGANSIM_FORCE_CLONES
#endif

namespace organsim::multibeam {
namespace {

Eigen::Vector3d vec(const std::array<double, 3>& p) { return {p[0], p[1], p[2]}; }

vertex_kernels::BeamAxis beam_axis(const ToolBeam& tool, std::uint32_t stations) noexcept {
  vertex_kernels::BeamAxis axis;
  for (int k = 0; k < 3; ++k) {
    axis.to_elements[k] = static_cast<float>(tool.frame(k, 0) * stations / tool.length);
    axis.element_step[k] = static_cast<float>(tool.frame(k, 0) * tool.length / stations);
  }
  return axis;
}

static_assert(vertex_kernels::kMaxBeams == kMaxTools && vertex_kernels::kPadding == organ::Organ::kPadding);
static_assert(sizeof(model::Point3) == 3 * sizeof(double));  // the kernels see xyz-interleaved arrays

/// The organ's beam tables' stations, or a one-line refusal without them.
std::uint32_t stations_of(const organ::Organ& organ) {
  if (!organ.has_beam_tables())
    throw std::invalid_argument(
        "the model has no beam tables (baked with --no-beam-tables): bake it again without "
        "that option to run the multi-beam model; every other model runs on it");
  return organ.model().beams.stations_per_beam;
}

}  // namespace

bool parse_merge_rule(std::string_view name, MergeRule& rule) noexcept {
  if (name == "influence")
    rule = MergeRule::influence;
  else if (name == "sum")
    rule = MergeRule::sum;
  else
    return false;
  return true;
}

bool parse_beam_theory(std::string_view name, BeamTheory& theory) noexcept {
  if (name == "euler-bernoulli")
    theory = BeamTheory::euler_bernoulli;
  else if (name == "timoshenko")
    theory = BeamTheory::timoshenko;
  else
    return false;
  return true;
}

MultiBeam::MultiBeam(const organ::Organ& organ, const MultiBeamOptions& options)
    : organ_(organ),
      options_(options),
      stations_(stations_of(organ)),
      elasticity_(
          BeamElasticity::from(organ.model().material.young_modulus * organ.model().material.beam_stiffness_scale,
                               organ.model().material.poisson_ratio)),
      attenuation_rate_(organ.model().material.attenuation_beta * std::log(organ.model().material.attenuation_alpha)) {
  if (options_.max_tools == 0 || options_.max_tools > kMaxTools)
    throw std::invalid_argument("max_tools must be between 1 and 16");
  if (!(options_.snap_distance >= 0.0) || !(options_.merge_distance >= 0.0) || !(options_.min_beam_length > 0.0))
    throw std::invalid_argument("snap, merge and minimum beam distances must be non-negative (m)");
  vertex_kernels::selected();  // picks the instruction set now, not in the first real-time call
  const std::uint32_t stations = stations_;
  if (stations > vertex_kernels::kMaxStations)
    throw std::invalid_argument("the multi-beam model takes at most " + std::to_string(vertex_kernels::kMaxStations) +
                                " stations per beam");
  tools_.resize(options_.max_tools);
  solvers_.reserve(options_.max_tools);
  for (std::uint32_t i = 0; i < options_.max_tools; ++i) solvers_.emplace_back(stations);
  sections_.resize(stations);
  foundation_.resize(stations);
  if (options_.supports && organ_.model().supports.vertices.size() == organ_.vertex_count()) {
    // Each supported vertex's foundation: its modulus on a third of its triangles' area.
    const model::OrganModel& m = organ_.model();
    std::vector<double> area(m.surface_vertices.size(), 0.0);
    for (const model::Triangle& t : m.surface_triangles) {
      const double third = (vec(m.surface_vertices[t[1]]) - vec(m.surface_vertices[t[0]]))
                               .cross(vec(m.surface_vertices[t[2]]) - vec(m.surface_vertices[t[0]]))
                               .norm() /
                           6.0;
      for (std::uint32_t v : t) area[v] += third;
    }
    for (std::uint32_t v = 0; v < m.surface_vertices.size(); ++v)
      if (m.supports.kind(v) != model::Supports::Kind::kFree)
        supported_.push_back(
            {v, m.supports.modulus(v) * area[v], m.supports.kind(v) == model::Supports::Kind::kContact});
  }
  coefficient_data_.assign(static_cast<std::size_t>(options_.max_tools) * kCoefficients * stations, 0.0);
  const std::size_t n = organ_.vertex_count();
  vertex_stride_ = n + organ::Organ::kPadding;
  for (int k = 0; k < 3; ++k) {
    const double* rest = k == 0 ? organ_.rest_x() : k == 1 ? organ_.rest_y() : organ_.rest_z();
    offset_[k].resize(vertex_stride_);
    for (std::size_t i = 0; i < vertex_stride_; ++i)
      offset_[k][i] = static_cast<float>(rest[i] - organ_.fixed_point()[k]);
  }
  vertex_weights_.assign(static_cast<std::size_t>(options_.max_tools) * vertex_stride_, 0.0);
  static_assert(vertex_kernels::kChunk == organ::Organ::kPadding);
  chunk_stride_ = vertex_stride_ / vertex_kernels::kChunk;
  chunk_elements_.assign(static_cast<std::size_t>(options_.max_tools) * chunk_stride_, 0);
  packed_positions_.assign(4 * vertex_stride_, 0.0f);
  for (std::size_t v = 0; v < organ_.vertex_count(); ++v) {  // the rest shape until the first distort()
    packed_positions_[4 * v] = offset_x()[v];
    packed_positions_[4 * v + 1] = offset_y()[v];
    packed_positions_[4 * v + 2] = offset_z()[v];
  }
}

Status MultiBeam::attach(std::uint32_t tool, const Eigen::Vector3d& point, double tip_radius) noexcept {
  if (tool >= options_.max_tools) return Status::too_many_tools;
  ToolBeam& beam = tools_[tool];
  if (beam.attached) ++contact_generation_;
  beam.attached = false;
  if (!point.allFinite()) return Status::not_finite;
  const geometry::SurfacePoint action = organ_.surface_tree().closest_point(point);
  if (action.distance > options_.snap_distance) return Status::far_from_organ;

  const Eigen::Vector3d& fixed = organ_.fixed_point();
  const double length = (action.position - fixed).norm();
  model::BeamFrame frame;
  if (!(length >= options_.min_beam_length) ||
      !model::make_beam_frame({fixed[0], fixed[1], fixed[2]},
                              {action.position[0], action.position[1], action.position[2]}, frame))
    return Status::at_fixed_point;
  const Eigen::Vector3d x = vec(frame.x), y = vec(frame.y), z = vec(frame.z);

  // Interpolate the three corner beams' sections. Each corner's section is
  // baked in its own beam frame, so the second moments are carried as world
  // tensors (frame-independent) and the centroid offsets as world vectors, then
  // read back in this beam's frame.
  const model::OrganModel& model = organ_.model();
  const model::Triangle& triangle = model.surface_triangles[action.triangle];
  Eigen::Vector3d corner_y[3], corner_z[3];
  double weight[3];
  for (int k = 0; k < 3; ++k) {
    model::BeamFrame f{};
    weight[k] = model::make_beam_frame({fixed[0], fixed[1], fixed[2]}, model.surface_vertices[triangle[k]], f)
                    ? action.barycentric[k]
                    : 0.0;  // a corner at the fixed point has no section
    corner_y[k] = vec(f.y);
    corner_z[k] = vec(f.z);
    if (weight[k] == 0.0) corner_y[k] = corner_z[k] = Eigen::Vector3d::Zero();
  }
  const double total = weight[0] + weight[1] + weight[2];
  if (!(total > 0.0)) return Status::at_fixed_point;
  const std::uint32_t stations = stations_;
  for (std::uint32_t s = 0; s < stations; ++s) {
    Eigen::Matrix3d tensor = Eigen::Matrix3d::Zero();  // ∫ r rᵀ dA over the section, world
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    double area = 0.0, torsion = 0.0;
    for (int k = 0; k < 3; ++k) {
      if (weight[k] == 0.0) continue;
      const model::BeamSection& c = model.beams.at(triangle[k], s);
      const double w = weight[k] / total;
      const Eigen::Vector3d& cy = corner_y[k];
      const Eigen::Vector3d& cz = corner_z[k];
      tensor += w * (c.i_zz * cy * cy.transpose() + c.i_yy * cz * cz.transpose() +
                     c.i_yz * (cy * cz.transpose() + cz * cy.transpose()));
      centroid += w * (c.centroid_y * cy + c.centroid_z * cz);
      area += w * c.area;
      torsion += w * c.torsion_j;
    }
    model::BeamSection& section = sections_[s];
    section.area = area;
    section.torsion_j = torsion;
    section.i_zz = y.dot(tensor * y);
    section.i_yy = z.dot(tensor * z);
    section.i_yz = y.dot(tensor * z);
    section.centroid_y = y.dot(centroid);
    section.centroid_z = z.dot(centroid);
  }
  // The section of beam node n (n h from the clamp, h = L / stations) is the
  // organ's slice there: it rests on the supports of the surface vertices
  // within h/2 of its plane, a contact along its normal as pressed.
  const double h = length / stations;
  for (std::uint32_t n = 0; n < stations; ++n) foundation_[n].setZero();
  for (const SupportedVertex& s : supported_) {
    const Eigen::Vector3d at = vec(model.surface_vertices[s.vertex]);
    const long node = std::lround((at - fixed).dot(x) / h);
    if (node < 1 || node > static_cast<long>(stations)) continue;
    const Eigen::Vector3d normal = vec(organ_.rest_normals()[s.vertex]);
    const Eigen::Vector3d local(normal.dot(x), normal.dot(y), normal.dot(z));
    foundation_[static_cast<std::size_t>(node - 1)] += s.unilateral
                                                           ? Eigen::Matrix3d(s.stiffness * local * local.transpose())
                                                           : Eigen::Matrix3d(s.stiffness * Eigen::Matrix3d::Identity());
  }
  const Status status = solvers_[tool].build(sections_.data(), stations, length, elasticity_, options_.beam,
                                             supported_.empty() ? nullptr : foundation_.data());
  if (status != Status::ok) return status;

  beam.action = action;
  beam.length = length;
  beam.frame.col(0) = x;
  beam.frame.col(1) = y;
  beam.frame.col(2) = z;
  beam.matched = options_.match_sites && beam.law.set(organ_, action, tip_radius, options_.supports);
  beam.stiffness = beam.matched ? beam.law.stiffness()
                                : Eigen::Matrix3d(beam.frame * solvers_[tool].tip_stiffness() * beam.frame.transpose());
  beam.attached = true;
  ++contact_generation_;
  return Status::ok;
}

void MultiBeam::detach(std::uint32_t tool) noexcept {
  if (tool < options_.max_tools && tools_[tool].attached) {
    tools_[tool].attached = false;
    ++contact_generation_;
  }
}

ORGANSIM_FORCE_CLONES Status MultiBeam::force(std::uint32_t tool, const Eigen::Vector3d& tip_displacement,
                                              Eigen::Vector3d& force_on_tool) const noexcept {
  const Status status = tool >= options_.max_tools ? Status::too_many_tools
                        : !tools_[tool].attached   ? Status::no_contact
                        // x·0 is 0 for finite x and NaN otherwise: one test for the three components
                        : (tip_displacement * 0.0).sum() != 0.0 ? Status::not_finite
                                                                : Status::ok;
  if (status != Status::ok) {
    force_on_tool.setZero();
    return status;
  }
  const ToolBeam& beam = tools_[tool];
  if (beam.matched)
    force_on_tool = beam.law.force(tip_displacement);
  else
    force_on_tool.noalias() = -(beam.stiffness * tip_displacement);
  return Status::ok;
}

Status MultiBeam::prepare(const Eigen::Vector3d* tip_displacements) noexcept {
  active_count_ = 0;
  const std::uint32_t stations = stations_;
  for (std::uint32_t tool = 0; tool < options_.max_tools; ++tool) {
    if (!tools_[tool].attached) continue;
    if (!tip_displacements[tool].allFinite()) {
      active_count_ = 0;
      return Status::not_finite;
    }
  }
  Eigen::Vector3d group_point[kMaxTools];
  std::uint32_t group_members[kMaxTools] = {};
  std::uint32_t groups = 0;
  for (std::uint32_t tool = 0; tool < options_.max_tools; ++tool) {
    const ToolBeam& beam = tools_[tool];
    if (!beam.attached) continue;
    const std::uint32_t slot = active_count_++;
    active_tool_[slot] = tool;
    active_point_[slot] = beam.action.position;

    // Merging: coinciding action points make the distance matrix singular.
    std::uint32_t group = groups;
    for (std::uint32_t g = 0; g < groups; ++g)
      if ((group_point[g] - beam.action.position).norm() <= options_.merge_distance) {
        group = g;
        break;
      }
    if (group == groups) group_point[groups++] = beam.action.position;
    active_group_[slot] = group;
    ++group_members[group];

    // Nodal displacements and rotations in the world frame, then per element
    // the Hermite cubic of the transverse displacement (slopes θ × x), the
    // linear axial displacement and the linear rotation.
    const ClampedBeam& solver = solvers_[tool];
    const Eigen::Vector3d local_tip = beam.frame.transpose() * tip_displacements[tool];
    const Eigen::Vector3d axis = beam.frame.col(0);
    const double h = beam.length / stations;
    Eigen::Vector3d u_a = Eigen::Vector3d::Zero(), theta_a = Eigen::Vector3d::Zero();
    for (std::uint32_t e = 0; e < stations; ++e) {
      const Eigen::Matrix<double, 6, 1> node = solver.node_response(e + 1) * local_tip;
      const Eigen::Vector3d u_b = beam.frame * node.head<3>();
      const Eigen::Vector3d theta_b = beam.frame * node.tail<3>();
      const Eigen::Vector3d slope_a = h * theta_a.cross(axis), slope_b = h * theta_b.cross(axis);
      const Eigen::Vector3d ut_a = u_a - u_a.dot(axis) * axis, ut_b = u_b - u_b.dot(axis) * axis;
      const Eigen::Vector3d c1 = slope_a + (u_b - u_a).dot(axis) * axis;
      const Eigen::Vector3d c2 = -3.0 * ut_a - 2.0 * slope_a + 3.0 * ut_b - slope_b;
      const Eigen::Vector3d c3 = 2.0 * ut_a + slope_a - 2.0 * ut_b + slope_b;
      const Eigen::Vector3d r1 = theta_b - theta_a;
      float* c = coefficients(slot, e);  // halves (vertex_kernels.h)
      for (int k = 0; k < 3; ++k) {
        c[k] = static_cast<float>(0.5 * u_a[k]);
        c[3 + k] = static_cast<float>(0.5 * c1[k]);
        c[6 + k] = static_cast<float>(0.5 * c2[k]);
        c[9 + k] = static_cast<float>(0.5 * c3[k]);
        c[12 + k] = static_cast<float>(0.5 * theta_a[k]);
        c[15 + k] = static_cast<float>(0.5 * r1[k]);
      }
      u_a = u_b;
      theta_a = theta_b;
    }
    vertex_kernels::add_knot_terms(coefficients(slot, 0), stations);
  }
  for (std::uint32_t slot = 0; slot < active_count_; ++slot)
    group_share_[slot] = 1.0 / group_members[active_group_[slot]];
  if (options_.merge == MergeRule::influence && groups > 0 && !influence_.set_points(group_point, groups)) {
    active_count_ = 0;
    return Status::not_finite;
  }
  // Stale until a distort() has rebuilt it: a prepare() that no distort()
  // followed must not clear the flag.
  vertex_weights_stale_ = (vertex_weights_stale_ && !distorted_.load(std::memory_order_relaxed)) ||
                          prepared_generation_ != contact_generation_;
  distorted_.store(false, std::memory_order_relaxed);
  prepared_generation_ = contact_generation_;
  return Status::ok;
}

void MultiBeam::build_vertex_weights(std::size_t first, std::size_t last) noexcept {
  const bool influence = options_.merge == MergeRule::influence;
  vertex_kernels::WeightJob job;
  job.rest[0] = organ_.rest_x();
  job.rest[1] = organ_.rest_y();
  job.rest[2] = organ_.rest_z();
  job.offset[0] = offset_x();
  job.offset[1] = offset_y();
  job.offset[2] = offset_z();
  job.stations = stations_;
  job.vertex_count = organ_.vertex_count();
  job.attenuation_rate = attenuation_rate_;
  job.groups = influence ? influence_.count() : 0;
  double group_points[kMaxTools][3];
  for (std::uint32_t g = 0; g < job.groups; ++g)
    for (int k = 0; k < 3; ++k) group_points[g][k] = influence_.point(g)[k];
  job.group_points = group_points[0];
  job.inverse = influence_.inverse_distances().data();
  job.inverse_stride = static_cast<std::size_t>(influence_.inverse_distances().outerStride());
  job.beams = active_count_;
  for (std::uint32_t slot = 0; slot < active_count_; ++slot) {
    vertex_kernels::WeightBeam& beam = job.beam[slot];
    for (int k = 0; k < 3; ++k) beam.point[k] = active_point_[slot][k];
    beam.share = influence ? group_share_[slot] : 1.0;
    beam.group = influence ? active_group_[slot] : 0;
    beam.axis = beam_axis(tools_[active_tool_[slot]], stations_);
    beam.weights = vertex_weight(slot);
    beam.chunk_elements = chunk_elements(slot);
  }
  vertex_kernels::selected().build_weights(job, first, last);
}

void MultiBeam::distort(std::size_t first, std::size_t last, model::Point3* positions) noexcept {
  if (vertex_weights_stale_) build_vertex_weights(first, last);
  distorted_.store(true, std::memory_order_relaxed);
  static_assert(kCoefficients == vertex_kernels::kCoefficients);
  vertex_kernels::DistortionJob job;
  job.offset[0] = offset_x();
  job.offset[1] = offset_y();
  job.offset[2] = offset_z();
  job.rest[0] = organ_.rest_x();
  job.rest[1] = organ_.rest_y();
  job.rest[2] = organ_.rest_z();
  job.stations = stations_;
  job.beams = active_count_;
  for (std::uint32_t slot = 0; slot < active_count_; ++slot) {
    vertex_kernels::BeamLanes& beam = job.beam[slot];
    beam.axis = beam_axis(tools_[active_tool_[slot]], stations_);
    beam.weights = vertex_weight(slot);
    beam.chunk_elements = chunk_elements(slot);
    beam.coefficients = coefficients(slot, 0);
  }
  job.positions = positions->data();
  job.packed = packed_positions_.data();
  vertex_kernels::selected().distort(job, first, last);
}

Eigen::Vector3d MultiBeam::displacement_at(const Eigen::Vector3d& rest) const noexcept {
  const bool influence = options_.merge == MergeRule::influence;
  double group_weight[kMaxTools];
  std::fill(group_weight, group_weight + kMaxTools, 1.0);
  if (influence && influence_.count() > 1) influence_.weights(rest, group_weight);
  const Eigen::Vector3d offset = rest - organ_.fixed_point();
  const std::uint32_t stations = stations_;
  Eigen::Vector3d total = Eigen::Vector3d::Zero();
  for (std::uint32_t slot = 0; slot < active_count_; ++slot) {
    const ToolBeam& beam = tools_[active_tool_[slot]];
    const Eigen::Vector3d axis = beam.frame.col(0);
    const double t = std::clamp(offset.dot(axis) / beam.length, 0.0, 1.0);
    const double tau = t * stations;
    const std::uint32_t element = std::min(static_cast<std::uint32_t>(tau), stations - 1);
    const double xi = tau - element;
    const Eigen::Vector3d q = offset - t * beam.length * axis;
    const float* c = coefficients(slot, element);
    Eigen::Vector3d u, theta;
    for (int k = 0; k < 3; ++k) {  // the records hold halves
      u[k] = 2.0 * (((c[9 + k] * xi + c[6 + k]) * xi + c[3 + k]) * xi + c[k]);
      theta[k] = 2.0 * (c[12 + k] + xi * c[15 + k]);
    }
    const Eigen::Vector3d rotated = theta.cross(q);
    const double weight = std::exp(-attenuation_rate_ * (rest - active_point_[slot]).norm()) *
                          (influence ? group_share_[slot] * group_weight[active_group_[slot]] : 1.0);
    total += weight * (u + rotated + 0.5 * theta.cross(rotated));
  }
  return total;
}

void MultiBeam::normals(std::size_t first, std::size_t last, model::Point3* normals) const noexcept {
  if (first >= last) return;
  vertex_kernels::PackedNormalsJob job;
  job.row_offsets = organ_.ring_row_offsets().data();
  job.rows = organ_.ring_rows().data();
  job.packed = packed_positions_.data();
  job.normals = normals->data();
  vertex_kernels::selected().packed_normals(job, first, last);
}

Status MultiBeam::deform(const Eigen::Vector3d* tip_displacements, model::Point3* positions, model::Point3* normals_out,
                         std::size_t capacity) noexcept {
  const std::size_t n = organ_.vertex_count();
  if (capacity < n) return Status::buffer_too_small;
  const Status status = prepare(tip_displacements);
  if (status != Status::ok) return status;
  distort(0, n, positions);
  normals(0, n, normals_out);
  return Status::ok;
}

}  // namespace organsim::multibeam
