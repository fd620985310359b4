// The .organ reader and writer: round trips, and one distinct error for every
// kind of damage.
#include <gtest/gtest.h>

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>

#include "format_patching.h"
#include "organsim/model/model_file.h"
#include "test_models.h"

namespace organsim {
namespace {

using testing::find_section;
using testing::list_sections;
using testing::poke;
using testing::refresh_checksums;

model::OrganModel small_model() {
  testing::CylinderSpec spec;
  spec.segments = 8;
  spec.rings = 3;
  spec.stations = 4;
  spec.section_polygon_vertices = 32;
  model::OrganModel m = testing::make_cylinder_model(spec);
  m.provenance.input_sha256 = std::string(64, 'a');
  m.provenance.parameters["tet_size_mm"] = "4";
  m.provenance.parameters["label"] = "liver, värde 1";
  m.material.beam_stiffness_scale = 1.25;
  m.material.spring_stiffness_scale = 0.8;
  m.sites.young_modulus = 5000.0;
  m.sites.poisson_ratio = 0.49;
  for (std::size_t v = 0; v < m.surface_vertices.size(); ++v)
    m.sites.compliance.push_back({0.3 + 1e-3 * v, 0.2, 0.1, 0.01, -0.02, 0.005});
  m.sites.depth_curve = {{{0.0, 1.0}}, {{0.005, 1.4}}, {{0.010, 2.1}}};
  m.sites.curve_tip_radius = 0.0025;
  for (std::size_t v = 0; v < m.surface_vertices.size(); ++v) m.sites.curvature.push_back({40.0 + 1e-2 * v, -5.0});
  m.sites.pull_curve = {{{0.0, 1.0}}, {{0.007, 2.2}}, {{0.012, 3.1}}};
  m.sites.pull_tip_radius = 0.0025;
  m.meshing = {0.004, 0.01, 0.0025};
  for (std::size_t v = 0; v < m.surface_vertices.size(); ++v)
    m.supports.vertices.push_back(v % 3 == 0 ? std::array<double, 2>{0.0, 0.0}
                                             : std::array<double, 2>{static_cast<double>(1 + v % 2), 2.5e5});
  for (std::size_t v = 0; v < m.surface_vertices.size(); ++v)
    m.sites.supported.push_back({0.1 + 1e-3 * v, 0.05, 0.04, 0.002, -0.004, 0.001});
  m.sites.supported_depth_curve = {{{0.0, 0.8}}, {{0.002, 0.75}}, {{0.005, 0.9}}};
  m.sites.supported_curve_tip_radius = 0.003;
  return m;
}

std::vector<std::uint8_t> encoded() { return model::serialize_organ_model(small_model()); }

// The error for damaged bytes, parsed in memory and read from a file (which
// maps it and keeps the beam tables as a view): the same message either way.
std::string error_of(const std::vector<std::uint8_t>& bytes) {
  const model::ModelReadResult r = model::parse_organ_model(bytes.data(), bytes.size(), "liver.organ");
  EXPECT_FALSE(r) << "damaged file was accepted";
  EXPECT_EQ(r.error.find('\n'), std::string::npos) << "error must be one line: " << r.error;
  EXPECT_EQ(r.error.rfind("liver.organ: ", 0), 0u) << "error must name the file: " << r.error;
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("organsim_error_of_" + std::to_string(::getpid()) + ".organ");
  {
    std::ofstream out(path, std::ios::binary);
    out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  }
  const model::ModelReadResult from_file = model::read_organ_model_file(path.string());
  std::filesystem::remove(path);
  EXPECT_FALSE(from_file) << "damaged file was accepted when read from disk";
  EXPECT_EQ(from_file.error, path.string() + r.error.substr(std::string("liver.organ").size()));
  return r.error;
}

#define EXPECT_ERROR(bytes, text)                              \
  do {                                                         \
    const std::string error_ = error_of(bytes);                \
    EXPECT_NE(error_.find(text), std::string::npos) << error_; \
  } while (0)

TEST(ModelFile, RoundTripOfEverySection) {
  const model::OrganModel model = small_model();
  ASSERT_EQ(model::validate_organ_model(model), "");
  const auto bytes = model::serialize_organ_model(model);
  const model::ModelReadResult r = model::parse_organ_model(bytes.data(), bytes.size(), "x");
  ASSERT_TRUE(r) << r.error;
  EXPECT_TRUE(*r.model == model);
  std::set<std::string> tags;
  for (const auto& s : r.file.sections) tags.insert(s.tag);
  EXPECT_EQ(tags, (std::set<std::string>{"META", "SVRT", "STRI", "SUVC", "TVRT", "TETS", "FIXP", "MATL", "BEAM", "SITE",
                                         "CURV", "MESH", "SUPP", "PULL", "SSUP", "SCRV"}));
  EXPECT_EQ(r.file.version.major, 1);
  EXPECT_EQ(r.file.file_bytes, bytes.size());
}

TEST(ModelFile, RoundTripWithoutOptionalSections) {
  model::OrganModel model = small_model();
  model.surface_texcoords.clear();
  model.volume_vertices.clear();
  model.tetrahedra.clear();
  model.beams = {};
  model.sites = {};
  model.meshing = {};
  model.supports = {};
  model.provenance.parameters.clear();
  model.provenance.input_sha256.clear();
  const auto bytes = model::serialize_organ_model(model);
  const model::ModelReadResult r = model::parse_organ_model(bytes.data(), bytes.size(), "x");
  ASSERT_TRUE(r) << r.error;
  EXPECT_TRUE(*r.model == model);
  EXPECT_EQ(r.file.sections.size(), 5u);
}

TEST(ModelFile, EncodingIsDeterministic) { EXPECT_EQ(encoded(), encoded()); }

TEST(ModelFile, FileRoundTripIsAtomicAndLeavesNothingElse) {
  const auto dir = std::filesystem::temp_directory_path() / "organsim_model_file_test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string path = (dir / "m.organ").string();
  model::write_organ_model_file(small_model(), path);
  model::write_organ_model_file(small_model(), path);  // overwrite in place
  const model::ModelReadResult r = model::read_organ_model_file(path);
  ASSERT_TRUE(r) << r.error;
  EXPECT_TRUE(*r.model == small_model());
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);

