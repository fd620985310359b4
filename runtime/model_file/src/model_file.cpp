#include "organsim/model/model_file.h"

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <initializer_list>
#include <memory>
#include <optional>
#include <stdexcept>

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include "format_layout.h"
#include "model_validation.h"
#include "organsim/io/atomic_file.h"

namespace organsim::model {
namespace {

using format::Section;

constexpr const char* kDamagedAdvice = "the file is damaged: copy it again or re-bake it with 'organsim bake'";

/// XXH3-64: a checksum fast enough (tens of GB/s) to verify a 100 MB model on
/// every load; it detects damage, it does not authenticate.
std::uint64_t checksum(const std::uint8_t* data, std::size_t size) { return XXH3_64bits(data, size); }

template <typename T>
T load(const std::uint8_t* p) {
  T value;
  std::memcpy(&value, p, sizeof(T));
  return value;
}

template <typename T>
void store(std::vector<std::uint8_t>& out, std::size_t at, T value) {
  std::memcpy(out.data() + at, &value, sizeof(T));
}

// ---------------------------------------------------------------- writing --

class PayloadWriter {
 public:
  template <typename T>
  void put(T value) {
    const std::size_t at = bytes_.size();
    bytes_.resize(at + sizeof(T));
    std::memcpy(bytes_.data() + at, &value, sizeof(T));
  }
  void put_string(const std::string& s) {
    put<std::uint32_t>(static_cast<std::uint32_t>(s.size()));
    bytes_.insert(bytes_.end(), s.begin(), s.end());
  }
  template <typename T, std::size_t N>
  void put_array(const std::vector<std::array<T, N>>& items) {
    put<std::uint64_t>(items.size());
    for (const auto& item : items)
      for (T c : item) put<T>(c);
  }
  std::vector<std::uint8_t> take() { return std::move(bytes_); }

 private:
  std::vector<std::uint8_t> bytes_;
};

std::map<std::string, std::string> metadata_entries(const ModelProvenance& p) {
  std::map<std::string, std::string> entries;
  entries["units"] = "SI";
  entries["coordinate_frame"] = p.coordinate_frame;
  entries["program_version"] = p.program_version;
  entries["input_sha256"] = p.input_sha256;
  for (const auto& [name, value] : p.parameters) entries["param." + name] = value;
  return entries;
}

std::vector<std::uint8_t> encode_section(Section id, const OrganModel& m) {
  PayloadWriter w;
  switch (id) {
    case Section::Metadata: {
      const auto entries = metadata_entries(m.provenance);
      w.put<std::uint32_t>(static_cast<std::uint32_t>(entries.size()));
      for (const auto& [key, value] : entries) {
        w.put_string(key);
        w.put_string(value);
      }
      break;
    }
    case Section::SurfaceVertices: w.put_array(m.surface_vertices); break;
    case Section::SurfaceTriangles: w.put_array(m.surface_triangles); break;
    case Section::SurfaceTexcoords: w.put_array(m.surface_texcoords); break;
    case Section::VolumeVertices: w.put_array(m.volume_vertices); break;
    case Section::Tetrahedra: w.put_array(m.tetrahedra); break;
    case Section::FixedPoints: w.put_array(m.fixed_points); break;
    case Section::Material: {
      const Material& mat = m.material;
      w.put<std::uint32_t>(format::kMaterialFieldsV1_1);
      w.put<std::uint32_t>(0);
      for (double v : {mat.young_modulus, mat.poisson_ratio, mat.density, mat.attenuation_alpha, mat.attenuation_beta,
                       mat.beam_stiffness_scale, mat.spring_stiffness_scale})
        w.put<double>(v);
      break;
    }
    case Section::BeamTables: {
      w.put<std::uint32_t>(m.beams.stations_per_beam);
      w.put<std::uint32_t>(format::kBeamFieldsV1);
      w.put<std::uint64_t>(m.beams.sections.size() / m.beams.stations_per_beam);
      for (const BeamSection& s : m.beams.sections)
        for (double v : {s.area, s.i_yy, s.i_zz, s.i_yz, s.torsion_j, s.centroid_y, s.centroid_z}) w.put<double>(v);
      break;
    }
    case Section::SiteCompliance: {
      const SiteCompliance& sites = m.sites;
      w.put<std::uint32_t>(format::kSiteFieldsV1_2);
      w.put<std::uint32_t>(0);
      for (double v : {sites.young_modulus, sites.poisson_ratio, sites.curve_tip_radius}) w.put<double>(v);
      w.put_array(sites.depth_curve);
      w.put_array(sites.compliance);
      break;
    }
    case Section::SiteCurvature:
      w.put<std::uint32_t>(format::kCurvatureFieldsV1_3);
      w.put<std::uint32_t>(0);
      w.put_array(m.sites.curvature);
      break;
    case Section::Meshing:
      w.put<std::uint32_t>(format::kMeshingFieldsV1_4);
      w.put<std::uint32_t>(0);
      for (double v : {m.meshing.tet_size, m.meshing.clamp_radius, m.meshing.clamp_cell_size}) w.put<double>(v);
      break;
    case Section::Supports:
      w.put<std::uint32_t>(format::kSupportFieldsV1_5);
      w.put<std::uint32_t>(0);
      w.put_array(m.supports.vertices);
      break;
    case Section::SupportedSiteCompliance:
      w.put<std::uint32_t>(format::kSupportedSiteFieldsV1_7);
      w.put<std::uint32_t>(0);
      w.put_array(m.sites.supported);
      break;
    case Section::PullCurve:
      w.put<std::uint32_t>(format::kPullFieldsV1_6);
      w.put<std::uint32_t>(0);
      w.put<double>(m.sites.pull_tip_radius);
      w.put_array(m.sites.pull_curve);
      break;
    case Section::SupportedDepthCurve:
      w.put<std::uint32_t>(format::kSupportedCurveFieldsV1_8);
      w.put<std::uint32_t>(0);
      w.put<double>(m.sites.supported_curve_tip_radius);
      w.put_array(m.sites.supported_depth_curve);
      break;
  }
  return w.take();
}

bool section_present(Section id, const OrganModel& m) {
  switch (id) {
    case Section::SurfaceTexcoords: return !m.surface_texcoords.empty();
    case Section::VolumeVertices: return !m.volume_vertices.empty();
    case Section::Tetrahedra: return !m.tetrahedra.empty();
    case Section::BeamTables: return !m.beams.empty();
    case Section::SiteCompliance: return !m.sites.empty();
    case Section::SiteCurvature: return !m.sites.curvature.empty();
    case Section::Meshing: return !m.meshing.empty();
    case Section::Supports: return !m.supports.empty();
    case Section::PullCurve: return !m.sites.pull_curve.empty();
    case Section::SupportedSiteCompliance: return !m.sites.supported.empty();
    case Section::SupportedDepthCurve: return !m.sites.supported_depth_curve.empty();
    default: return true;
  }
}

std::size_t align_up(std::size_t n) {
  return (n + format::kPayloadAlignment - 1) / format::kPayloadAlignment * format::kPayloadAlignment;
}

// ---------------------------------------------------------------- reading --

/// Bounds-checked little-endian reads from one section payload.
class PayloadReader {
 public:
  PayloadReader(const std::uint8_t* data, std::size_t size) : data_(data), size_(size) {}

