// Loop timings for runs of any length: a histogram of durations in fixed
// logarithmic bins instead of a list of samples, so that memory does not grow
// with the session (a day at 1 kHz would be 86 million samples).
#pragma once

#include <array>
#include <atomic>
#include <cstdint>
#include <limits>

namespace organsim::realtime {

struct Percentiles {
  double p50 = 0.0, p99 = 0.0, max = 0.0;  ///< s
};

/// Durations (s) counted in bins 2^(1/64) wide (each bin's values lie within
/// 1.1 % of each other) from 10 ns to about 140 s; shorter and longer
/// durations land in the first and last bins. Keeps the exact count, maximum,
/// and count above a threshold (a loop's deadline).
///
/// record() allocates nothing, takes no lock and touches three cache lines:
/// one writer (a real-time loop) records, while any thread may read the
/// counts at the same time (relaxed atomics: a reader sees each count whole).
class DurationHistogram {
 public:
  static constexpr double kSmallest = 1e-8;  ///< s, the lower edge of bin 0
  static constexpr int kBinsPerOctave = 64;
  static constexpr std::size_t kBins = 34 * kBinsPerOctave;

  /// `threshold` (s): durations above it are counted by above_threshold().
  explicit DurationHistogram(double threshold = std::numeric_limits<double>::infinity()) noexcept;
  DurationHistogram(const DurationHistogram& other) noexcept;
  DurationHistogram& operator=(const DurationHistogram& other) noexcept;

  void record(double seconds) noexcept;

  std::uint64_t count() const noexcept { return count_.load(std::memory_order_relaxed); }
  /// The largest duration recorded (exact); 0 when empty.
  double max() const noexcept { return max_.load(std::memory_order_relaxed); }
  /// The smallest duration recorded (exact); 0 when empty.
  double min() const noexcept { return count() == 0 ? 0.0 : min_.load(std::memory_order_relaxed); }
  /// Samples in [low, high], to the bins' resolution (a bin counts when its
  /// centre lies in the range).
  std::uint64_t count_between(double low, double high) const noexcept;
  std::uint64_t above_threshold() const noexcept { return above_.load(std::memory_order_relaxed); }
  double threshold() const noexcept { return threshold_; }

  /// The duration below which a fraction q of the samples lie: the centre of
  /// the bin holding the ⌈q·n⌉-th smallest sample (within 0.6 % of it), never
  /// above max(); 0 when empty.
  double quantile(double q) const noexcept;
  /// p50, p99 and the maximum.
  Percentiles percentiles() const noexcept { return {quantile(0.50), quantile(0.99), max()}; }

  /// The samples recorded since `earlier`, a copy of this histogram taken
  /// before (a minute's statistics from a running loop). Its max() is the
  /// upper edge of the highest bin that gained samples (the exact maximum of
  /// an interval is not kept).
  DurationHistogram since(const DurationHistogram& earlier) const noexcept;

 private:
  static std::size_t bin_of(double seconds) noexcept;
  static double lower_edge(std::size_t bin) noexcept;

  double threshold_;
  std::atomic<std::uint64_t> count_{0}, above_{0};
  std::atomic<double> max_{0.0};
  std::atomic<double> min_{std::numeric_limits<double>::infinity()};
  std::array<std::atomic<std::uint64_t>, kBins> bins_{};
};

}  // namespace organsim::realtime
