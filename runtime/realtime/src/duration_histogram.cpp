#include "organsim/realtime/duration_histogram.h"

#include <cmath>

namespace organsim::realtime {
namespace {

// The writer is the only thread that changes a count: load and store (not a
// read-modify-write instruction) are enough and cost no more than a plain add.
void increment(std::atomic<std::uint64_t>& counter, std::uint64_t by = 1) noexcept {
  counter.store(counter.load(std::memory_order_relaxed) + by, std::memory_order_relaxed);
}

}  // namespace

DurationHistogram::DurationHistogram(double threshold) noexcept : threshold_(threshold) {
  for (auto& bin : bins_) bin.store(0, std::memory_order_relaxed);
}

DurationHistogram::DurationHistogram(const DurationHistogram& other) noexcept : threshold_(other.threshold_) {
  *this = other;
}

DurationHistogram& DurationHistogram::operator=(const DurationHistogram& other) noexcept {
  threshold_ = other.threshold_;
  count_.store(other.count(), std::memory_order_relaxed);
  above_.store(other.above_threshold(), std::memory_order_relaxed);
  max_.store(other.max(), std::memory_order_relaxed);
  min_.store(other.min_.load(std::memory_order_relaxed), std::memory_order_relaxed);
  for (std::size_t b = 0; b < kBins; ++b)
    bins_[b].store(other.bins_[b].load(std::memory_order_relaxed), std::memory_order_relaxed);
  return *this;
}

std::size_t DurationHistogram::bin_of(double seconds) noexcept {
  if (!(seconds > kSmallest)) return 0;  // also NaN
  const double position = std::log2(seconds / kSmallest) * kBinsPerOctave;
  return position >= static_cast<double>(kBins - 1) ? kBins - 1 : static_cast<std::size_t>(position);
}

double DurationHistogram::lower_edge(std::size_t bin) noexcept {
  return kSmallest * std::exp2(static_cast<double>(bin) / kBinsPerOctave);
}

void DurationHistogram::record(double seconds) noexcept {
  increment(bins_[bin_of(seconds)]);
  increment(count_);
  if (seconds > threshold_) increment(above_);
  if (seconds > max_.load(std::memory_order_relaxed)) max_.store(seconds, std::memory_order_relaxed);
  if (seconds < min_.load(std::memory_order_relaxed)) min_.store(seconds, std::memory_order_relaxed);
}

std::uint64_t DurationHistogram::count_between(double low, double high) const noexcept {
  std::uint64_t total = 0;
  for (std::size_t b = 0; b < kBins; ++b) {
    const double centre = std::sqrt(lower_edge(b) * lower_edge(b + 1));
    if (centre >= low && centre <= high) total += bins_[b].load(std::memory_order_relaxed);
  }
  return total;
}

double DurationHistogram::quantile(double q) const noexcept {
  const std::uint64_t n = count();
  if (n == 0) return 0.0;
  const auto rank = static_cast<std::uint64_t>(std::ceil(q * static_cast<double>(n)));
  std::uint64_t seen = 0;
  for (std::size_t b = 0; b < kBins; ++b) {
    seen += bins_[b].load(std::memory_order_relaxed);
    if (seen >= rank && seen > 0) return std::fmin(std::sqrt(lower_edge(b) * lower_edge(b + 1)), max());
  }
  return max();
}

DurationHistogram DurationHistogram::since(const DurationHistogram& earlier) const noexcept {
  DurationHistogram interval(threshold_);
  std::uint64_t count = 0;
  std::size_t highest = kBins;
  for (std::size_t b = 0; b < kBins; ++b) {
    const std::uint64_t now = bins_[b].load(std::memory_order_relaxed);
    const std::uint64_t before = earlier.bins_[b].load(std::memory_order_relaxed);
    const std::uint64_t gained = now > before ? now - before : 0;
    interval.bins_[b].store(gained, std::memory_order_relaxed);
    count += gained;
    if (gained > 0) highest = b;
  }
  interval.count_.store(count, std::memory_order_relaxed);
  const std::uint64_t above = above_threshold(), above_before = earlier.above_threshold();
  interval.above_.store(above > above_before ? above - above_before : 0, std::memory_order_relaxed);
  interval.max_.store(highest == kBins ? 0.0 : std::fmin(lower_edge(highest + 1), max()), std::memory_order_relaxed);
  for (std::size_t b = 0; b < kBins; ++b)
    if (interval.bins_[b].load(std::memory_order_relaxed) > 0) {
      interval.min_.store(std::fmax(lower_edge(b), min()), std::memory_order_relaxed);
      break;
    }
  return interval;
}

}  // namespace organsim::realtime
