// Loop timings in fixed memory: the histogram's percentiles against the exact
// ones, its counts, and the statistics of an interval of a running loop.
#include <algorithm>
#include <cmath>
#include <random>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "organsim/realtime/duration_histogram.h"
#include "organsim/realtime/loop_runner.h"

namespace organsim::realtime {
namespace {

TEST(DurationHistogram, PercentilesAgreeWithTheExactOnesToTheBinWidth) {
  std::mt19937 random(3);
  std::lognormal_distribution<double> period(std::log(1e-3), 0.3);  // s, about 1 ms
  std::vector<double> samples;
  DurationHistogram histogram(2e-3);
  for (int i = 0; i < 100000; ++i) {
    samples.push_back(period(random));
    histogram.record(samples.back());
  }
  const Percentiles exact = percentiles(samples);
  const Percentiles binned = histogram.percentiles();
  EXPECT_NEAR(binned.p50, exact.p50, 0.006 * exact.p50);  // half a bin, 2^(1/128) − 1
  EXPECT_NEAR(binned.p99, exact.p99, 0.006 * exact.p99);
  EXPECT_EQ(binned.max, exact.max);  // kept exactly
  EXPECT_EQ(histogram.min(), *std::min_element(samples.begin(), samples.end()));
  EXPECT_EQ(histogram.count(), samples.size());
  EXPECT_EQ(histogram.above_threshold(), static_cast<std::uint64_t>(std::count_if(samples.begin(), samples.end(),
                                                                                  [](double s) { return s > 2e-3; })));
  const auto within = static_cast<double>(
      std::count_if(samples.begin(), samples.end(), [](double s) { return s >= 0.9e-3 && s <= 1.1e-3; }));
  // Each end of the range is resolved to a bin (1.1 % of 1 ms, 1/18 of the range).
  EXPECT_NEAR(static_cast<double>(histogram.count_between(0.9e-3, 1.1e-3)), within, 0.06 * within);
}

TEST(DurationHistogram, EmptyOutOfRangeAndNonFiniteDurations) {
  DurationHistogram histogram;
  EXPECT_EQ(histogram.count(), 0u);
  EXPECT_EQ(histogram.quantile(0.5), 0.0);
  EXPECT_EQ(histogram.max(), 0.0);
  EXPECT_EQ(histogram.min(), 0.0);
  histogram.record(0.0);
  histogram.record(-1.0);
  histogram.record(std::nan(""));
  histogram.record(1e6);  // past the last bin: counted there, max exact
  EXPECT_EQ(histogram.count(), 4u);
  EXPECT_EQ(histogram.max(), 1e6);
  EXPECT_LE(histogram.quantile(0.5), DurationHistogram::kSmallest * 1.02);
  EXPECT_GT(histogram.quantile(1.0), 100.0);
}

TEST(DurationHistogram, SinceGivesTheIntervalsSamples) {
  DurationHistogram histogram(2e-3);
  for (int i = 0; i < 1000; ++i) histogram.record(1e-3);
  const DurationHistogram minute_ago = histogram;
  for (int i = 0; i < 100; ++i) histogram.record(5e-3);
  histogram.record(9e-3);
  const DurationHistogram interval = histogram.since(minute_ago);
  EXPECT_EQ(interval.count(), 101u);
  EXPECT_EQ(interval.above_threshold(), 101u);
  EXPECT_NEAR(interval.quantile(0.5), 5e-3, 0.006 * 5e-3);
  EXPECT_NEAR(interval.max(), 9e-3, 0.011 * 9e-3);  // the highest bin's upper edge
  EXPECT_GE(interval.max(), 9e-3);
  EXPECT_NEAR(interval.min(), 5e-3, 0.011 * 5e-3);
  EXPECT_EQ(histogram.since(histogram).count(), 0u);
}

// One thread records (a loop) while another reads (the progress report): the
// counts the reader sees only grow and end at the total.
TEST(DurationHistogram, AReaderSeesTheCountsGrowWhileALoopRecords) {
  DurationHistogram histogram;
  std::thread loop([&] {
    for (int i = 0; i < 200000; ++i) histogram.record(1e-6 * (1 + i % 7));
  });
  std::uint64_t seen = 0;
  bool grew = true;
  while (seen < 200000) {
    const DurationHistogram snapshot = histogram;
    grew = grew && snapshot.count() >= seen;
    seen = snapshot.count();
  }
  loop.join();
  EXPECT_TRUE(grew);
  EXPECT_EQ(histogram.count(), 200000u);
  EXPECT_EQ(histogram.max(), 7e-6);
}

}  // namespace
}  // namespace organsim::realtime
