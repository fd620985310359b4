#include "reference_cache.h"

#include <filesystem>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <openssl/evp.h>

#include "organsim/io/atomic_file.h"
#include "organsim/model/model_file.h"
#include "organsim/version.h"

namespace organsim::cli {
namespace {

std::string sha256_hex(const std::string& bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest, &length, EVP_sha256(), nullptr) != 1)
    throw std::runtime_error("SHA-256 failed (OpenSSL)");
  static constexpr char kHex[] = "0123456789abcdef";
  std::string hex;
  for (unsigned int i = 0; i < length; ++i) {
    hex += kHex[digest[i] >> 4];
    hex += kHex[digest[i] & 15];
  }
  return hex;
}

}  // namespace

std::string reference_fingerprint(const model::OrganModel& model, const nlohmann::json& options) {
  // What the fast models alone read (and calibrate fits) leaves the key alone.
  model::OrganModel fem = model;
  fem.provenance = {};
  fem.beams = {};
  fem.sites = {};
  fem.material.beam_stiffness_scale = fem.material.spring_stiffness_scale = 1.0;
  fem.material.attenuation_alpha = model::liver_default_material().attenuation_alpha;
  fem.material.attenuation_beta = model::liver_default_material().attenuation_beta;
  const std::vector<std::uint8_t> bytes = model::serialize_organ_model(fem);
  // Past the file's header (docs/model-format.md#header), which names the
  // format's version: a newer format of the same organ keeps its key.
  constexpr std::size_t kHeaderBytes = 64;
  return sha256_hex(std::string(bytes.begin() + kHeaderBytes, bytes.end()) + options.dump() + kProgramVersion);
}

ReferenceCache::ReferenceCache(std::string directory, std::string fingerprint)
    : directory_(std::move(directory)), fingerprint_(std::move(fingerprint)) {
  if (directory_.empty()) return;
  std::error_code error;
  std::filesystem::create_directories(directory_, error);
  if (error || !std::filesystem::is_directory(directory_))
    throw std::runtime_error("--reference-cache " + directory_ + ": cannot create the directory (" + error.message() +
                             "); give a writable one");
}

std::string ReferenceCache::site_key(std::size_t site, std::uint32_t vertex) const {
  return sha256_hex(fingerprint_ + " site " + std::to_string(site) + " vertex " + std::to_string(vertex));
}

std::string ReferenceCache::path_of(const std::string& key) const {
  return (std::filesystem::path(directory_) / ("reference-" + key + ".json")).string();
}

std::optional<nlohmann::json> ReferenceCache::find(const std::string& key) const {
  if (!enabled()) return std::nullopt;
  std::ifstream in(path_of(key));
  if (!in) return std::nullopt;
  std::stringstream text;
  text << in.rdbuf();
  const nlohmann::json kept = nlohmann::json::parse(text.str(), nullptr, false);
  if (kept.is_discarded() || !kept.is_object() || !kept.contains("key") || kept["key"] != key ||
      !kept.contains("presses"))
    return std::nullopt;
  return kept["presses"];
}

void ReferenceCache::keep(const std::string& key, const nlohmann::json& presses) const {
  if (!enabled()) return;
  io::write_file_atomically(path_of(key), nlohmann::json{{"key", key}, {"presses", presses}}.dump());
}

}  // namespace organsim::cli