  model::OrganModel bad = small_model();
  bad.material.young_modulus = -1;
  EXPECT_THROW(model::write_organ_model_file(bad, (dir / "bad.organ").string()), std::invalid_argument);
  EXPECT_THROW(model::write_organ_model_file(small_model(), (dir / "missing" / "m.organ").string()),
               std::runtime_error);
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(dir), {}), 1);
  std::filesystem::remove_all(dir);
}

TEST(ModelFile, BeamTablesAreAViewOfTheMappedFileThatOutlivesTheFileAndCopiesOnWrite) {
  const std::filesystem::path path =
      std::filesystem::temp_directory_path() / ("organsim_view_" + std::to_string(::getpid()) + ".organ");
  model::write_organ_model_file(small_model(), path.string());
  model::ModelReadResult r = model::read_organ_model_file(path.string());
  ASSERT_TRUE(r) << r.error;
  std::filesystem::remove(path);  // the mapping keeps the data
  const model::SectionTable& sections = r.model->beams.sections;
  EXPECT_TRUE(sections.is_view());
  EXPECT_TRUE(*r.model == small_model());
  model::OrganModel copy = *r.model;  // shares the mapping
  EXPECT_TRUE(copy.beams.sections.is_view());
  const model::BeamSection before = sections[3];
  copy.beams.sections[3].area = 42.0;  // copies into owned storage first
  EXPECT_FALSE(copy.beams.sections.is_view());
  EXPECT_EQ(copy.beams.sections[3].area, 42.0);
  EXPECT_TRUE(sections[3] == before) << "the view is read-only: a write never reaches the mapped file";
  r.model.reset();  // the last view goes: the file is unmapped
  EXPECT_EQ(copy.beams.sections.size(), small_model().beams.sections.size());
}

TEST(ModelFile, MissingFileAndDirectoryAreReported) {
  const model::ModelReadResult missing = model::read_organ_model_file("/nonexistent/liver.organ");
  EXPECT_NE(missing.error.find("cannot open"), std::string::npos) << missing.error;
  const model::ModelReadResult directory = model::read_organ_model_file("/tmp");
  EXPECT_NE(directory.error.find("not a regular file"), std::string::npos) << directory.error;
}

TEST(ModelFile, EmptyGarbageAndBadMagic) {
  EXPECT_ERROR(std::vector<std::uint8_t>{}, "the file is empty");
  EXPECT_ERROR(std::vector<std::uint8_t>({'h', 'e', 'l', 'l', 'o'}), "wrong magic bytes");
  auto bytes = encoded();
  bytes[1] = 'X';
  EXPECT_ERROR(bytes, "wrong magic bytes");
}

TEST(ModelFile, TruncationInsideHeaderAndTable) {
  const auto bytes = encoded();
  EXPECT_ERROR(std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 20), "truncated inside the header");
  EXPECT_ERROR(std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + 80), "truncated inside the section table");
}

TEST(ModelFile, TruncationAtAndInsideEverySection) {
  const auto bytes = encoded();
  const auto sections = list_sections(bytes);
  ASSERT_EQ(sections.size(), 16u);
  for (const auto& s : sections) {
    EXPECT_ERROR(std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + s.offset),
                 "truncated at the start of section '" + s.tag + "'");
    EXPECT_ERROR(std::vector<std::uint8_t>(bytes.begin(), bytes.begin() + s.offset + s.size / 2),
                 "truncated inside section '" + s.tag + "'");
  }
}

TEST(ModelFile, TrailingBytes) {
  auto bytes = encoded();
  bytes.push_back(0);
  EXPECT_ERROR(bytes, "1 unexpected bytes after the declared end");
}

