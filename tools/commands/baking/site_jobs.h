// Work on a seeded set of press sites, shared among processes: each site's
// presses are their own (the reference re-meshed around the site, its
// factorization, a few minutes of one core on a liver), so forked copies of
// the program can press different sites at once and hand their results back
// as JSON. What `calibrate --evaluate` and the depth curve's fit run on.
#pragma once

#include <cstddef>
#include <functional>
#include <vector>

#include <nlohmann/json.hpp>

namespace organsim::cli {

/// CPUs this process may run on (its affinity mask: a container's or
/// taskset's limit, not the machine's count).
std::size_t usable_cpus();

/// `site(k)` for every k below `count`, in `jobs` processes forked from this
/// one (job j: k = j, j + jobs, …; one job: here, in order); each site's
/// result in site order, whatever the number of jobs. Call it with no other
/// thread of the program's own running. Throws std::runtime_error with the
/// first failure (a site's exception, a job killed), once every job has been
/// stopped and reaped.
std::vector<nlohmann::json> run_site_jobs(std::size_t count, std::size_t jobs,
                                          const std::function<nlohmann::json(std::size_t)>& site);

/// A double as JSON to the last bit (nlohmann writes round-trip precision);
/// one that is not finite, which JSON cannot hold, as its name.
nlohmann::json exact_json(double x);
double exact_double(const nlohmann::json& j);

}  // namespace organsim::cli
