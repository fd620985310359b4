// Byte layout of the `.organ` format, version 1 (docs/model-format.md is the
// normative description; keep the two in step).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace organsim::model::format {

static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__, "the .organ reader and writer assume a little-endian host");

// PNG-style magic: a non-ASCII first byte and CR LF / SUB catch text-mode transfers.
inline constexpr std::uint8_t kMagic[8] = {0x89, 'O', 'R', 'G', 'N', '\r', '\n', 0x1A};
inline constexpr std::uint32_t kByteOrderMark = 0x0A0B0C0Du;
inline constexpr std::uint32_t kByteOrderMarkSwapped = 0x0D0C0B0Au;
inline constexpr std::uint8_t kRealBytes = 8;   // IEEE-754 binary64
inline constexpr std::uint8_t kIndexBytes = 4;  // uint32

inline constexpr std::size_t kHeaderBytes = 64;
inline constexpr std::size_t kTableEntryBytes = 32;
inline constexpr std::size_t kPayloadAlignment = 8;
inline constexpr std::uint32_t kMaxSections = 64;

// Header field offsets.
inline constexpr std::size_t kOffMagic = 0;
inline constexpr std::size_t kOffVersionMajor = 8;
inline constexpr std::size_t kOffVersionMinor = 10;
inline constexpr std::size_t kOffByteOrder = 12;
inline constexpr std::size_t kOffRealBytes = 16;
inline constexpr std::size_t kOffIndexBytes = 17;
inline constexpr std::size_t kOffSectionCount = 20;
inline constexpr std::size_t kOffFileBytes = 24;
inline constexpr std::size_t kOffTableChecksum = 32;
inline constexpr std::size_t kOffFileChecksum = 40;    // of bytes [kHeaderBytes, file end)
inline constexpr std::size_t kOffHeaderChecksum = 48;  // of bytes [0, kOffHeaderChecksum)

// Table entry field offsets.
inline constexpr std::size_t kEntryTag = 0;
inline constexpr std::size_t kEntryChecksum = 8;
inline constexpr std::size_t kEntryOffset = 16;
inline constexpr std::size_t kEntrySize = 24;

// Limits that keep a hostile file from making the reader allocate absurdly.
inline constexpr std::uint32_t kMaxStationsPerBeam = 4096;
inline constexpr std::uint32_t kMaxMetadataEntries = 4096;
inline constexpr std::uint32_t kMaxMetadataKeyBytes = 256;
inline constexpr std::uint32_t kMaxMetadataValueBytes = 65536;
inline constexpr std::uint32_t kMaterialFieldsV1 = 5;
/// Format 1.1 added the beam and spring stiffness scales (1 when absent).
inline constexpr std::uint32_t kMaterialFieldsV1_1 = 7;
inline constexpr std::uint32_t kBeamFieldsV1 = 7;
/// Format 1.2's site compliance: reals per vertex (a symmetric 3×3 matrix),
/// and the most points a depth curve (or, format 1.6, a pull curve) may hold.
inline constexpr std::uint32_t kSiteFieldsV1_2 = 6;
inline constexpr std::uint64_t kMaxDepthCurvePoints = 256;
/// Format 1.3's site curvature: reals per vertex (κ₁, κ₂).
inline constexpr std::uint32_t kCurvatureFieldsV1_3 = 2;
/// Format 1.4's meshing record: reals (tet size, clamp radius, clamp cell size).
inline constexpr std::uint32_t kMeshingFieldsV1_4 = 3;
/// Format 1.5's supports: reals per surface vertex (kind, foundation modulus).
inline constexpr std::uint32_t kSupportFieldsV1_5 = 2;
/// Format 1.6's pull curve: reals per point (distance, softening).
inline constexpr std::uint32_t kPullFieldsV1_6 = 2;
/// Format 1.7's site compliance on the supports: reals per vertex (as SITE's).
inline constexpr std::uint32_t kSupportedSiteFieldsV1_7 = 6;
/// Format 1.8's depth curve on the supports: reals per point (depth, factor).
inline constexpr std::uint32_t kSupportedCurveFieldsV1_8 = 2;

enum class Section {
  Metadata,
  SurfaceVertices,
  SurfaceTriangles,
  SurfaceTexcoords,
  VolumeVertices,
  Tetrahedra,
  FixedPoints,
  Material,
  BeamTables,
  SiteCompliance,
  SiteCurvature,
  Meshing,
  Supports,
  PullCurve,
  SupportedSiteCompliance,
  SupportedDepthCurve
};

struct SectionDescription {
  Section id;
  char tag[5];
  const char* what;
  bool required;
};

// Also the order in which the writer emits sections.
inline constexpr SectionDescription kSections[] = {
    {Section::Metadata, "META", "metadata", true},
    {Section::SurfaceVertices, "SVRT", "surface vertices", true},
    {Section::SurfaceTriangles, "STRI", "surface triangles", true},
    {Section::SurfaceTexcoords, "SUVC", "surface texture coordinates", false},
    {Section::VolumeVertices, "TVRT", "tetrahedron vertices", false},
    {Section::Tetrahedra, "TETS", "tetrahedra", false},
    {Section::FixedPoints, "FIXP", "fixed points", true},
    {Section::Material, "MATL", "material", true},
    {Section::BeamTables, "BEAM", "beam tables", false},
    {Section::SiteCompliance, "SITE", "site compliance", false},
    {Section::SiteCurvature, "CURV", "site curvature", false},
    {Section::Meshing, "MESH", "meshing", false},
    {Section::Supports, "SUPP", "supports", false},
    {Section::PullCurve, "PULL", "pull curve", false},
    {Section::SupportedSiteCompliance, "SSUP", "site compliance on the supports", false},
    {Section::SupportedDepthCurve, "SCRV", "depth curve on the supports", false},
};

inline const SectionDescription& describe(Section id) { return kSections[static_cast<std::size_t>(id)]; }

/// "section 'TETS' (tetrahedra)" — the prefix of every section-specific message.
inline std::string section_label(Section id) {
  const SectionDescription& d = describe(id);
  return std::string("section '") + d.tag + "' (" + d.what + ")";
}

}  // namespace organsim::model::format
