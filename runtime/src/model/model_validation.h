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
std::optional<ModelIssue> find_model_issue(const OrganModel& model);

}  // namespace organsim::model
