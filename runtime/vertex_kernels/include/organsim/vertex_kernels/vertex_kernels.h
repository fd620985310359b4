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

namespace organsim::vertex_kernels {

inline constexpr std::uint32_t kMaxBeams = 16;  ///< = kMaxTools (static_assert in multibeam.cpp)
/// Values per beam element in the record the distortion reads (element-major),
/// each HALF the beam's displacement u (m) or rotation θ (rad), so that the
/// kernel evaluates u + θ × q + ½ θ × (θ × q) = 2 (u/2 + a × (q + a × q)),
/// a = θ/2, with two cross products and no scaling:
///  0–11  u(ξ)/2 = c0 + c1 ξ + c2 ξ² + c3 ξ³, three components each (c0 at 0–2, c1 at 3–5, …);
/// 12–17  θ(ξ)/2 = r0 + r1 ξ (r0 at 12–14, r1 at 15–17);
/// 18–29  the knot terms into the next element: with s = ξ − 1, the next
///        element's values minus this element's continued past its end,
///        u/2: s·k1 + s²·k2 + s³·k3 (k1 at 18–20, k2 at 21–23, k3 at 24–26),
///        θ/2: s·k4 (27–29); zero for the last element. The constant terms
///        are zero because u and θ are continuous at the knots.
inline constexpr std::uint32_t kPolynomialCoefficients = 18;
inline constexpr std::uint32_t kCoefficients = 30;
inline constexpr std::size_t kPadding = 8;  ///< = organ::Organ::kPadding: vertex arrays are padded
inline constexpr std::size_t kChunk = 8;    ///< vertices per chunk (one register of floats)
/// A chunk's elements in 16 bits: its lowest element (the low kElementBits
/// bits) and how many knots its vertices cross beyond it (the top two: 0, 1,
/// or 2 for two or more).
inline constexpr std::uint32_t kElementBits = 14;
inline constexpr std::uint32_t kMaxStations = 1u << kElementBits;

/// Fills values 18–29 of each of `stations` records from the polynomials
/// (values 0–17), which must be continuous at the knots.
void add_knot_terms(float* records, std::uint32_t stations) noexcept;

/// A tool's beam axis as the kernels see it (single precision): a vertex at
/// offset p from the fixed point lies at τ = clamp(p · to_elements, 0,
/// stations) along the beam, counted in elements, in element ⌊τ⌋ (the last
/// for τ = stations), and τ · element_step is the point of the axis beside it.
struct BeamAxis {
  float to_elements[3];   ///< axis × stations / length (1/m)
  float element_step[3];  ///< axis × length / stations (m)
};

/// One active tool's beam as the distortion reads it.
struct BeamLanes {
  BeamAxis axis;
  const float* weights;                 ///< per vertex (padded): attenuation × influence share
  const std::uint16_t* chunk_elements;  ///< per chunk: its elements, packed (build_weights)
  const float* coefficients;            ///< stations × kCoefficients, element-major
};

struct DistortionJob {
  const float* offset[3];  ///< rest position − fixed point per coordinate (m, padded)
  const double* rest[3];   ///< rest positions per coordinate (m, padded)
  std::uint32_t stations;  ///< beam elements per beam
  std::uint32_t beams;     ///< active tools
  BeamLanes beam[kMaxBeams];
  double* positions;  ///< out: xyz per vertex (m), interleaved
  float* packed;      ///< out: x, y, z, 0 per vertex relative to the fixed point (m)
};

/// What depends on a tool's contact but not on its displacement, per vertex:
/// rebuilt when contacts change.
struct WeightBeam {
  double point[3];  ///< action point (m)
  double share;     ///< 1 / members of the tool's group (1 without the influence rule)
  std::uint32_t group;
  BeamAxis axis;
  float* weights;                 ///< out: per vertex (padded)
  std::uint16_t* chunk_elements;  ///< out: per chunk of kChunk vertices, the elements they lie in, packed
};

struct WeightJob {
  const double* rest[3];       ///< rest positions per coordinate (m, padded)
  const float* offset[3];      ///< rest position − fixed point per coordinate (m, padded)
  std::uint32_t stations;      ///< beam elements per beam
  std::size_t vertex_count;    ///< vertices (the padding is left out of the chunks' elements)
  double attenuation_rate;     ///< β (1/m)
  std::uint32_t groups;        ///< influence groups; ≤ 1 means every weight f is 1
  const double* group_points;  ///< 3 per group (m)
  const double* inverse;       ///< L⁻¹, column-major, groups × groups
  std::size_t inverse_stride;  ///< its leading dimension
  std::uint32_t beams;
  WeightBeam beam[kMaxBeams];
};

struct NormalsJob {
  const std::uint32_t* row_offsets;  ///< organ::Organ::ring_row_offsets()
  const std::uint32_t* rows;         ///< organ::Organ::ring_rows()
  std::size_t vertex_count;
  const double* positions;  ///< xyz per vertex (m)
  double* normals;          ///< out: unit xyz per vertex
};

struct PackedNormalsJob {
  const std::uint32_t* row_offsets;  ///< organ::Organ::ring_row_offsets()
  const std::uint32_t* rows;         ///< organ::Organ::ring_rows()
  const float* packed;               ///< x, y, z, 0 per vertex (m, any origin), vertex_count + kPadding of them
  double* normals;                   ///< out: unit xyz per vertex
};

/// One instruction set's kernels. Each processes vertices [first, last),
/// allocates nothing, and may run on several threads for disjoint ranges;
/// bounds other than vertex counts are multiples of kChunk.
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

}  // namespace organsim::vertex_kernels