TEST(ModelFile, FlippedBytesInHeaderTableAndEveryPayload) {
  auto header = encoded();
  header[26] ^= 0x40;  // inside the file-size field
  EXPECT_ERROR(header, "header checksum mismatch");
  auto table = encoded();
  table[64 + 17] ^= 0x01;  // the offset in the first table entry
  EXPECT_ERROR(table, "section table checksum mismatch");
  const auto original = encoded();
  for (const auto& s : list_sections(original)) {
    auto bytes = original;
    bytes[s.offset + s.size - 1] ^= 0x10;
    EXPECT_ERROR(bytes, "section '" + s.tag + "'");
    EXPECT_ERROR(bytes, "checksum mismatch");
  }
  // A byte in the alignment padding between sections belongs to no section.
  auto padding = encoded();
  bool flipped = false;
  const auto sections = list_sections(padding);
  for (std::size_t i = 0; i + 1 < sections.size() && !flipped; ++i)
    if (sections[i].offset + sections[i].size < sections[i + 1].offset) {
      padding[sections[i].offset + sections[i].size] ^= 0xff;
      flipped = true;
    }
  ASSERT_TRUE(flipped);
  EXPECT_ERROR(padding, "whole-file checksum mismatch");
}

TEST(ModelFile, FutureMajorVersionIsRefusedWithBothVersions) {
  auto bytes = encoded();
  poke<std::uint16_t>(bytes, 8, 2);
  poke<std::uint16_t>(bytes, 10, 3);
  refresh_checksums(bytes);
  EXPECT_ERROR(bytes, "format version 2.3 but this organsim reads format 1.8");
}

TEST(ModelFile, UnknownSectionOfNewerMinorIsSkippedButNotOfSameMinor) {
  auto bytes = encoded();
  const auto suvc = find_section(bytes, "SUVC");
  std::memcpy(bytes.data() + suvc.table_entry, "XTRA", 4);
  refresh_checksums(bytes);
  EXPECT_ERROR(bytes, "section 'XTRA' is unknown in a format 1.8 file");

  poke<std::uint16_t>(bytes, 10, model::kModelFormatVersion.minor + 1);
  refresh_checksums(bytes);
  const model::ModelReadResult r = model::parse_organ_model(bytes.data(), bytes.size(), "x");
  ASSERT_TRUE(r) << r.error;
  EXPECT_TRUE(r.model->surface_texcoords.empty());
  bool skipped = false;
  for (const auto& s : r.file.sections) skipped |= (s.tag == "XTRA" && !s.understood);
  EXPECT_TRUE(skipped);
}

TEST(ModelFile, FormatOnePointZeroMaterialHasUnitStiffnessScales) {
  // A 1.0 writer's MATL held five fields: E, nu, rho, alpha, beta.
  auto bytes = encoded();
  poke<std::uint16_t>(bytes, 10, 0);
  const auto material = find_section(bytes, "MATL");
  poke<std::uint32_t>(bytes, material.offset, 5u);
  poke<std::uint64_t>(bytes, material.table_entry + 24, material.size - 16);
  refresh_checksums(bytes);
  const model::ModelReadResult r = model::parse_organ_model(bytes.data(), bytes.size(), "x");
  ASSERT_TRUE(r) << r.error;
  EXPECT_EQ(r.model->material.young_modulus, small_model().material.young_modulus);
  EXPECT_EQ(r.model->material.attenuation_beta, small_model().material.attenuation_beta);
  EXPECT_EQ(r.model->material.beam_stiffness_scale, 1.0);
  EXPECT_EQ(r.model->material.spring_stiffness_scale, 1.0);
}

TEST(ModelFile, FormatOnePointOneFileWithoutSiteCompliancesLoads) {
  // A 1.1 writer knew no SITE section: the model loads without site data.
  model::OrganModel without = small_model();
  without.sites = {};
  auto bytes = model::serialize_organ_model(without);
  poke<std::uint16_t>(bytes, 10, 1);
  refresh_checksums(bytes);
  const model::ModelReadResult r = model::parse_organ_model(bytes.data(), bytes.size(), "x");
  ASSERT_TRUE(r) << r.error;
  EXPECT_EQ(r.file.version.minor, 1);
  EXPECT_TRUE(r.model->sites.empty());
  EXPECT_TRUE(*r.model == without);
}

TEST(ModelFile, FormatOnePointTwoFileWithoutCurvaturesLoads) {
  // A 1.2 writer knew no CURV section: the site law takes the surface as flat.
  model::OrganModel without = small_model();
  without.sites.curvature.clear();
  auto bytes = model::serialize_organ_model(without);
  EXPECT_THROW(find_section(bytes, "CURV"), std::exception);
  poke<std::uint16_t>(bytes, 10, 2);
  refresh_checksums(bytes);
  const model::ModelReadResult r = model::parse_organ_model(bytes.data(), bytes.size(), "x");
  ASSERT_TRUE(r) << r.error;
  EXPECT_EQ(r.file.version.minor, 2);
  EXPECT_TRUE(r.model->sites.curvature.empty());
  EXPECT_TRUE(*r.model == without);
}

