// `organsim report DIR`: rebuilds a training report's page and metrics from
// the raw data a run recorded with --report (after a change of the force
// limit, say), optionally beside a reference run's.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <vector>

#include <fmt/format.h>
#include <nlohmann/json.hpp>

#include "command_line/command_line.h"
#include "report_options.h"

namespace organsim::cli {
namespace {

namespace fs = std::filesystem;

struct ReportCommandOptions {
  std::string directory;
  std::vector<std::string> history;  ///< --history: report directories, one attempt each
  std::string history_output = "history.html";
  report::ReportOptions report;
  bool limit_given = false;  ///< --force-limit on the command line
};

/// The directories to rebuild: DIR itself, or, for `replay --model a,b
/// --report DIR`, its per-model subdirectories (DIR/<model>/), in name order.
std::vector<fs::path> recorded_runs(const fs::path& directory) {
  if (fs::exists(directory / "run.json") || !fs::is_directory(directory)) return {directory};
  std::vector<fs::path> runs;
  for (const fs::directory_entry& entry : fs::directory_iterator(directory))
    if (entry.is_directory() && fs::exists(entry.path() / "run.json")) runs.push_back(entry.path());
  std::sort(runs.begin(), runs.end());
  return runs.empty() ? std::vector<fs::path>{directory} : runs;
}

/// The limit the run's page was made with (its metrics.json), so that a
/// rebuild without --force-limit keeps it; the default if there is none.
double recorded_limit(const fs::path& directory) {
  std::ifstream in(directory / "metrics.json");
  const nlohmann::json metrics = nlohmann::json::parse(in, nullptr, false);
  if (metrics.is_object() && metrics.contains("force_limit_n") && metrics["force_limit_n"].is_number()) {
    const double limit = metrics["force_limit_n"].get<double>();
    if (limit > 0.0) return limit;
  }
  return report::kDefaultForceLimit;
}

int run_report(const ReportCommandOptions& o) {
  if (!o.history.empty()) {
    if (!o.directory.empty())
      throw CLI::ValidationError("--history", "takes the report directories itself; give no DIRECTORY beside it");
    std::vector<std::string> runs;
    for (const std::string& directory : o.history)
      for (const fs::path& run : recorded_runs(directory)) runs.push_back(run.string());
    report::write_history(runs, o.report, o.history_output);
    std::cout << fmt::format("{:<16}{} ({} attempts)\n", "history", o.history_output, runs.size());
    return 0;
  }
  if (o.directory.empty()) throw CLI::ValidationError("directory", "give a report directory (or --history DIR ...)");
  for (const fs::path& run : recorded_runs(o.directory)) {
    report::ReportOptions options = o.report;
    if (!o.limit_given) options.force_limit_n = recorded_limit(run);
    for (const std::string& problem : report::write_report(run.string(), options)) warn("report", problem);
    std::cout << fmt::format("{:<16}{}/index.html (metrics: {}/metrics.json; force limit {:g} N)\n", "report",
                             run.string(), run.string(), options.force_limit_n);
  }
  return 0;
}

}  // namespace

void add_report_options(CLI::App& app, report::ReportOptions& options) {
  app.add_option("--force-limit", options.force_limit_n,
                 "Training report: the force, N, above which a tool's force counts as too much (judged on the "
                 "model's force, before the device's clamp; docs/report.md)")
      ->check(kPositive)
      ->capture_default_str();
  app.add_option("--strain-limit", options.strain_limit,
                 "Training report: the surface strain (a fraction of an edge's rest length) beyond which the "
                 "organ's surface counts as damaged (docs/report.md#skill-measures)")
      ->check(kPositive)
      ->capture_default_str();
  app.add_option("--reference-run", options.reference_run,
                 "Training report: another run's report directory (an expert's) to compare with, metric by metric");
  app.add_option("--expert-bands", options.expert_bands,
                 "Training report: a JSON file of expert bands, {\"KEY\": [LOW, HIGH], ...}: each skill measure is "
                 "judged against its band (docs/report.md#expert-bands)")
      ->check(CLI::ExistingFile);
}

Command add_report_command(CLI::App& app) {
  auto o = std::make_shared<ReportCommandOptions>();
  app.add_option("directory", o->directory,
                 "A report directory written by --report (or, after replay --model a,b --report DIR, DIR: each "
                 "model's report is rebuilt)");
  app.add_option("--history", o->history,
                 "A learning curve instead: each skill measure over these report directories, one attempt each in "
                 "the order given (a directory of reports: each report in it, in name order), written to --output");
  app.add_option("-o,--output", o->history_output, "--history: the page to write")->capture_default_str();
  add_report_options(app, o->report);
  CLI::Option* limit = app.get_option("--force-limit");
  limit->default_str("");
  limit->description(
      "Training report: the force, N, above which a tool's force counts as too much (judged on the "
      "model's force, before the device's clamp; default: the limit the run's report was made with)");
  return [o, limit] {
    o->limit_given = limit->count() > 0;
    return run_report(*o);
  };
}

}  // namespace organsim::cli
