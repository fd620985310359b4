// Reading and writing `.organ` model files (format specified in
// docs/model-format.md). The reader validates everything and never trusts a
// size, index or value from the file; the writer writes atomically.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "organsim/model/organ_model.h"

namespace organsim::model {

struct FormatVersion {
  std::uint16_t major = 0;
  std::uint16_t minor = 0;
};

/// The format version this build writes and fully understands. Files with the
/// same major and a newer minor are read (unknown sections skipped); a newer
/// major is refused.
inline constexpr FormatVersion kModelFormatVersion{1, 8};

/// One entry of a file's section table, for reporting.
struct SectionSummary {
  std::string tag;          ///< four ASCII characters, e.g. "TETS"
  std::uint64_t bytes = 0;  ///< payload size
  bool understood = false;  ///< false for skipped sections of a newer minor version
};

/// What the reader learned about the file itself.
struct ModelFileSummary {
  FormatVersion version;
  std::uint64_t file_bytes = 0;
  std::vector<SectionSummary> sections;
};

/// The outcome of reading a model file: a model, or an error message of one
/// line that names the file, the section (when there is one) and the problem.
struct ModelReadResult {
  std::optional<OrganModel> model;
  ModelFileSummary file;
  std::string error;

  explicit operator bool() const { return model.has_value(); }
};

/// Reads and validates a model file. Never throws for bad file contents and
/// never allocates more than a small multiple of the file's size.
ModelReadResult read_organ_model_file(const std::string& path);

/// Parses a model held in memory; `source_name` is used in error messages.
ModelReadResult parse_organ_model(const std::uint8_t* data, std::size_t size, const std::string& source_name);

/// Encodes a model in the current format version. Throws std::invalid_argument
/// (with the validation message) when the model is not valid.
std::vector<std::uint8_t> serialize_organ_model(const OrganModel& model);

/// Writes a model file atomically (organsim/io/atomic_file.h): a temporary file
/// in the target directory, flushed, then renamed over `path`. On any error no
/// file is left behind and std::runtime_error (or std::invalid_argument for an invalid model) is thrown.
void write_organ_model_file(const OrganModel& model, const std::string& path);

}  // namespace organsim::model