TEST(ModelFile, FormatOnePointThreeFileWithoutMeshingLoads) {
  // A 1.3 writer knew no MESH section: a re-mesh takes the mesher's defaults.
  model::OrganModel without = small_model();
  without.meshing = {};
  auto bytes = model::serialize_organ_model(without);
  EXPECT_THROW(find_section(bytes, "MESH"), std::exception);
  poke<std::uint16_t>(bytes, 10, 3);
  refresh_checksums(bytes);
  const model::ModelReadResult r = model::parse_organ_model(bytes.data(), bytes.size(), "x");
  ASSERT_TRUE(r) << r.error;
  EXPECT_EQ(r.file.version.minor, 3);
  EXPECT_TRUE(r.model->meshing.empty());
  EXPECT_TRUE(*r.model == without);
}

TEST(ModelFile, FormatOnePointFourFileWithoutSupportsLoads) {
  // A 1.4 writer knew no SUPP section: the organ is held by its clamp alone.
  model::OrganModel without = small_model();
  without.supports = {};
  without.sites.supported.clear();
  without.sites.supported_depth_curve.clear();
  without.sites.supported_curve_tip_radius = 0.0;
  auto bytes = model::serialize_organ_model(without);
  EXPECT_THROW(find_section(bytes, "SUPP"), std::exception);
  poke<std::uint16_t>(bytes, 10, 4);
  refresh_checksums(bytes);
  const model::ModelReadResult r = model::parse_organ_model(bytes.data(), bytes.size(), "x");
  ASSERT_TRUE(r) << r.error;
  EXPECT_EQ(r.file.version.minor, 4);
  EXPECT_TRUE(r.model->supports.empty());
  EXPECT_TRUE(*r.model == without);
}

TEST(ModelFile, FormatOnePointFiveFileWithoutAPullCurveLoads) {
  // A 1.5 writer knew no PULL section: a grasp holds as the bonded punch.
  model::OrganModel without = small_model();
  without.sites.pull_curve.clear();
  without.sites.pull_tip_radius = 0.0;
  auto bytes = model::serialize_organ_model(without);
  EXPECT_THROW(find_section(bytes, "PULL"), std::exception);
  poke<std::uint16_t>(bytes, 10, 5);
  refresh_checksums(bytes);
  const model::ModelReadResult r = model::parse_organ_model(bytes.data(), bytes.size(), "x");
  ASSERT_TRUE(r) << r.error;
  EXPECT_EQ(r.file.version.minor, 5);
  EXPECT_TRUE(r.model->sites.pull_curve.empty());
  EXPECT_TRUE(*r.model == without);
}

TEST(ModelFile, ImplausiblePullCurvesAreRefused) {
  const auto original = encoded();
  const auto pull = find_section(original, "PULL");
  // Header: fields, reserved, tip radius; the curve (count, pairs).
  const std::size_t first_point = pull.offset + 8 + 8 + 8;
  auto check = [&](std::size_t at, double value, const char* what) {
    auto bytes = original;
    poke<double>(bytes, at, value);
    refresh_checksums(bytes);
    EXPECT_ERROR(bytes, "section 'PULL' (pull curve): ");
    EXPECT_ERROR(bytes, what);
  };
  check(pull.offset + 8, 0.0, "needs the tip radius");
  check(pull.offset + 8, -1.0, "tip radius must be a length");
  check(first_point + 16, 0.0, "increasing");  // the second distance equals the first
  check(first_point + 8, 0.0, "softenings must be positive");
  check(first_point + 8, 1e4, "softenings must be positive numbers up to 1000");
  check(first_point + 24, std::nan(""), "softenings");
  auto fields = original;
  poke<std::uint32_t>(fields, pull.offset, 3u);
  refresh_checksums(fields);
  EXPECT_ERROR(fields, "section 'PULL' (pull curve): field count 3 is not 2");
  auto count = original;
  poke<std::uint64_t>(count, first_point - 8, 1000);
  refresh_checksums(count);
  EXPECT_ERROR(count, "item count 1000 does not match");
  model::OrganModel orphan = small_model();
  orphan.sites = {};
  orphan.sites.pull_curve = {{{0.0, 1.0}}};
  orphan.sites.pull_tip_radius = 0.0025;
  EXPECT_NE(model::validate_organ_model(orphan).find("a pull curve without site compliances"), std::string::npos);
}

