// `organsim report DIR`: rebuilds a training report's page and metrics from
// the raw data a run recorded with --report (after a change of the force
// limit, say), optionally beside a reference run's.
#include <iostream>
#include <memory>

#include <fmt/format.h>

#include "command_line.h"
#include "report_options.h"

namespace organsim::cli {
namespace {

struct ReportCommandOptions {
  std::string directory;
  report::ReportOptions report;
};

int run_report(const ReportCommandOptions& o) {
  for (const std::string& problem : report::write_report(o.directory, o.report)) warn("report", problem);
  std::cout << fmt::format("{:<16}{}/index.html (metrics: {}/metrics.json)\n", "report", o.directory, o.directory);
  return 0;
}

}  // namespace

void add_report_options(CLI::App& app, report::ReportOptions& options) {
  app.add_option("--force-limit", options.force_limit_n,
                 "Training report: the force, N, above which a tool's force counts as too much (judged on the "
                 "model's force, before the device's clamp; docs/report.md)")
      ->check(kPositive)
      ->capture_default_str();
  app.add_option("--reference-run", options.reference_run,
                 "Training report: another run's report directory (an expert's) to compare with, metric by metric");
}

Command add_report_command(CLI::App& app) {
  auto o = std::make_shared<ReportCommandOptions>();
  app.add_option("directory", o->directory, "A report directory written by replay --report")->required();
  add_report_options(app, o->report);
  return [o] { return run_report(*o); };
}

}  // namespace organsim::cli