  template <typename T>
  bool get(T& value) {
    if (size_ - at_ < sizeof(T)) return false;
    value = load<T>(data_ + at_);
    at_ += sizeof(T);
    return true;
  }
  bool get_string(std::string& s, std::uint32_t max_bytes) {
    std::uint32_t length = 0;
    if (!get(length) || length > max_bytes || size_ - at_ < length) return false;
    s.assign(reinterpret_cast<const char*>(data_ + at_), length);
    at_ += length;
    return true;
  }
  std::size_t remaining() const { return size_ - at_; }
  const std::uint8_t* here() const { return data_ + at_; }
  void skip(std::size_t n) { at_ += n; }

 private:
  const std::uint8_t* data_;
  std::size_t size_;
  std::size_t at_ = 0;
};

struct TableEntry {
  char tag[5] = {};
  std::uint64_t checksum = 0;
  std::uint64_t offset = 0;
  std::uint64_t size = 0;
};

/// Thrown inside the parser only; turned into ModelReadResult::error.
struct ParseError {
  std::string message;
};

[[noreturn]] void fail(std::string message) { throw ParseError{std::move(message)}; }

[[noreturn]] void fail_section(Section id, const std::string& problem) {
  fail(format::section_label(id) + ": " + problem);
}

// Room for `count` items in memory the kernel may back with 2 MiB pages: a
// 100 MB table then faults in 50 times instead of 25,000.
template <typename T>
void reserve_in_huge_pages(std::vector<T>& items, std::size_t count) {
  items.reserve(count);
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  const auto begin = reinterpret_cast<std::uintptr_t>(items.data());
  const std::uintptr_t first = (begin + kHuge - 1) & ~(kHuge - 1);
  const std::uintptr_t last = (begin + count * sizeof(T)) & ~(kHuge - 1);
  if (last > first) ::madvise(reinterpret_cast<void*>(first), last - first, MADV_HUGEPAGE);
}

template <typename T, std::size_t N>
std::vector<std::array<T, N>> read_array(Section id, const std::uint8_t* data, std::size_t size) {
  PayloadReader r(data, size);
  std::uint64_t count = 0;
  if (!r.get(count))
    fail_section(id, std::string("payload of ") + std::to_string(size) + " bytes is too short for its item count; " +
                         kDamagedAdvice);
  constexpr std::size_t item_bytes = sizeof(T) * N;
  // Compare by division so that an absurd count can neither overflow nor allocate.
  if (count > r.remaining() / item_bytes || count * item_bytes != r.remaining())
    fail_section(id, "item count " + std::to_string(count) + " does not match the payload of " + std::to_string(size) +
                         " bytes (" + std::to_string(item_bytes) + " bytes per item); " + kDamagedAdvice);
  std::vector<std::array<T, N>> items;
  reserve_in_huge_pages(items, static_cast<std::size_t>(count));
  items.resize(static_cast<std::size_t>(count));
  if (count > 0) std::memcpy(items.data(), r.here(), static_cast<std::size_t>(count) * item_bytes);
  return items;
}

void read_metadata(const std::uint8_t* data, std::size_t size, ModelProvenance& p) {
  const Section id = Section::Metadata;
  PayloadReader r(data, size);
  std::uint32_t count = 0;
  if (!r.get(count)) fail_section(id, std::string("payload too short for its entry count; ") + kDamagedAdvice);
  if (count > format::kMaxMetadataEntries)
    fail_section(id, "entry count " + std::to_string(count) + " exceeds the limit of " +
                         std::to_string(format::kMaxMetadataEntries) + "; " + kDamagedAdvice);
  std::string previous_key, key, value, units;
  for (std::uint32_t i = 0; i < count; ++i) {
    if (!r.get_string(key, format::kMaxMetadataKeyBytes) || !r.get_string(value, format::kMaxMetadataValueBytes))
      fail_section(
          id, "entry " + std::to_string(i) + " runs past the payload or exceeds the length limits; " + kDamagedAdvice);
    if (i > 0 && key <= previous_key)
      fail_section(id, "keys are not strictly sorted (duplicate or out-of-order key '" + key + "'); " + kDamagedAdvice);
    previous_key = key;
    if (key == "units")
      units = value;
    else if (key == "coordinate_frame")
      p.coordinate_frame = value;
    else if (key == "program_version")
      p.program_version = value;
    else if (key == "input_sha256")
      p.input_sha256 = value;
    else if (key.rfind("param.", 0) == 0)
      p.parameters[key.substr(6)] = value;
    // Other keys come from newer writers and carry nothing this reader needs.
  }
  if (r.remaining() != 0)
    fail_section(id, std::to_string(r.remaining()) + " unexpected bytes after the last entry; " + kDamagedAdvice);
  if (units != "SI")
    fail_section(id, "units are '" + units + "' but only SI is supported; re-bake the model with organsim");
}

/// A section of a field count, a zero and that many reals, of which the
/// reader knows `targets` and needs the first `required`: fields beyond those
/// known (a newer minor version's) are skipped, and known fields an older
/// file lacks keep their values.
void read_reals(Section id, const std::uint8_t* data, std::size_t size, std::uint32_t required,
                std::initializer_list<double*> targets) {
  PayloadReader r(data, size);
  std::uint32_t fields = 0, reserved = 0;
  if (!r.get(fields) || !r.get(reserved))
    fail_section(id, std::string("payload too short for its field count; ") + kDamagedAdvice);
  if (fields < required || fields > r.remaining() / sizeof(double) || fields * sizeof(double) != r.remaining())
    fail_section(id, "field count " + std::to_string(fields) + " does not match the payload of " +
                         std::to_string(size) + " bytes; " + kDamagedAdvice);
  std::uint32_t f = 0;
  for (double* target : targets)
    if (f++ < fields) r.get(*target);
}

void read_material(const std::uint8_t* data, std::size_t size, Material& mat) {
  read_reals(Section::Material, data, size, format::kMaterialFieldsV1,
             {&mat.young_modulus, &mat.poisson_ratio, &mat.density, &mat.attenuation_alpha, &mat.attenuation_beta,
              &mat.beam_stiffness_scale, &mat.spring_stiffness_scale});
}

void read_sites(const std::uint8_t* data, std::size_t size, SiteCompliance& sites) {
  const Section id = Section::SiteCompliance;
  PayloadReader r(data, size);
  std::uint32_t fields = 0, reserved = 0;
  if (!r.get(fields) || !r.get(reserved) || !r.get(sites.young_modulus) || !r.get(sites.poisson_ratio) ||
      !r.get(sites.curve_tip_radius))
    fail_section(id, std::string("payload too short for its header; ") + kDamagedAdvice);
  if (fields != format::kSiteFieldsV1_2)
    fail_section(id, "field count " + std::to_string(fields) + " is not " + std::to_string(format::kSiteFieldsV1_2) +
                         "; " + kDamagedAdvice);
  std::uint64_t points = 0;
  if (!r.get(points) || points > format::kMaxDepthCurvePoints || points > r.remaining() / (2 * sizeof(double)))
    fail_section(id, "the depth curve's point count is missing or exceeds " +
                         std::to_string(format::kMaxDepthCurvePoints) + " or the payload; " + kDamagedAdvice);
  sites.depth_curve.resize(static_cast<std::size_t>(points));
  for (auto& point : sites.depth_curve) r.get(point[0]), r.get(point[1]);
  std::uint64_t vertices = 0;
  constexpr std::size_t kVertexBytes = format::kSiteFieldsV1_2 * sizeof(double);
  if (!r.get(vertices) || vertices > r.remaining() / kVertexBytes || vertices * kVertexBytes != r.remaining())
    fail_section(
        id, "the vertex count does not match the payload of " + std::to_string(size) + " bytes; " + kDamagedAdvice);
  sites.compliance.resize(static_cast<std::size_t>(vertices));
  if (vertices > 0) std::memcpy(sites.compliance.data(), r.here(), static_cast<std::size_t>(vertices) * kVertexBytes);
}

/// PULL and SCRV: a field count (2), a reserved word, the tip radius the
/// curve was fitted for and its points.
void read_curve(Section id, std::uint32_t fields, const std::uint8_t* data, std::size_t size, double& tip_radius,
                std::vector<std::array<double, 2>>& curve) {
  PayloadReader r(data, size);
  std::uint32_t found = 0, reserved = 0;
  if (!r.get(found) || !r.get(reserved) || !r.get(tip_radius))
    fail_section(id, std::string("payload too short for its header; ") + kDamagedAdvice);
  if (found != fields)
    fail_section(id,
                 "field count " + std::to_string(found) + " is not " + std::to_string(fields) + "; " + kDamagedAdvice);
  curve = read_array<double, 2>(id, r.here(), r.remaining());
  if (curve.size() > format::kMaxDepthCurvePoints)
    fail_section(
        id, "the curve has more than " + std::to_string(format::kMaxDepthCurvePoints) + " points; " + kDamagedAdvice);
}

/// A section of a field count (`fields`), a reserved word and a pair of
/// reals per surface vertex (CURV, SUPP).
std::vector<std::array<double, 2>> read_vertex_pairs(Section id, std::uint32_t fields, const std::uint8_t* data,
                                                     std::size_t size) {
  PayloadReader r(data, size);
  std::uint32_t found = 0, reserved = 0;
  if (!r.get(found) || !r.get(reserved))
    fail_section(id, std::string("payload too short for its header; ") + kDamagedAdvice);
  if (found != fields)
    fail_section(id,
                 "field count " + std::to_string(found) + " is not " + std::to_string(fields) + "; " + kDamagedAdvice);
  return read_array<double, 2>(id, r.here(), r.remaining());
}

/// SSUP: a field count (6), a reserved word and a compliance per surface vertex.
std::vector<std::array<double, 6>> read_supported_sites(const std::uint8_t* data, std::size_t size) {
  const Section id = Section::SupportedSiteCompliance;
  PayloadReader r(data, size);
  std::uint32_t fields = 0, reserved = 0;
  if (!r.get(fields) || !r.get(reserved))
    fail_section(id, std::string("payload too short for its header; ") + kDamagedAdvice);
  if (fields != format::kSupportedSiteFieldsV1_7)
    fail_section(id, "field count " + std::to_string(fields) + " is not " +
                         std::to_string(format::kSupportedSiteFieldsV1_7) + "; " + kDamagedAdvice);
  return read_array<double, 6>(id, r.here(), r.remaining());
}

void read_meshing(const std::uint8_t* data, std::size_t size, Meshing& meshing) {
  read_reals(Section::Meshing, data, size, format::kMeshingFieldsV1_4,
             {&meshing.tet_size, &meshing.clamp_radius, &meshing.clamp_cell_size});
}

// Returns whether every value is plausible (checked chunk by chunk as it is
// copied, while the chunk is in cache).
// `checked`: whether the values are plausible, when the hash pass found out.
bool read_beams(const std::uint8_t* data, std::size_t size, BeamTables& beams,
                const std::shared_ptr<const void>& mapping, std::optional<bool> checked) {
  const Section id = Section::BeamTables;
  PayloadReader r(data, size);
  std::uint32_t stations = 0, fields = 0;
  std::uint64_t vertices = 0;
  if (!r.get(stations) || !r.get(fields) || !r.get(vertices))
    fail_section(id, std::string("payload too short for its header; ") + kDamagedAdvice);
  if (stations == 0 || stations > format::kMaxStationsPerBeam)
    fail_section(id, "stations per beam " + std::to_string(stations) + " is outside 1.." +
                         std::to_string(format::kMaxStationsPerBeam) + "; " + kDamagedAdvice);
  if (fields < format::kBeamFieldsV1 || fields > 64)
    fail_section(id, "field count " + std::to_string(fields) + " is outside " + std::to_string(format::kBeamFieldsV1) +
                         "..64; " + kDamagedAdvice);
  const std::uint64_t row_bytes = std::uint64_t{stations} * fields * sizeof(double);
  if (vertices > r.remaining() / row_bytes || vertices * row_bytes != r.remaining())
    fail_section(id, "vertex count " + std::to_string(vertices) + " with " + std::to_string(stations) +
                         " stations does not match the payload of " + std::to_string(size) + " bytes; " +
                         kDamagedAdvice);
  beams.stations_per_beam = stations;
  const auto count = static_cast<std::size_t>(vertices * stations);
  static_assert(sizeof(BeamSection) == format::kBeamFieldsV1 * sizeof(double));
  if (fields == format::kBeamFieldsV1 && mapping &&
      reinterpret_cast<std::uintptr_t>(r.here()) % alignof(BeamSection) == 0) {
    // The file's layout is BeamSection's: the mapped file itself is the table.
    const auto* sections = reinterpret_cast<const BeamSection*>(r.here());
    beams.sections = SectionTable::view(sections, count, mapping);
    return checked ? *checked : beam_values_plausible(sections, count);
  }
  std::vector<BeamSection>& owned = beams.sections.owned();
  reserve_in_huge_pages(owned, count);
  owned.resize(count);
  beams.sections.sync();
  if (fields == format::kBeamFieldsV1) {
    constexpr std::size_t kChunk = 4096;  // sections: 224 KiB, in cache when checked
    bool plausible = true;
    for (std::size_t first = 0; first < count; first += kChunk) {
      const std::size_t n = std::min(kChunk, count - first);
      std::memcpy(owned.data() + first, r.here() + first * sizeof(BeamSection), n * sizeof(BeamSection));
      if (!checked) plausible &= beam_values_plausible(owned.data() + first, n);
    }
    return checked ? *checked : plausible;
  }
  for (BeamSection& s : owned) {
    double* targets[] = {&s.area, &s.i_yy, &s.i_zz, &s.i_yz, &s.torsion_j, &s.centroid_y, &s.centroid_z};
    for (double* t : targets) r.get(*t);
    r.skip((fields - format::kBeamFieldsV1) * sizeof(double));
  }
  return false;  // not checked here
}

const format::SectionDescription* find_known_section(const char* tag) {
  for (const auto& d : format::kSections)
    if (std::memcmp(d.tag, tag, 4) == 0) return &d;
  return nullptr;
}

std::string printable_tag(const char* tag) {
  std::string s;
  for (int i = 0; i < 4; ++i) {
    const unsigned char c = static_cast<unsigned char>(tag[i]);
    if (c >= 0x20 && c < 0x7f) {
      s += static_cast<char>(c);
    } else {
      char hex[8];
      std::snprintf(hex, sizeof hex, "\\x%02x", c);
      s += hex;
    }
  }
  return s;
}

std::vector<TableEntry> read_table(const std::uint8_t* data, std::uint32_t count) {
  std::vector<TableEntry> table(count);
  for (std::uint32_t i = 0; i < count; ++i) {
    const std::uint8_t* e = data + format::kHeaderBytes + i * format::kTableEntryBytes;
    std::memcpy(table[i].tag, e, 4);
    table[i].checksum = load<std::uint64_t>(e + format::kEntryChecksum);
    table[i].offset = load<std::uint64_t>(e + format::kEntryOffset);
    table[i].size = load<std::uint64_t>(e + format::kEntrySize);
  }
  return table;
}

/// Where a file cut short at `actual` bytes ends, for the truncation message.
std::string describe_cut(const std::uint8_t* data, std::size_t actual, std::uint32_t section_count) {
  const std::size_t table_end = format::kHeaderBytes + std::size_t{section_count} * format::kTableEntryBytes;
  if (section_count > format::kMaxSections || actual < table_end) return "inside the section table";
  std::vector<TableEntry> table = read_table(data, section_count);
  std::sort(table.begin(), table.end(), [](const TableEntry& a, const TableEntry& b) { return a.offset < b.offset; });
  for (const TableEntry& e : table) {
    const auto* known = find_known_section(e.tag);
    const std::string label = known ? format::section_label(known->id) : "section '" + printable_tag(e.tag) + "'";
    if (e.offset >= actual) return "at the start of " + label;
    if (e.size > actual - e.offset) return "inside " + label;
  }
  return "in the padding after the last section";
}

// The beam values of a payload whose layout is BeamSection's (format v1's
// seven fields, aligned), checked piece by piece as the whole-file hash reads
// them; `plausible` is known once the hash has passed their end.
struct BeamValueCheck {
  const std::uint8_t* begin = nullptr;  // the first section; null: nothing to check here
  std::size_t count = 0;
  std::size_t checked = 0;
  bool plausible = true;

