// OpenIGTLink messages as a client sends them, for the tests of `organsim
// serve` and its message reader: well-formed ones through libOpenIGTLink, and
// raw ones with any header and body (wrong sizes, bad CRCs, version 2).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace organsim::testing {

using Bytes = std::vector<std::uint8_t>;

/// A TRANSFORM message packed by libOpenIGTLink (protocol version 1 header):
/// translation `tip` (mm), third rotation column `shaft`, the rest of the
/// rotation completing a right-handed frame.
Bytes transform_message(const std::string& device, const std::array<double, 3>& tip,
                        const std::array<double, 3>& shaft = {0.0, 0.0, 1.0});

/// A STRING message packed by libOpenIGTLink (protocol version 1 header, US-ASCII).
Bytes string_message(const std::string& device, const std::string& text);

/// The 48 bytes of a TRANSFORM body: 12 float32, big-endian, column by column.
Bytes transform_body(const std::array<float, 12>& matrix);

/// A message with any header fields: `crc` is the body's CRC-64 unless
/// `damage_crc`, `body_size` the body's length unless given.
Bytes raw_message(const std::string& type, const std::string& device, const Bytes& body, std::uint16_t version = 1,
                  bool damage_crc = false, std::uint64_t announced_body_size = ~std::uint64_t{0});

/// A protocol version 2 body: extended header (12 bytes), `content`, and a
/// metadata header and metadata with one key "Source" = "test".
Bytes version2_body(const Bytes& content);

}  // namespace organsim::testing
