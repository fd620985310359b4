// How the tetrahedra stage names a tetrahedron's faces and edges, shared by
// sliver removal and the connected-part filter.
#pragma once

#include <algorithm>
#include <array>
#include <cstdint>

namespace organsim::pipeline {

constexpr int kFaces[4][3] = {{1, 2, 3}, {0, 2, 3}, {0, 1, 3}, {0, 1, 2}};  // face opposite corner i

/// A face as its sorted vertex indices packed into one key (indices below
/// 2^21: two million tetrahedron vertices).
inline std::uint64_t face_key(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
  std::array<std::uint64_t, 3> v{a, b, c};
  std::sort(v.begin(), v.end());
  return (v[0] << 42) | (v[1] << 21) | v[2];
}
inline std::uint64_t edge_key(std::uint32_t a, std::uint32_t b) {
  return a < b ? (std::uint64_t{a} << 32) | b : (std::uint64_t{b} << 32) | a;
}

}  // namespace organsim::pipeline