  BeamValueCheck(const TableEntry* entry, const std::uint8_t* data) {
    constexpr std::size_t kHeader = 16;  // stations (4), fields (4), vertices (8)
    if (entry == nullptr || entry->size < kHeader) return;
    const std::uint8_t* payload = data + entry->offset;
    if (load<std::uint32_t>(payload + 4) != format::kBeamFieldsV1 ||
        (entry->size - kHeader) % sizeof(BeamSection) != 0 ||
        reinterpret_cast<std::uintptr_t>(payload + kHeader) % alignof(BeamSection) != 0)
      return;
    begin = payload + kHeader;
    count = static_cast<std::size_t>((entry->size - kHeader) / sizeof(BeamSection));
  }
  /// The bytes up to `end` have been read: check the sections that lie before it.
  void read_up_to(const std::uint8_t* end) noexcept {
    if (begin == nullptr || end <= begin) return;
    const std::size_t upto = std::min(count, static_cast<std::size_t>(end - begin) / sizeof(BeamSection));
    if (upto <= checked) return;
    plausible &= beam_values_plausible(reinterpret_cast<const BeamSection*>(begin) + checked, upto - checked);
    checked = upto;
  }
  bool done() const noexcept { return begin != nullptr && checked == count; }
};

// XXH3 of `size` bytes (the same value as checksum()), read in cache-sized
// pieces, each handed to `beams` while it is in cache.
std::uint64_t checksum_checking(const std::uint8_t* data, std::size_t size, BeamValueCheck& beams) {
  constexpr std::size_t kPiece = std::size_t{256} << 10;
  XXH3_state_t state;
  XXH3_64bits_reset(&state);
  for (std::size_t at = 0; at < size; at += kPiece) {
    const std::size_t piece = std::min(kPiece, size - at);
    XXH3_64bits_update(&state, data + at, piece);
    beams.read_up_to(data + at + piece);
  }
  return XXH3_64bits_digest(&state);
}

/// Checks the header (magic, byte order, version, scalar sizes, checksums of
/// the header and the section table, the declared length); returns where the
/// section table ends.
std::size_t check_header(const std::uint8_t* data, std::size_t size, ModelFileSummary& summary) {
  using namespace format;
  const std::size_t magic_bytes = std::min<std::size_t>(size, sizeof kMagic);
  if (size == 0) fail("the file is empty; pass a .organ model file written by 'organsim bake'");
  if (std::memcmp(data, kMagic, magic_bytes) != 0)
    fail(
        "not an organsim model file (wrong magic bytes at the start); pass a .organ file written by "
        "'organsim bake'");
  if (size < kHeaderBytes)
    fail("truncated inside the header (" + std::to_string(size) + " of " + std::to_string(kHeaderBytes) + " bytes); " +
         kDamagedAdvice);

  const std::uint32_t bom = load<std::uint32_t>(data + kOffByteOrder);
  if (bom == kByteOrderMarkSwapped)
    fail(
        "the file was written on a big-endian machine, which format v1 does not support; re-bake it on "
        "this machine");
  if (bom != kByteOrderMark) fail(std::string("the byte-order mark in the header is corrupt; ") + kDamagedAdvice);

  summary.version.major = load<std::uint16_t>(data + kOffVersionMajor);
  summary.version.minor = load<std::uint16_t>(data + kOffVersionMinor);
  const std::string file_version = std::to_string(summary.version.major) + "." + std::to_string(summary.version.minor);
  const std::string our_version =
      std::to_string(kModelFormatVersion.major) + "." + std::to_string(kModelFormatVersion.minor);
  if (summary.version.major > kModelFormatVersion.major)
    fail("the file has format version " + file_version + " but this organsim reads format " + our_version +
         " and older minor versions; update organsim to read it");
  if (summary.version.major < kModelFormatVersion.major)
    fail("format version " + file_version + " predates the first released format " + our_version +
         "; re-bake the model with this organsim");
  if (data[kOffRealBytes] != kRealBytes || data[kOffIndexBytes] != kIndexBytes)
    fail("scalar sizes " + std::to_string(data[kOffRealBytes]) + "/" + std::to_string(data[kOffIndexBytes]) +
         " bytes (real/index) are not the 8/4 that format v1 uses; " + kDamagedAdvice);
  if (load<std::uint64_t>(data + kOffHeaderChecksum) != checksum(data, kOffHeaderChecksum))
    fail(std::string("header checksum mismatch; ") + kDamagedAdvice);

  const std::uint64_t declared_bytes = load<std::uint64_t>(data + kOffFileBytes);
  const std::uint32_t section_count = load<std::uint32_t>(data + kOffSectionCount);
  summary.file_bytes = size;
  if (size < declared_bytes)
    fail("truncated " + describe_cut(data, size, section_count) + ": the file has " + std::to_string(size) +
         " bytes but its header says " + std::to_string(declared_bytes) + "; " + kDamagedAdvice);
  if (size > declared_bytes)
    fail(std::to_string(size - declared_bytes) + " unexpected bytes after the declared end of the file (" +
         std::to_string(declared_bytes) + " bytes); " + kDamagedAdvice);
  if (section_count > kMaxSections)
    fail("section count " + std::to_string(section_count) + " exceeds the limit of " + std::to_string(kMaxSections) +
         "; " + kDamagedAdvice);
  const std::size_t table_end = kHeaderBytes + std::size_t{section_count} * kTableEntryBytes;
  if (table_end > size) fail("the section table runs past the end of the file; " + std::string(kDamagedAdvice));
  if (load<std::uint64_t>(data + kOffTableChecksum) != checksum(data + kHeaderBytes, table_end - kHeaderBytes))
    fail(std::string("section table checksum mismatch; ") + kDamagedAdvice);
  return table_end;
}

/// The known sections' table entries (null where absent), once each.
struct SectionIndex {
  const TableEntry* found[std::size(format::kSections)] = {};

