#include "organsim/multibeam/multibeam.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "organsim/model/beam_frame.h"
#include "vector_math.h"

namespace organsim::multibeam {
namespace {

Eigen::Vector3d vec(const std::array<double, 3>& p) { return {p[0], p[1], p[2]}; }

// Vertices are distorted in blocks so that per-tool distances and weights live
// in small stack arrays and the inner loops run over contiguous vertices.
constexpr std::size_t kBlock = 128;
static_assert(kLanes == BeamOrgan::kPadding && kBlock % kLanes == 0);

}  // namespace

MultiBeam::MultiBeam(const BeamOrgan& organ, const MultiBeamOptions& options) : organ_(organ), options_(options) {
  if (options_.max_tools == 0 || options_.max_tools > kMaxTools)
    throw std::invalid_argument("max_tools must be between 1 and 16");
  if (!(options_.snap_distance >= 0.0) || !(options_.merge_distance >= 0.0) || !(options_.min_beam_length > 0.0))
    throw std::invalid_argument("snap, merge and minimum beam distances must be non-negative (m)");
  const std::uint32_t stations = organ_.stations();
  tools_.resize(options_.max_tools);
  solvers_.reserve(options_.max_tools);
  for (std::uint32_t i = 0; i < options_.max_tools; ++i) solvers_.emplace_back(stations);
  sections_.resize(stations);
  coefficient_data_.assign(static_cast<std::size_t>(options_.max_tools) * kCoefficients * stations, 0.0);
  vertex_stride_ = organ_.vertex_count() + BeamOrgan::kPadding;
  vertex_weights_.assign(static_cast<std::size_t>(options_.max_tools) * vertex_stride_, 0.0);
}

Status MultiBeam::attach(std::uint32_t tool, const Eigen::Vector3d& point) noexcept {
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
  const std::uint32_t stations = organ_.stations();
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
  const Status status = solvers_[tool].build(sections_.data(), stations, length, organ_.elasticity(), options_.beam);
  if (status != Status::ok) return status;

  beam.action = action;
  beam.length = length;
  beam.frame.col(0) = x;
  beam.frame.col(1) = y;
  beam.frame.col(2) = z;
  beam.stiffness = beam.frame * solvers_[tool].tip_stiffness() * beam.frame.transpose();
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

Status MultiBeam::force(std::uint32_t tool, const Eigen::Vector3d& tip_displacement,
                        Eigen::Vector3d& force_on_tool) const noexcept {
  force_on_tool.setZero();
  if (tool >= options_.max_tools) return Status::too_many_tools;
  if (!tools_[tool].attached) return Status::no_contact;
  if (!tip_displacement.allFinite()) return Status::not_finite;
  force_on_tool.noalias() = -tools_[tool].stiffness * tip_displacement;
  return Status::ok;
}

Status MultiBeam::prepare(const Eigen::Vector3d* tip_displacements) noexcept {
  active_count_ = 0;
  const std::uint32_t stations = organ_.stations();
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
      float* c = coefficients(slot, e);
      for (int k = 0; k < 3; ++k) {
        c[k] = static_cast<float>(u_a[k]);
        c[3 + k] = static_cast<float>(c1[k]);
        c[6 + k] = static_cast<float>(c2[k]);
        c[9 + k] = static_cast<float>(c3[k]);
        c[12 + k] = static_cast<float>(theta_a[k]);
        c[15 + k] = static_cast<float>(r1[k]);
      }
      u_a = u_b;
      theta_a = theta_b;
    }
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

ORGANSIM_SIMD_KERNEL void MultiBeam::build_vertex_weights(std::size_t first, std::size_t last) noexcept {
  const double* rx = organ_.rest_x();
  const double* ry = organ_.rest_y();
  const double* rz = organ_.rest_z();
  const double rate = organ_.attenuation_rate();
  const bool influence = options_.merge == MergeRule::influence;
  const std::uint32_t groups = influence_.count();

  for (std::size_t begin = first; begin < last; begin += kBlock) {
    const std::size_t n = std::min(kBlock, last - begin);
    const double* x = rx + begin;
    const double* y = ry + begin;
    const double* z = rz + begin;
    alignas(64) double weight[kMaxTools][kBlock];
    if (influence && groups > 1) {
      // f(p) = L⁻¹ l(p) / ‖L⁻¹ l(p)‖₁ per vertex, with l(p) the group distances.
      alignas(64) double distance[kMaxTools][kBlock];
      for (std::uint32_t g = 0; g < groups; ++g) {
        const Eigen::Vector3d& p = influence_.point(g);
        for (std::size_t v = 0; v < n; ++v) {
          const double dx = x[v] - p[0], dy = y[v] - p[1], dz = z[v] - p[2];
          distance[g][v] = std::sqrt(dx * dx + dy * dy + dz * dz);
        }
      }
      const auto& inverse = influence_.inverse_distances();
      alignas(64) double norm[kBlock];
      for (std::size_t v = 0; v < n; ++v) norm[v] = 0.0;
      for (std::uint32_t i = 0; i < groups; ++i) {
        for (std::size_t v = 0; v < n; ++v) weight[i][v] = 0.0;
        for (std::uint32_t j = 0; j < groups; ++j) {
          const double m = inverse(i, j);
          for (std::size_t v = 0; v < n; ++v) weight[i][v] += m * distance[j][v];
        }
        for (std::size_t v = 0; v < n; ++v) norm[v] += std::abs(weight[i][v]);
      }
      for (std::size_t v = 0; v < n; ++v) norm[v] = norm[v] > 0.0 ? 1.0 / norm[v] : 0.0;
      for (std::uint32_t i = 0; i < groups; ++i)
        for (std::size_t v = 0; v < n; ++v) weight[i][v] *= norm[v];
    } else {
      for (std::size_t v = 0; v < n; ++v) weight[0][v] = 1.0;
    }

    for (std::uint32_t slot = 0; slot < active_count_; ++slot) {
      const double share = influence ? group_share_[slot] : 1.0;
      const double* w = weight[influence ? active_group_[slot] : 0];
      const double px = active_point_[slot][0], py = active_point_[slot][1], pz = active_point_[slot][2];
      float* factor = vertex_weight(slot) + begin;
      for (std::size_t v = 0; v < n; ++v) {
        const double dx = x[v] - px, dy = y[v] - py, dz = z[v] - pz;
        factor[v] = static_cast<float>(exp_nonpositive(-rate * std::sqrt(dx * dx + dy * dy + dz * dz)) * share * w[v]);
      }
    }
  }
}

ORGANSIM_SIMD_KERNEL void MultiBeam::distort(std::size_t first, std::size_t last, model::Point3* positions) noexcept {
  if (vertex_weights_stale_) build_vertex_weights(first, last);
  distorted_.store(true, std::memory_order_relaxed);
  const LaneIntegers last_element = splat_integer(static_cast<std::int32_t>(organ_.stations()) - 1);
  const Lanes scale = splat(static_cast<float>(organ_.stations()));

  // Single precision: the displacements (millimetres) come out to about 10⁻⁷
  // of themselves plus a few nanometres, far below what a surface mesh or a
  // screen resolves, and eight lanes fit where four doubles would.
  for (std::size_t begin = first; begin < last; begin += kBlock) {
    const std::size_t count = std::min(kBlock, last - begin);
    const std::size_t chunks = (count + kLanes - 1) / kLanes;  // the vertex arrays are padded
    const float* x = organ_.offset_x() + begin;
    const float* y = organ_.offset_y() + begin;
    const float* z = organ_.offset_z() + begin;
    alignas(32) float out_x[kBlock] = {}, out_y[kBlock] = {}, out_z[kBlock] = {};

    for (std::uint32_t slot = 0; slot < active_count_; ++slot) {
      const ToolBeam& beam = tools_[active_tool_[slot]];
      // Scalars broadcast once here: GCC assembles a scalar operand of a
      // vector operation lane by lane in the SIMD clones of this function.
      const Lanes ax = splat(static_cast<float>(beam.frame(0, 0))), ay = splat(static_cast<float>(beam.frame(1, 0))),
                  az = splat(static_cast<float>(beam.frame(2, 0)));
      const Lanes length = splat(static_cast<float>(beam.length)),
                  inverse_length = splat(static_cast<float>(1.0 / beam.length));
      const float* factor = vertex_weight(slot) + begin;
      for (std::size_t chunk = 0; chunk < chunks; ++chunk) {
        // The vertex's place along the beam t in [0, 1], its element and local
        // coordinate ξ, and its offset from the axis q = x − b(t), b(t) = fixed
        // + t L axis: recomputed (a few flops) rather than stored, so that a
        // frame reads one weight per vertex and tool from memory.
        const std::size_t v = chunk * kLanes;
        const Lanes fx = load_lanes(x + v), fy = load_lanes(y + v), fz = load_lanes(z + v);
        Lanes t = (fx * ax + fy * ay + fz * az) * inverse_length;
        t = t < 0.0f ? splat(0.0f) : t;
        t = t > 1.0f ? splat(1.0f) : t;
        const Lanes tau = t * scale;
        LaneIntegers element = __builtin_convertvector(tau, LaneIntegers);
        element = element > last_element ? last_element : element;
        const Lanes xi = tau - __builtin_convertvector(element, Lanes);
        const Lanes along = t * length;
        const Lanes qx = fx - along * ax, qy = fy - along * ay, qz = fz - along * az;

        const Lanes w = load_lanes(factor + v);
        // Always inlined: out of line it would be compiled for the baseline ISA
        // whatever the SIMD clone of this function (vector_math.h).
        auto accumulate = [&](auto c) __attribute__((always_inline)) {  // c(k): coefficient k of each lane's element
          const Lanes ux = ((c(9) * xi + c(6)) * xi + c(3)) * xi + c(0);
          const Lanes uy = ((c(10) * xi + c(7)) * xi + c(4)) * xi + c(1);
          const Lanes uz = ((c(11) * xi + c(8)) * xi + c(5)) * xi + c(2);
          const Lanes tx = c(12) + xi * c(15), ty = c(13) + xi * c(16), tz = c(14) + xi * c(17);
          const Lanes rx1 = ty * qz - tz * qy, ry1 = tz * qx - tx * qz, rz1 = tx * qy - ty * qx;
          const Lanes rx2 = ty * rz1 - tz * ry1, ry2 = tz * rx1 - tx * rz1, rz2 = tx * ry1 - ty * rx1;
          store_lanes(out_x + v, load_lanes(out_x + v) + w * (ux + rx1 + 0.5f * rx2));
          store_lanes(out_y + v, load_lanes(out_y + v) + w * (uy + ry1 + 0.5f * ry2));
          store_lanes(out_z + v, load_lanes(out_z + v) + w * (uz + rz1 + 0.5f * rz2));
        };
        // The lanes' coefficients: vertices are numbered in Morton order, so a
        // chunk mostly lies in one element (72 % of the chunks on the 100k-vertex
        // benchmark sphere), else mostly in two (24 %). One element's
        // coefficients are broadcast, several elements' blended lane by lane
        // (gathers are several times slower).
        const std::int32_t first_lane = element[0];
        if (all_equal(element, first_lane)) {
          const float* only = coefficients(slot, static_cast<std::uint32_t>(first_lane));
          accumulate([&](int k) { return splat(only[k]); });
          continue;
        }
        const std::int32_t lowest = horizontal_min(element), highest = horizontal_max(element);
        const float* low = coefficients(slot, static_cast<std::uint32_t>(lowest));
        if (highest == lowest + 1) {
          const LaneIntegers in_low = element == splat_integer(lowest);
          const float* high = low + kCoefficients;
          accumulate([&](int k) { return in_low ? splat(low[k]) : splat(high[k]); });
        } else {
          accumulate([&](int k) {
            Lanes value = splat(low[k]);
            for (std::int32_t e = 1; e <= highest - lowest; ++e)
              value = element == splat_integer(lowest + e) ? splat(low[e * kCoefficients + k]) : value;
            return value;
          });
        }
      }
    }
    const double* rest_x = organ_.rest_x() + begin;
    const double* rest_y = organ_.rest_y() + begin;
    const double* rest_z = organ_.rest_z() + begin;
    for (std::size_t v = 0; v < count; ++v)
      positions[begin + v] = {rest_x[v] + out_x[v], rest_y[v] + out_y[v], rest_z[v] + out_z[v]};
  }
}

Eigen::Vector3d MultiBeam::displacement_at(const Eigen::Vector3d& rest) const noexcept {
  const bool influence = options_.merge == MergeRule::influence;
  double group_weight[kMaxTools];
  std::fill(group_weight, group_weight + kMaxTools, 1.0);
  if (influence && influence_.count() > 1) influence_.weights(rest, group_weight);
  const Eigen::Vector3d offset = rest - organ_.fixed_point();
  const std::uint32_t stations = organ_.stations();
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
    for (int k = 0; k < 3; ++k) {
      u[k] = ((c[9 + k] * xi + c[6 + k]) * xi + c[3 + k]) * xi + c[k];
      theta[k] = c[12 + k] + xi * c[15 + k];
    }
    const Eigen::Vector3d rotated = theta.cross(q);
    const double weight = std::exp(-organ_.attenuation_rate() * (rest - active_point_[slot]).norm()) *
                          (influence ? group_share_[slot] * group_weight[active_group_[slot]] : 1.0);
    total += weight * (u + rotated + 0.5 * theta.cross(rotated));
  }
  return total;
}

void MultiBeam::normals(std::size_t first, std::size_t last, const model::Point3* positions, model::Point3* normals) const noexcept {
  compute_vertex_normals(organ_, positions, normals, first, last);
}

Status MultiBeam::deform(const Eigen::Vector3d* tip_displacements, model::Point3* positions, model::Point3* normals_out,
                         std::size_t capacity) noexcept {
  const std::size_t n = organ_.vertex_count();
  if (capacity < n) return Status::buffer_too_small;
  const Status status = prepare(tip_displacements);
  if (status != Status::ok) return status;
  distort(0, n, positions);
  normals(0, n, positions, normals_out);
  return Status::ok;
}

}  // namespace organsim::multibeam
