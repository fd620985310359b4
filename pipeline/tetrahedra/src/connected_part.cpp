#include "organsim/tetrahedra/connected_part.h"

#include "tetrahedron_faces.h"

#include <algorithm>
#include <array>
#include <cstdint>
#include <limits>
#include <unordered_map>
#include <vector>

namespace organsim::pipeline {
namespace {

// The part each tetrahedron belongs to (union-find over shared faces), 0..parts-1 in order of first appearance.
std::vector<std::uint32_t> face_connected_parts(const std::vector<model::Tetrahedron>& tets, std::uint32_t& parts) {
  std::vector<std::uint32_t> parent(tets.size());
  for (std::uint32_t i = 0; i < tets.size(); ++i) parent[i] = i;
  auto root = [&](std::uint32_t i) {
    while (parent[i] != i) i = parent[i] = parent[parent[i]];
    return i;
  };
  std::unordered_map<std::uint64_t, std::uint32_t> first_user;
  for (std::uint32_t i = 0; i < tets.size(); ++i)
    for (const auto& f : kFaces) {
      const auto [at, inserted] = first_user.emplace(face_key(tets[i][f[0]], tets[i][f[1]], tets[i][f[2]]), i);
      if (!inserted) parent[root(i)] = root(at->second);
    }
  std::vector<std::uint32_t> part(tets.size());
  std::unordered_map<std::uint32_t, std::uint32_t> numbered;
  for (std::uint32_t i = 0; i < tets.size(); ++i)
    part[i] = numbered.emplace(root(i), static_cast<std::uint32_t>(numbered.size())).first->second;
  parts = static_cast<std::uint32_t>(numbered.size());
  return part;
}

}  // namespace

ConnectedPartReport keep_largest_connected_part(geometry::TetrahedralMesh& mesh) {
  ConnectedPartReport report;
  std::uint32_t parts = 0;
  const std::vector<std::uint32_t> part = face_connected_parts(mesh.tetrahedra, parts);
  std::vector<std::size_t> size(parts, 0);
  for (std::uint32_t p : part) ++size[p];
  const auto largest = static_cast<std::uint32_t>(std::max_element(size.begin(), size.end()) - size.begin());

  std::size_t kept = 0;
  for (std::size_t i = 0; i < mesh.tetrahedra.size(); ++i)
    if (part[i] == largest) mesh.tetrahedra[kept++] = mesh.tetrahedra[i];
  report.tetrahedra_dropped = mesh.tetrahedra.size() - kept;
  mesh.tetrahedra.resize(kept);

  constexpr std::uint32_t kUnused = std::numeric_limits<std::uint32_t>::max();
  std::vector<std::uint32_t> new_index(mesh.vertices.size(), kUnused);
  for (const model::Tetrahedron& t : mesh.tetrahedra)
    for (std::uint32_t v : t) new_index[v] = 0;
  std::uint32_t next = 0;
  for (std::size_t v = 0; v < mesh.vertices.size(); ++v)
    if (new_index[v] != kUnused) {
      new_index[v] = next;
      mesh.vertices[next++] = mesh.vertices[v];
    }
  report.vertices_dropped = mesh.vertices.size() - next;
  mesh.vertices.resize(next);
  for (model::Tetrahedron& t : mesh.tetrahedra)
    for (std::uint32_t& v : t) v = new_index[v];
  return report;
}

}  // namespace organsim::pipeline