  bool has(Section id) const { return found[static_cast<std::size_t>(id)] != nullptr; }
  const TableEntry* entry(Section id) const { return found[static_cast<std::size_t>(id)]; }
};

/// Places every section in the payload area (no overlaps, no unknown section
/// unless the file is of a newer minor version, none twice, every required
/// one present) and lists them in the summary.
SectionIndex index_sections(const std::vector<TableEntry>& table, std::size_t table_end, std::size_t size,
                            ModelFileSummary& summary) {
  using namespace format;
  const std::string file_version = std::to_string(summary.version.major) + "." + std::to_string(summary.version.minor);
  const bool newer_minor = summary.version.minor > kModelFormatVersion.minor;
  SectionIndex index;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> extents;
  for (const TableEntry& e : table) {
    const auto* known = find_known_section(e.tag);
    const std::string label = known ? section_label(known->id) : "section '" + printable_tag(e.tag) + "'";
    if (e.offset < table_end || e.offset % kPayloadAlignment != 0 || e.offset > size || e.size > size - e.offset)
      fail(label + ": offset " + std::to_string(e.offset) + " and size " + std::to_string(e.size) +
           " lie outside the payload area; " + kDamagedAdvice);
    extents.emplace_back(e.offset, e.size);
    summary.sections.push_back({printable_tag(e.tag), e.size, known != nullptr});
    if (!known) {
      if (!newer_minor) fail(label + " is unknown in a format " + file_version + " file; " + kDamagedAdvice);
      continue;  // Added by a newer minor version: safe to skip by definition of "minor".
    }
    const std::size_t k = static_cast<std::size_t>(known->id);
    if (index.found[k]) fail(label + " appears twice; " + std::string(kDamagedAdvice));
    index.found[k] = &e;
  }
  std::sort(extents.begin(), extents.end());
  for (std::size_t i = 1; i < extents.size(); ++i)
    if (extents[i].first < extents[i - 1].first + extents[i - 1].second)
      fail(std::string("two sections overlap in the file; ") + kDamagedAdvice);
  return index;
}

/// The whole-file checksum, in one pass in the common case: only when it fails
/// are the sections hashed one by one, to name the damaged one. The same pass
/// checks the beam values a view will keep, while each piece of the file is
/// in cache (`beam_check`).
void check_payloads(const std::uint8_t* data, std::size_t size, const std::vector<TableEntry>& table,
                    BeamValueCheck& beam_check) {
  using namespace format;
  if (load<std::uint64_t>(data + kOffFileChecksum) ==
      checksum_checking(data + kHeaderBytes, size - kHeaderBytes, beam_check))
    return;
  for (const TableEntry& e : table)
    if (checksum(data + e.offset, static_cast<std::size_t>(e.size)) != e.checksum) {
      const auto* known = find_known_section(e.tag);
      fail((known ? section_label(known->id) : "section '" + printable_tag(e.tag) + "'") + ": checksum mismatch; " +
           kDamagedAdvice);
    }
  fail(std::string("whole-file checksum mismatch (damage outside every section's payload); ") + kDamagedAdvice);
}

/// The model from the checked sections, itself checked (find_model_issue).
OrganModel read_sections(const std::uint8_t* data, const SectionIndex& index, const BeamValueCheck& beam_check,
                         const std::shared_ptr<const void>& mapping) {
  auto payload = [&](Section id) { return data + index.entry(id)->offset; };
  auto bytes = [&](Section id) { return static_cast<std::size_t>(index.entry(id)->size); };
  OrganModel m;
  read_metadata(payload(Section::Metadata), bytes(Section::Metadata), m.provenance);
  m.surface_vertices = read_array<double, 3>(Section::SurfaceVertices, payload(Section::SurfaceVertices),
                                             bytes(Section::SurfaceVertices));
  m.surface_triangles = read_array<std::uint32_t, 3>(Section::SurfaceTriangles, payload(Section::SurfaceTriangles),
                                                     bytes(Section::SurfaceTriangles));
  if (index.has(Section::SurfaceTexcoords))
    m.surface_texcoords = read_array<double, 2>(Section::SurfaceTexcoords, payload(Section::SurfaceTexcoords),
                                                bytes(Section::SurfaceTexcoords));
  if (index.has(Section::Tetrahedra) && !index.has(Section::VolumeVertices))
    fail_section(Section::Tetrahedra,
                 std::string("present without section 'TVRT' (tetrahedron vertices); ") + kDamagedAdvice);
  if (index.has(Section::VolumeVertices))
    m.volume_vertices = read_array<double, 3>(Section::VolumeVertices, payload(Section::VolumeVertices),
                                              bytes(Section::VolumeVertices));
  if (index.has(Section::Tetrahedra))
    m.tetrahedra =
        read_array<std::uint32_t, 4>(Section::Tetrahedra, payload(Section::Tetrahedra), bytes(Section::Tetrahedra));
  m.fixed_points =
      read_array<double, 3>(Section::FixedPoints, payload(Section::FixedPoints), bytes(Section::FixedPoints));
  read_material(payload(Section::Material), bytes(Section::Material), m.material);
  bool beams_plausible = false;
  if (index.has(Section::BeamTables)) {
    beams_plausible = read_beams(payload(Section::BeamTables), bytes(Section::BeamTables), m.beams, mapping,
                                 beam_check.done() ? std::optional<bool>(beam_check.plausible) : std::nullopt);
    if (m.beams.sections.size() / m.beams.stations_per_beam != m.surface_vertices.size())
      fail_section(Section::BeamTables, "tables for " +
                                            std::to_string(m.beams.sections.size() / m.beams.stations_per_beam) +
                                            " vertices but the surface has " +
                                            std::to_string(m.surface_vertices.size()) + "; " + kDamagedAdvice);
  }
  if (index.has(Section::SiteCompliance))
    read_sites(payload(Section::SiteCompliance), bytes(Section::SiteCompliance), m.sites);
  if (index.has(Section::SiteCurvature))
    m.sites.curvature = read_vertex_pairs(Section::SiteCurvature, format::kCurvatureFieldsV1_3,
                                          payload(Section::SiteCurvature), bytes(Section::SiteCurvature));
  if (index.has(Section::Meshing)) read_meshing(payload(Section::Meshing), bytes(Section::Meshing), m.meshing);
  if (index.has(Section::Supports))
    m.supports.vertices = read_vertex_pairs(Section::Supports, format::kSupportFieldsV1_5, payload(Section::Supports),
                                            bytes(Section::Supports));
  if (index.has(Section::PullCurve))
    read_curve(Section::PullCurve, format::kPullFieldsV1_6, payload(Section::PullCurve), bytes(Section::PullCurve),
               m.sites.pull_tip_radius, m.sites.pull_curve);
  if (index.has(Section::SupportedSiteCompliance))
    m.sites.supported =
        read_supported_sites(payload(Section::SupportedSiteCompliance), bytes(Section::SupportedSiteCompliance));
  if (index.has(Section::SupportedDepthCurve))
    read_curve(Section::SupportedDepthCurve, format::kSupportedCurveFieldsV1_8, payload(Section::SupportedDepthCurve),
               bytes(Section::SupportedDepthCurve), m.sites.supported_curve_tip_radius, m.sites.supported_depth_curve);
  if (const auto issue = find_model_issue(m, beams_plausible))
    fail_section(issue->section, issue->message + "; " + kDamagedAdvice);
  return m;
}

OrganModel parse(const std::uint8_t* data, std::size_t size, ModelFileSummary& summary,
                 const std::shared_ptr<const void>& mapping) {
  const std::size_t table_end = check_header(data, size, summary);
  const std::vector<TableEntry> table = read_table(data, load<std::uint32_t>(data + format::kOffSectionCount));
  const SectionIndex index = index_sections(table, table_end, size, summary);
  BeamValueCheck beam_check(index.entry(Section::BeamTables), data);
  check_payloads(data, size, table, beam_check);
  for (const auto& d : format::kSections)
    if (d.required && !index.has(d.id)) fail(section_label(d.id) + " is missing but required; " + kDamagedAdvice);
  return read_sections(data, index, beam_check, mapping);
}

// `mapping` (may be null) keeps `data` valid: the beam tables may then view it.
ModelReadResult parse_kept(const std::uint8_t* data, std::size_t size, const std::string& source_name,
                           const std::shared_ptr<const void>& mapping) {
  ModelReadResult result;
  try {
    result.model = parse(data, size, result.file, mapping);
  } catch (const ParseError& e) {
    result.error = source_name + ": " + e.message;
  } catch (const std::bad_alloc&) {
    result.error = source_name + ": not enough memory to load the model";
  }
  return result;
}

}  // namespace

ModelReadResult parse_organ_model(const std::uint8_t* data, std::size_t size, const std::string& source_name) {
  return parse_kept(data, size, source_name, nullptr);
}

ModelReadResult read_organ_model_file(const std::string& path) {
  ModelReadResult result;
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) {
    result.error = path + ": cannot open (" + std::strerror(errno) + "); check the path and permissions";
    return result;
  }
  struct stat st {};
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode)) {
    result.error = path + ": is not a regular file; pass a .organ model file";
    ::close(fd);
    return result;
  }
  const auto size = static_cast<std::size_t>(st.st_size);
  if (size == 0) {
    ::close(fd);
    return parse_organ_model(nullptr, 0, path);
  }
  // Mapping (pre-faulted) instead of reading saves a copy of the whole file:
  // a 100 MB model loads in about half the time. organsim replaces model files
  // by rename, never in place, so a mapped file does not change under us.
  void* mapped = ::mmap(nullptr, size, PROT_READ, MAP_PRIVATE | MAP_POPULATE, fd, 0);
  ::close(fd);
  if (mapped == MAP_FAILED) {
    result.error = path + ": cannot read (" + std::strerror(errno) + "); check the disk and permissions";
    return result;
  }
  // The mapping lives as long as the model's beam tables view it.
  const std::shared_ptr<const void> mapping(mapped, [size](const void* at) { ::munmap(const_cast<void*>(at), size); });
  return parse_kept(static_cast<const std::uint8_t*>(mapped), size, path, mapping);
}

