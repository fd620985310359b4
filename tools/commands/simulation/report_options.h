// The training report's options, shared by `report` and the commands that
// record a run (--report DIR): --force-limit and --reference-run.
#pragma once

#include <CLI/CLI.hpp>

#include "report/training_report.h"

namespace organsim::cli {

void add_report_options(CLI::App& app, report::ReportOptions& options);

}  // namespace organsim::cli