TEST(ModelFile, ImplausibleSupportsAreRefused) {
  const auto original = encoded();
  const auto supp = find_section(original, "SUPP");
  // Header: fields, reserved; the vertices (count, 2 reals each). Vertex 1 is a contact.
  const std::size_t vertex_one = supp.offset + 8 + 8 + 16;
  auto check = [&](std::size_t at, double value, const char* what) {
    auto bytes = original;
    poke<double>(bytes, at, value);
    refresh_checksums(bytes);
    EXPECT_ERROR(bytes, "section 'SUPP' (supports): ");
    EXPECT_ERROR(bytes, what);
  };
  check(vertex_one, 3.0, "support kind of vertex 1 is not 0 (free), 1 (contact) or 2 (attachment)");
  check(vertex_one, 0.5, "support kind of vertex 1");
  check(vertex_one, std::nan(""), "support kind of vertex 1");
  check(vertex_one + 8, 0.0, "foundation modulus of vertex 1");
  check(vertex_one + 8, -1.0, "foundation modulus of vertex 1");
  check(vertex_one + 8, std::numeric_limits<double>::infinity(), "foundation modulus of vertex 1");
  check(supp.offset + 8 + 8 + 8, 1.0, "foundation modulus of vertex 0");  // free with a modulus
  auto fields = original;
  poke<std::uint32_t>(fields, supp.offset, 3u);
  refresh_checksums(fields);
  EXPECT_ERROR(fields, "section 'SUPP' (supports): field count 3 is not 2");
  model::OrganModel short_list = small_model();
  short_list.supports.vertices.pop_back();
  EXPECT_NE(model::validate_organ_model(short_list).find("support entries for"), std::string::npos);
}

TEST(ModelFile, FormatOnePointSixFileWithoutCompliancesOnTheSupportsLoads) {
  // A 1.6 writer knew no SSUP section: the fast models' presses then meet
  // the organ held by its clamp, also with --supports baked.
  model::OrganModel without = small_model();
  without.sites.supported.clear();
  without.sites.supported_depth_curve.clear();
  without.sites.supported_curve_tip_radius = 0.0;
  auto bytes = model::serialize_organ_model(without);
  EXPECT_THROW(find_section(bytes, "SSUP"), std::exception);
  poke<std::uint16_t>(bytes, 10, 6);
  refresh_checksums(bytes);
  const model::ModelReadResult r = model::parse_organ_model(bytes.data(), bytes.size(), "x");
  ASSERT_TRUE(r) << r.error;
  EXPECT_EQ(r.file.version.minor, 6);
  EXPECT_TRUE(r.model->sites.supported.empty());
  EXPECT_TRUE(*r.model == without);
}

TEST(ModelFile, FormatOnePointSevenFileWithoutADepthCurveOnTheSupportsLoads) {
  // A 1.7 writer knew no SCRV section: presses on the supports read the
  // model's one depth curve.
  model::OrganModel without = small_model();
  without.sites.supported_depth_curve.clear();
  without.sites.supported_curve_tip_radius = 0.0;
  auto bytes = model::serialize_organ_model(without);
  EXPECT_THROW(find_section(bytes, "SCRV"), std::exception);
  poke<std::uint16_t>(bytes, 10, 7);
  refresh_checksums(bytes);
  const model::ModelReadResult r = model::parse_organ_model(bytes.data(), bytes.size(), "x");
  ASSERT_TRUE(r) << r.error;
  EXPECT_EQ(r.file.version.minor, 7);
  EXPECT_TRUE(r.model->sites.supported_depth_curve.empty());
  EXPECT_TRUE(*r.model == without);
}

TEST(ModelFile, ImplausibleDepthCurvesOnTheSupportsAreRefused) {
  const auto original = encoded();
  const auto scrv = find_section(original, "SCRV");
  // Header: fields, reserved, tip radius; the curve (count, pairs).
  const std::size_t first_point = scrv.offset + 8 + 8 + 8;
  auto check = [&](std::size_t at, double value, const char* what) {
    auto bytes = original;
    poke<double>(bytes, at, value);
    refresh_checksums(bytes);
    EXPECT_ERROR(bytes, "section 'SCRV' (depth curve on the supports): ");
    EXPECT_ERROR(bytes, what);
  };
  check(scrv.offset + 8, 0.0, "a depth curve on the supports needs the tip radius it was fitted with");
  check(scrv.offset + 8, std::nan(""), "the depth curve on the supports's tip radius must be a length");
  check(first_point + 16, 0.0, "depths must be finite, >= 0 and increasing");  // the second depth equals the first
  check(first_point + 8, -0.5, "factors must be positive numbers");
  check(first_point + 24, std::numeric_limits<double>::infinity(), "factors must be positive numbers");
  auto fields = original;
  poke<std::uint32_t>(fields, scrv.offset, 3u);
  refresh_checksums(fields);
  EXPECT_ERROR(fields, "section 'SCRV' (depth curve on the supports): field count 3 is not 2");
  auto count = original;
  poke<std::uint64_t>(count, first_point - 8, 1000);
  refresh_checksums(count);
  EXPECT_ERROR(count, "item count 1000 does not match");
  model::OrganModel orphan = small_model();
  orphan.sites.supported.clear();
  EXPECT_NE(model::validate_organ_model(orphan).find("a depth curve on the supports without site compliances on them"),
            std::string::npos);
}

