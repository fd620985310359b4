// Model invariants, with the file section each one belongs to so that the
// reader can name it in its error message.
#pragma once

#include <optional>
#include <string>

#include "format_layout.h"
#include "organsim/model/organ_model.h"

namespace organsim::model {

struct ModelIssue {
  format::Section section;
  std::string message;
};

/// The first violated invariant of `model`, or nothing when it is valid.
/// `beam_values_plausible_already`: the reader found every beam value finite and
/// the magnitudes non-negative while it copied them (beam_values_plausible), so
/// the 100 MB are not read again.
std::optional<ModelIssue> find_model_issue(const OrganModel& model, bool beam_values_plausible_already = false);

/// No beam value NaN or infinite, no area, second moment or torsion constant negative.
bool beam_values_plausible(const BeamSection* sections, std::size_t count) noexcept;

}  // namespace organsim::model
