// Low-level edits of encoded model files for corruption tests and the fuzzer:
// change bytes, then recompute the checksums so that the reader's deeper
// checks (counts, indices, values) are reached.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace organsim::testing {

struct SectionLocation {
  std::string tag;
  std::size_t table_entry = 0;  ///< byte offset of the section's table entry
  std::size_t offset = 0;       ///< byte offset of the payload
  std::size_t size = 0;         ///< payload bytes
};

/// The section table of an encoded file (no validation: the file must be one
/// the writer produced).
std::vector<SectionLocation> list_sections(const std::vector<std::uint8_t>& file);
SectionLocation find_section(const std::vector<std::uint8_t>& file, const std::string& tag);

/// Recomputes every section checksum whose payload lies inside the file, the
/// table checksum, the whole-file checksum and the header checksum. Safe on arbitrary bytes.
void refresh_checksums(std::vector<std::uint8_t>& file);

template <typename T>
void poke(std::vector<std::uint8_t>& file, std::size_t at, T value) {
  for (std::size_t i = 0; i < sizeof(T); ++i) file.at(at + i) = reinterpret_cast<const std::uint8_t*>(&value)[i];
}

}  // namespace organsim::testing
