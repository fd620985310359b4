#include "organsim/pipeline/image_hash.h"

#include <openssl/evp.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <memory>
#include <stdexcept>
#include <vector>

#include <fmt/format.h>

namespace organsim::pipeline {

std::string image_sha256(const CtImage& ct) {
  std::unique_ptr<EVP_MD_CTX, decltype(&EVP_MD_CTX_free)> context(EVP_MD_CTX_new(), &EVP_MD_CTX_free);
  if (!context || EVP_DigestInit_ex(context.get(), EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("cannot compute SHA-256: OpenSSL failed to initialise");
  std::vector<unsigned char> bytes;
  auto put_u64 = [&](std::uint64_t v) {
    for (int b = 0; b < 8; ++b) bytes.push_back(static_cast<unsigned char>(v >> (8 * b)));
  };
  auto put_f64 = [&](double v) {
    std::uint64_t u;
    std::memcpy(&u, &v, sizeof u);
    put_u64(u);
  };
  const auto size = ct.GetLargestPossibleRegion().GetSize();
  for (unsigned k = 0; k < 3; ++k) put_u64(size[k]);
  for (unsigned k = 0; k < 3; ++k) put_f64(ct.GetSpacing()[k]);
  for (unsigned k = 0; k < 3; ++k) put_f64(ct.GetOrigin()[k]);
  for (unsigned r = 0; r < 3; ++r)
    for (unsigned c = 0; c < 3; ++c) put_f64(ct.GetDirection()[r][c]);
  EVP_DigestUpdate(context.get(), bytes.data(), bytes.size());
  // Voxels in chunks, little-endian whatever the host.
  const std::int16_t* voxels = ct.GetBufferPointer();
  const std::size_t count = size[0] * size[1] * size[2];
  std::vector<unsigned char> chunk;
  for (std::size_t start = 0; start < count; start += 1 << 16) {
    const std::size_t end = std::min(count, start + (std::size_t{1} << 16));
    chunk.resize(2 * (end - start));
    for (std::size_t i = start; i < end; ++i) {
      const auto u = static_cast<std::uint16_t>(voxels[i]);
      chunk[2 * (i - start)] = static_cast<unsigned char>(u & 0xff);
      chunk[2 * (i - start) + 1] = static_cast<unsigned char>(u >> 8);
    }
    EVP_DigestUpdate(context.get(), chunk.data(), chunk.size());
  }
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned length = 0;
  EVP_DigestFinal_ex(context.get(), digest, &length);
  std::string hex;
  for (unsigned i = 0; i < length; ++i) hex += fmt::format("{:02x}", digest[i]);
  return hex;
}

}  // namespace organsim::pipeline
