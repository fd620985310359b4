#include "format_patching.h"

#define XXH_INLINE_ALL
#include <xxhash.h>

#include <cstring>
#include <stdexcept>

#include "format_layout.h"

namespace organsim::testing {
namespace {

template <typename T>
T peek(const std::vector<std::uint8_t>& file, std::size_t at) {
  T value;
  std::memcpy(&value, file.data() + at, sizeof(T));
  return value;
}

std::uint64_t checksum(const std::uint8_t* data, std::size_t size) { return XXH3_64bits(data, size); }

}  // namespace

std::vector<SectionLocation> list_sections(const std::vector<std::uint8_t>& file) {
  using namespace model::format;
  std::vector<SectionLocation> sections;
  const auto count = peek<std::uint32_t>(file, kOffSectionCount);
  for (std::uint32_t i = 0; i < count; ++i) {
    const std::size_t entry = kHeaderBytes + i * kTableEntryBytes;
    sections.push_back({std::string(reinterpret_cast<const char*>(file.data() + entry), 4), entry,
                        static_cast<std::size_t>(peek<std::uint64_t>(file, entry + kEntryOffset)),
                        static_cast<std::size_t>(peek<std::uint64_t>(file, entry + kEntrySize))});
  }
  return sections;
}

SectionLocation find_section(const std::vector<std::uint8_t>& file, const std::string& tag) {
  for (const SectionLocation& s : list_sections(file))
    if (s.tag == tag) return s;
  throw std::logic_error("no section " + tag);
}

void refresh_checksums(std::vector<std::uint8_t>& file) {
  using namespace model::format;
  if (file.size() < kHeaderBytes) return;
  const auto count = peek<std::uint32_t>(file, kOffSectionCount);
  const std::uint64_t entries = std::min<std::uint64_t>(count, (file.size() - kHeaderBytes) / kTableEntryBytes);
  for (std::uint64_t i = 0; i < entries; ++i) {
    const std::size_t entry = kHeaderBytes + i * kTableEntryBytes;
    const auto offset = peek<std::uint64_t>(file, entry + kEntryOffset);
    const auto size = peek<std::uint64_t>(file, entry + kEntrySize);
    if (offset <= file.size() && size <= file.size() - offset)
      poke<std::uint64_t>(file, entry + kEntryChecksum, checksum(file.data() + offset, static_cast<std::size_t>(size)));
  }
  const std::size_t table_end = kHeaderBytes + static_cast<std::size_t>(entries) * kTableEntryBytes;
  poke<std::uint64_t>(file, kOffTableChecksum, checksum(file.data() + kHeaderBytes, table_end - kHeaderBytes));
  poke<std::uint64_t>(file, kOffFileChecksum, checksum(file.data() + kHeaderBytes, file.size() - kHeaderBytes));
  poke<std::uint64_t>(file, kOffHeaderChecksum, checksum(file.data(), kOffHeaderChecksum));
}

}  // namespace organsim::testing