std::vector<std::uint8_t> serialize_organ_model(const OrganModel& model) {
  if (const auto issue = find_model_issue(model)) throw std::invalid_argument("invalid organ model: " + issue->message);
  using namespace format;

  std::vector<Section> present;
  std::vector<std::vector<std::uint8_t>> payloads;
  for (const auto& d : kSections)
    if (section_present(d.id, model)) {
      present.push_back(d.id);
      payloads.push_back(encode_section(d.id, model));
    }
  const std::size_t table_end = kHeaderBytes + present.size() * kTableEntryBytes;
  std::size_t file_bytes = align_up(table_end);
  std::vector<std::size_t> offsets;
  for (const auto& p : payloads) {
    offsets.push_back(file_bytes);
    file_bytes = align_up(file_bytes + p.size());
  }

  std::vector<std::uint8_t> out(file_bytes, 0);
  for (std::size_t i = 0; i < present.size(); ++i) {
    std::memcpy(out.data() + offsets[i], payloads[i].data(), payloads[i].size());
    const std::size_t e = kHeaderBytes + i * kTableEntryBytes;
    std::memcpy(out.data() + e, describe(present[i]).tag, 4);
    store<std::uint64_t>(out, e + kEntryChecksum, checksum(payloads[i].data(), payloads[i].size()));
    store<std::uint64_t>(out, e + kEntryOffset, offsets[i]);
    store<std::uint64_t>(out, e + kEntrySize, payloads[i].size());
  }
  std::memcpy(out.data() + kOffMagic, kMagic, sizeof kMagic);
  store<std::uint16_t>(out, kOffVersionMajor, kModelFormatVersion.major);
  store<std::uint16_t>(out, kOffVersionMinor, kModelFormatVersion.minor);
  store<std::uint32_t>(out, kOffByteOrder, kByteOrderMark);
  out[kOffRealBytes] = kRealBytes;
  out[kOffIndexBytes] = kIndexBytes;
  store<std::uint32_t>(out, kOffSectionCount, static_cast<std::uint32_t>(present.size()));
  store<std::uint64_t>(out, kOffFileBytes, file_bytes);
  store<std::uint64_t>(out, kOffTableChecksum, checksum(out.data() + kHeaderBytes, table_end - kHeaderBytes));
  store<std::uint64_t>(out, kOffFileChecksum, checksum(out.data() + kHeaderBytes, file_bytes - kHeaderBytes));
  store<std::uint64_t>(out, kOffHeaderChecksum, checksum(out.data(), kOffHeaderChecksum));
  return out;
}

void write_organ_model_file(const OrganModel& model, const std::string& path) {
  const std::vector<std::uint8_t> bytes = serialize_organ_model(model);
  io::write_file_atomically(path, bytes.data(), bytes.size());
}

}  // namespace organsim::model
