// `calibrate --evaluate --reference-cache DIR`: the reference's presses kept
// on disk. They are the expensive part of an evaluation (an organ re-meshed
// around each site and a nonlinear FEM solve per press: minutes per site on a
// liver) and depend on nothing the fast models do, so with them kept an
// evaluation stopped halfway resumes where it stopped, a longer one (more
// sites, which keep the first sites' places) presses only the sites it adds,
// and a change to the fast models (their site data, their code) is measured
// again in the time the fast models take.
//
// One JSON file per site, written atomically as the site finishes, named by a
// key (SHA-256) of everything its reference presses depend on: the organ's
// surface, tetrahedra, clamp and material as the FEM reads them (the model
// file without its beam tables, site data, provenance and the fast models'
// own scales), the site, the reference's options, and organsim's version. A
// file whose contents do not parse or name another key is pressed again.
#pragma once

#include <optional>
#include <string>

#include <nlohmann/json.hpp>

#include "organsim/model/organ_model.h"

namespace organsim::cli {

class ReferenceCache {
 public:
  /// Keeps nothing when `directory` is empty. `fingerprint` names the model
  /// and options every site shares (reference_fingerprint). Creates the
  /// directory; throws std::runtime_error when it cannot.
  ReferenceCache(std::string directory, std::string fingerprint);

  bool enabled() const { return !directory_.empty(); }
  /// The key of one site's presses: the fingerprint, the site's number and
  /// its surface vertex.
  std::string site_key(std::size_t site, std::uint32_t vertex) const;
  /// What keep() kept under `key`, if it is there and intact.
  std::optional<nlohmann::json> find(const std::string& key) const;
  /// Writes `presses` under `key` (atomically; throws std::runtime_error).
  void keep(const std::string& key, const nlohmann::json& presses) const;

 private:
  std::string path_of(const std::string& key) const;
  std::string directory_, fingerprint_;
};

/// SHA-256 (lowercase hex) of the model as the FEM reference reads it and of
/// `options` (the reference's settings, as one JSON object).
std::string reference_fingerprint(const model::OrganModel& model, const nlohmann::json& options);

}  // namespace organsim::cli
