#include "site_jobs.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <csignal>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iostream>
#include <limits>
#include <stdexcept>
#include <string>
#include <thread>

#include <sched.h>
#include <sys/prctl.h>
#include <sys/wait.h>
#include <unistd.h>

#include <fmt/format.h>

namespace organsim::cli {
namespace {

struct Job {
  pid_t pid = -1;
  int output = -1;  ///< the read end of its pipe; -1 once read
};

void write_all(int fd, const std::string& text) {
  for (std::size_t written = 0; written < text.size();) {
    const ssize_t n = ::write(fd, text.data() + written, text.size() - written);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;  // the parent is gone: nothing to report to
    written += static_cast<std::size_t>(n);
  }
}

std::string read_all(int fd) {
  std::string text;
  char buffer[65536];
  for (;;) {
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return text;
    text.append(buffer, static_cast<std::size_t>(n));
  }
}

void reap(pid_t pid, int& status) {
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
}

/// Stops the jobs from `from` on (SIGTERM), closes their pipes and reaps them.
void stop_jobs(std::vector<Job>& jobs, std::size_t from) {
  for (std::size_t j = from; j < jobs.size(); ++j) {
    ::kill(jobs[j].pid, SIGTERM);
    if (jobs[j].output >= 0) ::close(jobs[j].output);
    jobs[j].output = -1;
    int status = 0;
    reap(jobs[j].pid, status);
  }
}

std::string dump(const nlohmann::json& j) { return j.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace); }

/// Job j's sites, written to `fd` as {"sites": [...]} or {"error": "..."};
/// never returns.
[[noreturn]] void run_job(std::size_t count, std::size_t j, std::size_t jobs,
                          const std::function<nlohmann::json(std::size_t)>& site, int fd) {
  ::prctl(PR_SET_PDEATHSIG, SIGTERM);  // a run stopped stops its jobs
  std::string text;
  int status = 0;
  try {
    nlohmann::json results = nlohmann::json::array();
    for (std::size_t k = j; k < count; k += jobs) results.push_back(site(k));
    text = dump({{"sites", std::move(results)}});
  } catch (const std::exception& e) {
    text = dump({{"error", e.what()}});
    status = 1;
  } catch (...) {
    text = R"({"error":"an unknown error"})";
    status = 1;
  }
  write_all(fd, text);
  std::fflush(stderr);
  std::_Exit(status);  // the parent's state (its files, its solvers) is the parent's to clean up
}

/// Job j's results, or why there are none.
std::vector<nlohmann::json> job_results(const std::string& text, int status, std::size_t j, std::size_t jobs) {
  if (WIFSIGNALED(status))
    throw std::runtime_error(fmt::format("job {} of {} was killed by signal {} (out of memory? try fewer --jobs)",
                                         j + 1, jobs, WTERMSIG(status)));
  nlohmann::json out;
  try {
    out = nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw std::runtime_error(fmt::format("job {} of {} ended (exit status {}) without its results: {}", j + 1, jobs,
                                         WIFEXITED(status) ? WEXITSTATUS(status) : -1, e.what()));
  }
  if (out.contains("error")) throw std::runtime_error(out.at("error").get<std::string>());
  return out.at("sites").get<std::vector<nlohmann::json>>();
}

}  // namespace

std::size_t usable_cpus() {
  cpu_set_t set;
  if (::sched_getaffinity(0, sizeof set, &set) == 0) return static_cast<std::size_t>(std::max(1, CPU_COUNT(&set)));
  return std::max(1u, std::thread::hardware_concurrency());
}

std::vector<nlohmann::json> run_site_jobs(std::size_t count, std::size_t jobs,
                                          const std::function<nlohmann::json(std::size_t)>& site) {
  jobs = std::min(jobs, count);
  std::vector<nlohmann::json> results(count);
  if (jobs <= 1) {
    for (std::size_t k = 0; k < count; ++k) results[k] = site(k);
    return results;
  }
  // The jobs are forked before any thread of ours exists, so each is the
  // program as it stands (OpenBLAS shuts its pool down around a fork and
  // starts it again); nothing buffered is written twice.
  std::vector<Job> started;
  std::cout.flush();
  std::fflush(nullptr);
  for (std::size_t j = 0; j < jobs; ++j) {
    int pipe_ends[2] = {-1, -1};
    const pid_t pid = ::pipe(pipe_ends) == 0 ? ::fork() : -1;
    if (pid < 0) {
      const int error = errno;
      for (int end : pipe_ends)
        if (end >= 0) ::close(end);
      stop_jobs(started, 0);
      throw std::runtime_error(
          fmt::format("cannot start job {} of {}: {}; try --jobs 1", j + 1, jobs, std::strerror(error)));
    }
    if (pid == 0) {
      ::close(pipe_ends[0]);
      for (const Job& s : started) ::close(s.output);
      run_job(count, j, jobs, site, pipe_ends[1]);
    }
    ::close(pipe_ends[1]);
    started.push_back({pid, pipe_ends[0]});
  }
  for (std::size_t j = 0; j < started.size(); ++j) {
    const std::string text = read_all(started[j].output);
    ::close(started[j].output);
    started[j].output = -1;
    int status = 0;
    reap(started[j].pid, status);
    std::vector<nlohmann::json> mine;
    try {
      mine = job_results(text, status, j, jobs);
      if (mine.size() != (count - j + jobs - 1) / jobs)
        throw std::runtime_error(fmt::format("job {} of {} gave {} sites' results", j + 1, jobs, mine.size()));
    } catch (const std::exception&) {
      stop_jobs(started, j + 1);  // the others' sites would not make a whole
      throw;
    }
    for (std::size_t i = 0; i < mine.size(); ++i) results[j + i * jobs] = std::move(mine[i]);
  }
  return results;
}

nlohmann::json exact_json(double x) {
  if (std::isfinite(x)) return x;
  return std::isnan(x) ? "nan" : x > 0 ? "inf" : "-inf";
}

double exact_double(const nlohmann::json& j) {
  if (j.is_number()) return j.get<double>();
  const std::string name = j.get<std::string>();
  if (name == "nan") return std::numeric_limits<double>::quiet_NaN();
  if (name == "inf") return std::numeric_limits<double>::infinity();
  if (name == "-inf") return -std::numeric_limits<double>::infinity();
  throw std::runtime_error("'" + name + "' is not a number");
}

}  // namespace organsim::cli