TEST(ModelFile, ImplausibleCompliancesOnTheSupportsAreRefused) {
  const auto original = encoded();
  const auto ssup = find_section(original, "SSUP");
  const std::size_t vertex_one = ssup.offset + 8 + 8 + 6 * 8;  // field count, reserved, count, vertex 0
  for (const double bad : {-1.0, std::nan(""), std::numeric_limits<double>::infinity()}) {
    auto bytes = original;
    poke<double>(bytes, vertex_one, bad);
    refresh_checksums(bytes);
    EXPECT_ERROR(bytes, "section 'SSUP' (site compliance on the supports): ");
    EXPECT_ERROR(bytes, "compliance on the supports of vertex 1 is not finite or not positive semi-definite");
  }
  auto fields = original;
  poke<std::uint32_t>(fields, ssup.offset, 3u);
  refresh_checksums(fields);
  EXPECT_ERROR(fields, "section 'SSUP' (site compliance on the supports): field count 3 is not 6");
  model::OrganModel unsupported = small_model();
  unsupported.supports = {};
  EXPECT_NE(model::validate_organ_model(unsupported).find("on the supports without supports"), std::string::npos);
  model::OrganModel short_list = small_model();
  short_list.sites.supported.pop_back();
  EXPECT_NE(model::validate_organ_model(short_list).find("site compliances on the supports for"), std::string::npos);
}

TEST(ModelFile, ImplausibleMeshingIsRefused) {
  const auto original = encoded();
  const auto mesh = find_section(original, "MESH");
  const std::size_t first_real = mesh.offset + 8;  // after the field count and the reserved word
  auto check = [&](std::size_t at, double value, const char* what) {
    auto bytes = original;
    poke<double>(bytes, at, value);
    refresh_checksums(bytes);
    EXPECT_ERROR(bytes, "section 'MESH' (meshing): ");
    EXPECT_ERROR(bytes, what);
  };
  check(first_real, 0.0, "tetrahedron size must be a positive number of metres");
  check(first_real, std::nan(""), "tetrahedron size must be a positive number of metres");
  check(first_real + 8, -0.01, "clamp radius");
  check(first_real + 16, std::numeric_limits<double>::infinity(), "clamp radius");
  auto fields = original;
  poke<std::uint32_t>(fields, mesh.offset, 2u);
  refresh_checksums(fields);
  EXPECT_ERROR(fields, "section 'MESH' (meshing): field count 2 does not match");
  // Without tetrahedra a meshing record means nothing.
  model::OrganModel no_tetrahedra = small_model();
  no_tetrahedra.tetrahedra.clear();
  no_tetrahedra.volume_vertices.clear();
  EXPECT_NE(model::validate_organ_model(no_tetrahedra).find("a meshing record without tetrahedra"), std::string::npos);
}

TEST(ModelFile, ImplausibleSiteCurvaturesAreRefused) {
  const auto original = encoded();
  const auto curv = find_section(original, "CURV");
  // Header: fields, reserved; the vertices (count, 2 reals each).
  const std::size_t first_vertex = curv.offset + 8 + 8;
  auto check = [&](std::size_t at, double value) {
    auto bytes = original;
    poke<double>(bytes, at, value);
    refresh_checksums(bytes);
    EXPECT_ERROR(bytes, "section 'CURV' (site curvature): ");
    EXPECT_ERROR(bytes, "curvatures of vertex 0");
  };
  check(first_vertex, std::nan(""));
  check(first_vertex, 2e5);        // a radius of 5 µm
  check(first_vertex + 8, 100.0);  // κ₂ > κ₁
  auto fields = original;
  poke<std::uint32_t>(fields, curv.offset, 3u);
  refresh_checksums(fields);
  EXPECT_ERROR(fields, "field count 3 is not 2");
  auto count = original;
  poke<std::uint64_t>(count, first_vertex - 8, 3);
  refresh_checksums(count);
  EXPECT_ERROR(count, "item count 3 does not match");
  // Curvatures need the site compliances they belong to.
  model::OrganModel orphan = small_model();
  orphan.sites.compliance.clear();
  orphan.sites.depth_curve.clear();
  orphan.sites.pull_curve.clear();
  EXPECT_NE(model::validate_organ_model(orphan).find("curvatures without site compliances"), std::string::npos);
}

