#include "organsim/organ/organ.h"

// The per-vertex kernels are shared with the multi-beam model (its distortion).
#include "organsim/vertex_kernels/vertex_kernels.h"
#include "organsim/geometry/model_measures.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <type_traits>
#include <utility>

namespace organsim::organ {
namespace {

// The model with its surface vertices renumbered along the Morton curve;
// file_index[new] = old. A model baked in that order (organsim bake writes it)
// is taken as it is: its 100 MB of beam tables are not copied.
model::OrganModel surface_in_morton_order(model::OrganModel model, std::vector<std::uint32_t>& file_index) {
  const std::size_t n = model.surface_vertices.size();
  file_index = morton_order(model.surface_vertices);
  bool identity = true;
  for (std::size_t i = 0; i < n && identity; ++i) identity = file_index[i] == i;
  if (identity) return model;
  std::vector<std::uint32_t> new_index(n);
  for (std::size_t i = 0; i < n; ++i) new_index[file_index[i]] = static_cast<std::uint32_t>(i);
  // One gather into new storage per array (read through const: a view of
  // the file is read, not copied first).
  auto gathered = [&](const auto& values, std::size_t per_vertex) {
    std::vector<std::remove_cv_t<std::remove_reference_t<decltype(*values.data())>>> out;
    if (values.size() != n * per_vertex) return out;
    out.reserve(values.size());
    for (std::size_t i = 0; i < n; ++i) {
      const auto* from = values.data() + file_index[i] * per_vertex;
      out.insert(out.end(), from, from + per_vertex);
    }
    return out;
  };
  if (model.surface_vertices.size() == n) model.surface_vertices = gathered(model.surface_vertices, 1);
  if (model.surface_texcoords.size() == n) model.surface_texcoords = gathered(model.surface_texcoords, 1);
  const std::size_t stations = model.beams.stations_per_beam;
  if (stations > 0 && model.beams.sections.size() == n * stations)
    model.beams.sections = model::SectionTable(gathered(std::as_const(model.beams.sections), stations));
  if (model.sites.compliance.size() == n) model.sites.compliance = gathered(model.sites.compliance, 1);
  if (model.sites.curvature.size() == n) model.sites.curvature = gathered(model.sites.curvature, 1);
  if (model.sites.supported.size() == n) model.sites.supported = gathered(model.sites.supported, 1);
  if (model.supports.vertices.size() == n) model.supports.vertices = gathered(model.supports.vertices, 1);
  for (model::Triangle& t : model.surface_triangles)
    for (std::uint32_t& v : t) v = new_index[v];
  return model;
}

}  // namespace

std::vector<std::uint32_t> morton_order(const std::vector<model::Point3>& vertices) {
  const std::size_t n = vertices.size();
  Eigen::AlignedBox3d box;
  for (const model::Point3& p : vertices) box.extend(Eigen::Vector3d(p[0], p[1], p[2]));
  const Eigen::Vector3d extent = n > 0 ? Eigen::Vector3d(box.sizes().cwiseMax(1e-12)) : Eigen::Vector3d::Ones();
  std::vector<std::pair<std::uint64_t, std::uint32_t>> keys(n);
  for (std::size_t v = 0; v < n; ++v) {
    std::uint64_t key = 0;
    for (int k = 0; k < 3; ++k) {
      const double unit = (vertices[v][k] - box.min()[k]) / extent[k];
      const auto cell = static_cast<std::uint64_t>(std::clamp(unit, 0.0, 1.0) * ((1u << 21) - 1));
      for (int bit = 0; bit < 21; ++bit) key |= ((cell >> bit) & 1u) << (3 * bit + k);
    }
    keys[v] = {key, static_cast<std::uint32_t>(v)};
  }
  std::sort(keys.begin(), keys.end());
  std::vector<std::uint32_t> order(n);
  for (std::size_t i = 0; i < n; ++i) order[i] = keys[i].second;
  return order;
}

void renumber_in_morton_order(std::vector<model::Point3>& vertices, std::vector<model::Triangle>& triangles) {
  const std::vector<std::uint32_t> order = morton_order(vertices);
  std::vector<std::uint32_t> new_index(order.size());
  std::vector<model::Point3> ordered(order.size());
  for (std::size_t i = 0; i < order.size(); ++i) {
    new_index[order[i]] = static_cast<std::uint32_t>(i);
    ordered[i] = vertices[order[i]];
  }
  vertices = std::move(ordered);
  for (model::Triangle& t : triangles)
    for (std::uint32_t& v : t) v = new_index[v];
}

Organ::Organ(model::OrganModel model)
    : model_(surface_in_morton_order(std::move(model), file_index_)),
      fixed_point_(model_.fixed_points.empty() ? Eigen::Vector3d::Zero()
                                               : Eigen::Vector3d(model_.fixed_points[0][0], model_.fixed_points[0][1],
                                                                 model_.fixed_points[0][2])),
      tree_(model_.surface_vertices, model_.surface_triangles) {
  if (model_.fixed_points.empty()) throw std::invalid_argument("the model has no fixed point");
  if (model_.surface_vertices.empty()) throw std::invalid_argument("the model has no surface");

  const std::size_t n = model_.surface_vertices.size();
  // Each triangle (v, a, b), rotated to start at v, contributes the edge a → b
  // of v's ring; a closed manifold ring chains these edges into one cycle.
  std::vector<std::uint32_t> edge_offsets(n + 1, 0);
  for (const model::Triangle& t : model_.surface_triangles)
    for (std::uint32_t v : t) ++edge_offsets[v + 1];
  for (std::size_t v = 0; v < n; ++v) edge_offsets[v + 1] += edge_offsets[v];
  std::vector<std::array<std::uint32_t, 2>> edges(edge_offsets[n]);
  std::vector<std::uint32_t> fill(edge_offsets.begin(), edge_offsets.end() - 1);
  for (const model::Triangle& t : model_.surface_triangles)
    for (int k = 0; k < 3; ++k) edges[fill[t[k]]++] = {t[(k + 1) % 3], t[(k + 2) % 3]};

  // Each vertex's cyclic sequence (see ring_rows()), as vertex indices.
  std::vector<std::uint32_t> sequence_offsets(n + 1, 0);
  std::vector<std::uint32_t> sequences;
  sequences.reserve(edges.size() * 2);
  for (std::size_t v = 0; v < n; ++v) {
    const std::uint32_t first = edge_offsets[v], count = edge_offsets[v + 1] - first;
    std::vector<std::uint32_t> cycle;
    if (count >= 3) {
      cycle.push_back(edges[first][0]);
      std::uint32_t current = edges[first][1];
      while (cycle.size() <= count && current != cycle.front()) {
        std::uint32_t next = UINT32_MAX, matches = 0;
        for (std::uint32_t e = first; e < first + count; ++e)
          if (edges[e][0] == current) {
            next = edges[e][1];
            ++matches;
          }
        if (matches != 1) break;
        cycle.push_back(current);
        current = next;
      }
      if (current != cycle.front() || cycle.size() != count) cycle.clear();
    }
    if (!cycle.empty()) {
      sequences.insert(sequences.end(), cycle.begin(), cycle.end());
    } else {  // a border or non-manifold vertex: each triangle on its own, v between them
      for (std::uint32_t e = first; e < first + count; ++e)
        sequences.insert(sequences.end(), {edges[e][0], edges[e][1], static_cast<std::uint32_t>(v)});
    }
    sequence_offsets[v + 1] = static_cast<std::uint32_t>(sequences.size());
  }

  // Entries are 32-bit byte offsets of 16-byte points.
  if (n > static_cast<std::size_t>(UINT32_MAX / 16))
    throw std::invalid_argument("the surface has more vertices than the runtime handles (268 million)");
  const std::size_t groups = (n + kPadding - 1) / kPadding;
  ring_row_offsets_.assign(groups + 1, 0);
  ring_rows_.clear();
  for (std::size_t g = 0; g < groups; ++g) {
    auto vertex_of_lane = [&](std::size_t lane) { return std::min(g * kPadding + lane, n - 1); };
    std::uint32_t longest = 1;  // at least one row: the kernels read the last row first
    for (std::size_t lane = 0; lane < kPadding; ++lane) {
      const std::size_t v = vertex_of_lane(lane);
      longest = std::max(longest, sequence_offsets[v + 1] - sequence_offsets[v]);
    }
    const std::size_t row0 = ring_rows_.size();
    ring_rows_.resize(row0 + kPadding * longest);
    for (std::size_t lane = 0; lane < kPadding; ++lane) {
      const std::size_t v = vertex_of_lane(lane);
      const std::uint32_t begin = sequence_offsets[v], length = sequence_offsets[v + 1] - begin;
      for (std::uint32_t r = 0; r < longest; ++r) {
        const std::size_t neighbour = length == 0 ? v : sequences[begin + std::min(r, length - 1)];
        ring_rows_[row0 + kPadding * r + lane] = static_cast<std::uint32_t>(16 * neighbour);
      }
    }
    ring_row_offsets_[g + 1] = static_cast<std::uint32_t>(ring_rows_.size() / kPadding);
  }

  for (int k = 0; k < 3; ++k) {
    rest_[k].resize(n + kPadding);
    for (std::size_t i = 0; i < n + kPadding; ++i) rest_[k][i] = model_.surface_vertices[std::min(i, n - 1)][k];
  }
  vertex_kernels::selected();  // picks the instruction set now, not in the first real-time call
  rest_normals_.resize(n);
  compute_vertex_normals(*this, model_.surface_vertices.data(), rest_normals_.data(), 0, n);
}

Eigen::Vector3d Organ::rest_normal_at(const geometry::SurfacePoint& at) const noexcept {
  const model::Triangle& t = model_.surface_triangles[at.triangle];
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) {
    const model::Point3& n = rest_normals_[t[k]];
    normal += at.barycentric[k] * Eigen::Vector3d(n[0], n[1], n[2]);
  }
  return normal.norm() > 0.0 ? Eigen::Vector3d(normal.normalized()) : geometry::triangle_normal(model_, at.triangle);
}

void compute_vertex_normals(const Organ& organ, const model::Point3* positions, model::Point3* normals,
                            std::size_t first, std::size_t last) noexcept {
  if (first >= last) return;
  vertex_kernels::NormalsJob job;
  job.row_offsets = organ.ring_row_offsets().data();
  job.rows = organ.ring_rows().data();
  job.vertex_count = organ.vertex_count();
  job.positions = positions->data();
  job.normals = normals->data();
  vertex_kernels::selected().normals(job, first, last);
}

const char* vertex_kernel_level() noexcept { return vertex_kernels::selected().level; }

}  // namespace organsim::organ
