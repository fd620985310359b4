// The multi-beam model's per-vertex kernels (distortion, its weights, vertex
// normals) behind a plain-data interface, so that kernels.cpp can be compiled
// once per instruction set and the widest one the CPU runs is picked at run
// time.
//
// Why separate objects rather than GCC's target_clones: inside a clone GCC
// assembles vector constants and scalar operands lane by lane and cannot use
// the target's masked loads, which left the portable build 10–30 % behind a
// -march=native one. Each kernels.cpp object is compiled like native code for
// its level. Nothing it defines is shared with the rest of the program (its
// functions live in a namespace named after the level and it uses no
// templates or inline functions from other headers), so the linker cannot
// substitute one level's copy of an inline function for another's.
#pragma once

#include <cstddef>
#include <cstdint>

namespace organsim::multibeam::kernels {

inline constexpr std::uint32_t kMaxBeams = 16;      ///< = kMaxTools (static_assert in multibeam.cpp)
inline constexpr std::uint32_t kCoefficients = 18;  ///< per element: u(ξ) cubic (12), θ(ξ) linear (6)
inline constexpr std::size_t kPadding = 8;          ///< = BeamOrgan::kPadding: vertex arrays are padded

/// One active tool's beam as the distortion reads it (single precision, m).
struct BeamLanes {
  float axis[3];               ///< beam x axis (world, unit)
  float length;                ///< m
  float inverse_length;        ///< 1/m (rounded from the double quotient)
  const float* weights;        ///< per vertex (padded): attenuation × influence share
  const float* coefficients;   ///< stations × kCoefficients, element-major
};

struct DistortionJob {
  const float* offset[3];  ///< rest position − fixed point per coordinate (m, padded)
  const double* rest[3];   ///< rest positions per coordinate (m, padded)
  std::uint32_t stations;  ///< beam elements per beam
  std::uint32_t beams;     ///< active tools
  BeamLanes beam[kMaxBeams];
  double* positions;       ///< out: xyz per vertex (m), interleaved
  float* packed;           ///< out: x, y, z, 0 per vertex relative to the fixed point (m)
};

struct WeightBeam {
  double point[3];   ///< action point (m)
  double share;      ///< 1 / members of the tool's group (1 without the influence rule)
  std::uint32_t group;
  float* weights;    ///< out: per vertex (padded)
};

struct WeightJob {
  const double* rest[3];       ///< rest positions per coordinate (m, padded)
  double attenuation_rate;     ///< β (1/m)
  std::uint32_t groups;        ///< influence groups; ≤ 1 means every weight f is 1
  const double* group_points;  ///< 3 per group (m)
  const double* inverse;       ///< L⁻¹, column-major, groups × groups
  std::size_t inverse_stride;  ///< its leading dimension
  std::uint32_t beams;
  WeightBeam beam[kMaxBeams];
};

struct NormalsJob {
  const std::uint32_t* row_offsets;  ///< BeamOrgan::ring_row_offsets()
  const std::uint32_t* rows;         ///< BeamOrgan::ring_rows()
  std::size_t vertex_count;
  const double* positions;           ///< xyz per vertex (m)
  double* normals;                   ///< out: unit xyz per vertex
};

struct PackedNormalsJob {
  const std::uint32_t* row_offsets;  ///< BeamOrgan::ring_row_offsets()
  const std::uint32_t* rows;         ///< BeamOrgan::ring_rows()
  const float* packed;               ///< x, y, z, 0 per vertex (m, any origin), vertex_count + kPadding of them
  double* normals;                   ///< out: unit xyz per vertex
};

/// One instruction set's kernels. Each processes vertices [first, last),
/// allocates nothing, and may run on several threads for disjoint ranges.
struct KernelSet {
  const char* level;  ///< "x86-64-v4", "x86-64-v3", "x86-64" (baseline), or "native"
  void (*build_weights)(const WeightJob& job, std::size_t first, std::size_t last) noexcept;
  void (*distort)(const DistortionJob& job, std::size_t first, std::size_t last) noexcept;
  void (*normals)(const NormalsJob& job, std::size_t first, std::size_t last) noexcept;
  void (*packed_normals)(const PackedNormalsJob& job, std::size_t first, std::size_t last) noexcept;
};

/// The widest set this CPU runs, chosen on the first call (call it once
/// before real-time use; later calls only read).
const KernelSet& selected() noexcept;

/// Every compiled set this CPU runs, widest first (set[0] is selected()'s).
struct RunnableSets {
  KernelSet set[3];
  std::size_t count;
};
RunnableSets runnable() noexcept;

}  // namespace organsim::multibeam::kernels
