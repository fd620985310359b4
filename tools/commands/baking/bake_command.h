// `organsim bake` for other programs (the Python module's organsim.bake).
#pragma once

#include <string>

#include "organsim/pipeline/bake.h"

namespace organsim::cli {

/// What `organsim bake` does after parsing its options, for other programs
/// (the Python module binds pipeline::BakeOptions and calls this): stamps the
/// program's version into the options (the model's provenance), bakes, writes
/// the model file (options.output_path, required) and returns the report
/// exactly as `bake --json` prints it. Prints nothing. Throws
/// std::runtime_error with the pipeline's one-line messages.
std::string bake_report_json(pipeline::BakeOptions options);

}  // namespace organsim::cli
