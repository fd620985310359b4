// What every benchmark reports next to its figures, so that figures from
// different machines can be compared: the CPU, the SIMD level the multi-beam
// kernels run at (ORGANSIM_SIMD caps it), and two limits measured in the same
// run — the memory bandwidth of a large copy (STREAM's "copy": bytes read +
// bytes written per second, arrays far larger than the caches) and the peak
// double-precision arithmetic of one core at that SIMD level (independent
// fused multiply-adds). A figure divided by its limit is the fraction of the
// machine the code uses.
#pragma once

#include <string>

#include <benchmark/benchmark.h>

namespace organsim::bench {

struct MachineLimits {
  std::string cpu;          ///< /proc/cpuinfo's model name
  std::string simd;         ///< the kernel level: x86-64-v4 (AVX-512), x86-64-v3 (AVX2), x86-64
  double copy_bytes_per_s;  ///< STREAM-like copy, one thread, bytes read + written
  double peak_flops;        ///< double-precision flops per second, one core, at `simd`
};

/// Measured once per program (about 1 s), on first use.
const MachineLimits& machine_limits();

/// A counter: the time per iteration as a multiple of moving `bytes` through
/// memory at the measured copy bandwidth (1 = at the memory limit).
benchmark::Counter times_memory_limit(double bytes);
/// The same against doing `flops` double-precision operations at the peak rate.
benchmark::Counter times_arithmetic_limit(double flops);

/// Adds the limits to Google Benchmark's context (printed before the table and
/// in --benchmark_format=json's "context").
void add_machine_context();

/// BENCHMARK_MAIN's body with the machine's limits in the context: what a
/// benchmark program's main() returns.
int run_benchmarks(int argc, char** argv);

}  // namespace organsim::bench

/// BENCHMARK_MAIN with the machine's limits in the context.
#define ORGANSIM_BENCHMARK_MAIN()                                                         \
  int main(int argc, char** argv) { return organsim::bench::run_benchmarks(argc, argv); } \
  static_assert(true, "")
