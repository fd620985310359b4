#include "machine_limits.h"

#include <algorithm>
#include <chrono>
#include <cstring>
#include <fstream>
#include <memory>

#include <immintrin.h>

#include <benchmark/benchmark.h>
#include <fmt/format.h>

#include "organsim/organ/organ.h"

namespace organsim::bench {
namespace {

using Clock = std::chrono::steady_clock;

std::string cpu_model() {
  std::ifstream in("/proc/cpuinfo");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("model name", 0) == 0) return line.substr(line.find(':') + 2);
  return "unknown";
}

// Best of five copies of 512 MiB (beyond every cache this class of machine has).
double copy_bandwidth() {
  constexpr std::size_t kBytes = std::size_t{512} << 20;
  const std::unique_ptr<char[]> from(new char[kBytes]), to(new char[kBytes]);
  std::memset(from.get(), 1, kBytes);
  std::memset(to.get(), 2, kBytes);
  double best = 1e30;
  for (int run = 0; run < 5; ++run) {
    const auto start = Clock::now();
    std::memcpy(to.get(), from.get(), kBytes);
    benchmark::DoNotOptimize(to.get());
    best = std::min(best, std::chrono::duration<double>(Clock::now() - start).count());
  }
  return 2.0 * kBytes / best;
}

// Twelve independent chains of a·x + b: enough in flight to cover the FMA
// latency on two ports. Flops: 2 per lane per chain per iteration.
constexpr int kChains = 12;

// One copy per SIMD width: intrinsics only inline into functions compiled for them.
#define ORGANSIM_FMA_CHAINS(name, target_features, Vector, set1, fma, lanes)     \
  __attribute__((target(target_features))) double name(std::size_t iterations) { \
    Vector acc[kChains];                                                         \
    for (auto& x : acc) x = set1(1.0);                                           \
    const Vector a = set1(0.999999), b = set1(1e-7);                             \
    for (std::size_t i = 0; i < iterations; ++i)                                 \
      for (auto& x : acc) x = fma(x, a, b);                                      \
    double sum = 0.0, lane[lanes];                                               \
    for (const auto& x : acc) {                                                  \
      std::memcpy(lane, &x, sizeof lane);                                        \
      for (double v : lane) sum += v;                                            \
    }                                                                            \
    return sum;                                                                  \
  }
inline __m128d multiply_add(__m128d x, __m128d a, __m128d b) { return _mm_add_pd(_mm_mul_pd(x, a), b); }
ORGANSIM_FMA_CHAINS(chains_avx512, "avx512f", __m512d, _mm512_set1_pd, _mm512_fmadd_pd, 8)
ORGANSIM_FMA_CHAINS(chains_avx2, "avx2,fma", __m256d, _mm256_set1_pd, _mm256_fmadd_pd, 4)
ORGANSIM_FMA_CHAINS(chains_sse2, "sse2", __m128d, _mm_set1_pd, multiply_add, 2)  // no FMA below x86-64-v3
#undef ORGANSIM_FMA_CHAINS

double peak_flops(const std::string& simd) {
  __builtin_cpu_init();
  const bool native = simd == "native";
  const bool avx512 = simd == "x86-64-v4" || (native && __builtin_cpu_supports("avx512f"));
  const bool avx2 = !avx512 && (simd == "x86-64-v3" || (native && __builtin_cpu_supports("avx2")));
  double (*run)(std::size_t) = avx512 ? chains_avx512 : avx2 ? chains_avx2 : chains_sse2;
  const int lanes = avx512 ? 8 : avx2 ? 4 : 2;
  constexpr std::size_t kIterations = 20'000'000;
  double best = 1e30;
  for (int r = 0; r < 3; ++r) {
    const auto start = Clock::now();
    benchmark::DoNotOptimize(run(kIterations));
    best = std::min(best, std::chrono::duration<double>(Clock::now() - start).count());
  }
  return 2.0 * kChains * lanes * static_cast<double>(kIterations) / best;
}

}  // namespace

const MachineLimits& machine_limits() {
  static const MachineLimits limits = [] {
    MachineLimits m;
    m.cpu = cpu_model();
    m.simd = organ::vertex_kernel_level();
    m.copy_bytes_per_s = copy_bandwidth();
    m.peak_flops = peak_flops(m.simd);
    return m;
  }();
  return limits;
}

benchmark::Counter times_memory_limit(double bytes) {
  return benchmark::Counter(bytes / machine_limits().copy_bytes_per_s,
                            benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

benchmark::Counter times_arithmetic_limit(double flops) {
  return benchmark::Counter(flops / machine_limits().peak_flops,
                            benchmark::Counter::kIsIterationInvariantRate | benchmark::Counter::kInvert);
}

void add_machine_context() {
  const MachineLimits& m = machine_limits();
  benchmark::AddCustomContext("cpu", m.cpu);
  benchmark::AddCustomContext("simd", m.simd);
  benchmark::AddCustomContext("copy_bandwidth", fmt::format("{:.1f} GB/s (STREAM-like copy, read + write, one thread)",
                                                            m.copy_bytes_per_s / 1e9));
  benchmark::AddCustomContext("peak_fp64",
                              fmt::format("{:.1f} GFLOP/s (one core, FMA at {})", m.peak_flops / 1e9, m.simd));
}

int run_benchmarks(int argc, char** argv) {
  add_machine_context();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

}  // namespace organsim::bench