TEST(ModelFile, ImplausibleSiteCompliancesAreRefused) {
  const auto original = encoded();
  const auto site = find_section(original, "SITE");
  // Header: fields, reserved, E, nu, curve tip radius; the curve (count, pairs); the vertices (count, 6 reals each).
  const std::size_t curve = site.offset + 8 + 3 * 8;
  const std::size_t first_vertex = curve + 8 + 3 * 16 + 8;
  auto check = [&](std::size_t at, double value, const std::string& text) {
    auto bytes = original;
    poke<double>(bytes, at, value);
    refresh_checksums(bytes);
    EXPECT_ERROR(bytes, "section 'SITE' (site compliance): ");
    EXPECT_ERROR(bytes, text);
  };
  check(site.offset + 8, -5.0, "Young's modulus");
  check(site.offset + 16, 0.5, "Poisson's ratio");
  check(curve + 8 + 16, 0.0, "increasing");  // the second depth equals the first
  check(curve + 8 + 8, -1.0, "factors");     // the first factor
  check(first_vertex, std::nan(""), "vertex 0");
  check(first_vertex + 8, -0.1, "vertex 0");                 // yy < 0
  check(first_vertex + 24, 10.0, "positive semi-definite");  // xy² > xx yy
  auto count = original;
  poke<std::uint64_t>(count, curve, 1000);
  refresh_checksums(count);
  EXPECT_ERROR(count, "depth curve's point count");
  auto vertices = original;
  poke<std::uint64_t>(vertices, first_vertex - 8, 3);
  refresh_checksums(vertices);
  EXPECT_ERROR(vertices, "vertex count does not match");
}

TEST(ModelFile, ByteOrderAndScalarSizes) {
  auto swapped = encoded();
  poke<std::uint32_t>(swapped, 12, 0x0D0C0B0Au);
  EXPECT_ERROR(swapped, "big-endian");
  auto bom = encoded();
  poke<std::uint32_t>(bom, 12, 0x12345678u);
  EXPECT_ERROR(bom, "byte-order mark");
  auto scalar = encoded();
  scalar[16] = 4;
  refresh_checksums(scalar);
  EXPECT_ERROR(scalar, "scalar sizes 4/4");
}

TEST(ModelFile, OutOfRangeIndices) {
  auto triangles = encoded();
  poke<std::uint32_t>(triangles, find_section(triangles, "STRI").offset + 8 + 4, 999999u);
  refresh_checksums(triangles);
  EXPECT_ERROR(triangles, "section 'STRI' (surface triangles): surface triangle 0 refers to vertex 999999");
  auto tets = encoded();
  poke<std::uint32_t>(tets, find_section(tets, "TETS").offset + 8 + 4 * 5, 777777u);
  refresh_checksums(tets);
  EXPECT_ERROR(tets, "section 'TETS' (tetrahedra): tetrahedron 1 refers to vertex 777777");
}

TEST(ModelFile, NonFiniteValues) {
  auto vertices = encoded();
  poke<double>(vertices, find_section(vertices, "SVRT").offset + 8 + 8 * 4, std::nan(""));
  refresh_checksums(vertices);
  EXPECT_ERROR(vertices, "section 'SVRT' (surface vertices): surface vertex 1 has a non-finite coordinate");
  auto material = encoded();
  poke<double>(material, find_section(material, "MATL").offset + 8, std::numeric_limits<double>::infinity());
  refresh_checksums(material);
  EXPECT_ERROR(material, "section 'MATL' (material): Young's modulus");
  auto beams = encoded();
  poke<double>(beams, find_section(beams, "BEAM").offset + 16 + 8 * 9, -std::numeric_limits<double>::infinity());
  refresh_checksums(beams);
  EXPECT_ERROR(beams, "section 'BEAM' (beam tables): beam section of vertex 0, station 1 has a non-finite value");
  auto fixed = encoded();
  poke<double>(fixed, find_section(fixed, "FIXP").offset + 8, std::nan(""));
  refresh_checksums(fixed);
  EXPECT_ERROR(fixed, "section 'FIXP' (fixed points): fixed point 0 has a non-finite coordinate");
}

TEST(ModelFile, AbsurdCountsNeverAllocate) {
  auto vertices = encoded();
  poke<std::uint64_t>(vertices, find_section(vertices, "SVRT").offset, std::uint64_t{1} << 60);
  refresh_checksums(vertices);
  EXPECT_ERROR(vertices, "item count 1152921504606846976 does not match");
  auto beams = encoded();
  poke<std::uint64_t>(beams, find_section(beams, "BEAM").offset + 8, ~std::uint64_t{0});
  refresh_checksums(beams);
  EXPECT_ERROR(beams, "vertex count 18446744073709551615");
  auto stations = encoded();
  poke<std::uint32_t>(stations, find_section(stations, "BEAM").offset, 1u << 30);
  refresh_checksums(stations);
  EXPECT_ERROR(stations, "stations per beam 1073741824 is outside");
  auto metadata = encoded();
  poke<std::uint32_t>(metadata, find_section(metadata, "META").offset, 0xffffffffu);
  refresh_checksums(metadata);
  EXPECT_ERROR(metadata, "entry count 4294967295 exceeds the limit");
  auto key = encoded();
  poke<std::uint32_t>(key, find_section(key, "META").offset + 4, 0x7fffffffu);
  refresh_checksums(key);
  EXPECT_ERROR(key, "entry 0 runs past the payload");
  auto sections = encoded();
  poke<std::uint32_t>(sections, 20, 100000u);
  refresh_checksums(sections);
  EXPECT_ERROR(sections, "section count 100000 exceeds the limit");
}

TEST(ModelFile, StructuralDamageToTheTable) {
  auto outside = encoded();
  poke<std::uint64_t>(outside, find_section(outside, "TETS").table_entry + 24, std::uint64_t{1} << 40);
  refresh_checksums(outside);
  EXPECT_ERROR(outside, "section 'TETS' (tetrahedra): offset");
  EXPECT_ERROR(outside, "lie outside the payload area");

  auto twice = encoded();
  std::memcpy(twice.data() + find_section(twice, "SUVC").table_entry, "SVRT", 4);
  refresh_checksums(twice);
  EXPECT_ERROR(twice, "section 'SVRT' (surface vertices) appears twice");

  auto overlap = encoded();
  const auto tvrt = find_section(overlap, "TVRT");
  poke<std::uint64_t>(overlap, tvrt.table_entry + 16, find_section(overlap, "SUVC").offset);
  refresh_checksums(overlap);
  EXPECT_ERROR(overlap, "two sections overlap");

  auto missing = encoded();
  poke<std::uint16_t>(missing, 10, model::kModelFormatVersion.minor + 1);
  std::memcpy(missing.data() + find_section(missing, "FIXP").table_entry, "FIXQ", 4);
  refresh_checksums(missing);
  EXPECT_ERROR(missing, "section 'FIXP' (fixed points) is missing but required");

  auto orphan_tets = encoded();
  poke<std::uint16_t>(orphan_tets, 10, model::kModelFormatVersion.minor + 1);
  std::memcpy(orphan_tets.data() + find_section(orphan_tets, "TVRT").table_entry, "TVRX", 4);
  refresh_checksums(orphan_tets);
  EXPECT_ERROR(orphan_tets, "section 'TETS' (tetrahedra): present without section 'TVRT'");
}

TEST(ModelFile, MetadataMustBeSortedAndSI) {
  auto units = encoded();
  const auto meta = find_section(units, "META");
  const auto begin = units.begin() + meta.offset, end = begin + meta.size;
  const std::string si = "SI";
  auto at = std::search(begin, end, si.begin(), si.end());
  ASSERT_NE(at, end);
  *at = 'X';
  refresh_checksums(units);
  EXPECT_ERROR(units, "units are 'XI' but only SI is supported");

  auto order = encoded();
  const std::string key = "coordinate_frame";
  auto k = std::search(order.begin() + meta.offset, order.begin() + meta.offset + meta.size, key.begin(), key.end());
  *k = 'z';
  refresh_checksums(order);
  EXPECT_ERROR(order, "keys are not strictly sorted");
}

TEST(ModelFile, EveryDamageKindHasItsOwnMessage) {
  // Different kinds of damage must be distinguishable from the message alone.
  std::set<std::string> messages;
  auto add = [&](std::vector<std::uint8_t> bytes) {
    std::string e = error_of(bytes);
    messages.insert(e.substr(0, e.find(';')));
  };
  add({});
  add({'x'});
  auto b = encoded();
  add(std::vector<std::uint8_t>(b.begin(), b.begin() + 20));
  add(std::vector<std::uint8_t>(b.begin(), b.begin() + 80));
  add(std::vector<std::uint8_t>(b.begin(), b.end() - 8));
  auto c = b;
  c.push_back(1);
  add(c);
  c = b;
  c[30] ^= 1;
  add(c);
  c = b;
  c[70] ^= 1;
  add(c);
  c = b;
  c.back() ^= 1;
  add(c);
  EXPECT_EQ(messages.size(), 9u);
}

TEST(ModelValidation, CatchesInvalidModels) {
  model::OrganModel m = small_model();
  EXPECT_EQ(model::validate_organ_model(m), "");
  m.surface_triangles[3] = {1, 1, 2};
  EXPECT_NE(model::validate_organ_model(m).find("repeats a vertex"), std::string::npos);
  m = small_model();
  m.fixed_points.clear();
  EXPECT_NE(model::validate_organ_model(m).find("no fixed point"), std::string::npos);
  m = small_model();
  m.material.poisson_ratio = 0.5;
  EXPECT_NE(model::validate_organ_model(m).find("Poisson"), std::string::npos);
  m = small_model();
  m.beams.sections.pop_back();
  EXPECT_NE(model::validate_organ_model(m).find("beam tables hold"), std::string::npos);
  m = small_model();
  m.surface_texcoords.pop_back();
  EXPECT_NE(model::validate_organ_model(m).find("texture coordinates for"), std::string::npos);
  m = small_model();
  m.provenance.coordinate_frame = "XYZ";
  EXPECT_NE(model::validate_organ_model(m).find("neither LPS nor RAS"), std::string::npos);
}

}  // namespace
}  // namespace organsim
