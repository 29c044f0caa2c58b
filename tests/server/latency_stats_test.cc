// Latency percentiles: nearest-rank values on known samples and the bounded window.
#include "server/latency_stats.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>

namespace caustica::server {
namespace {

TEST(Percentile, NearestRankOnKnownSamples) {
  std::vector<double> samples;
  for (int i = 100; i >= 1; --i) samples.push_back(i);  // unsorted on purpose
  EXPECT_EQ(percentile(samples, 50), 50);
  EXPECT_EQ(percentile(samples, 90), 90);
  EXPECT_EQ(percentile(samples, 99), 99);
  EXPECT_EQ(percentile(samples, 100), 100);
  EXPECT_EQ(percentile(samples, 0), 1);

  std::vector<double> four = {40, 10, 30, 20};
  EXPECT_EQ(percentile(four, 50), 20);  // rank ceil(2) = 2
  EXPECT_EQ(percentile(four, 51), 30);  // rank ceil(2.04) = 3
  EXPECT_EQ(percentile(four, 99), 40);

  std::vector<double> one = {7.5};
  EXPECT_EQ(percentile(one, 50), 7.5);
  std::vector<double> none;
  EXPECT_EQ(percentile(none, 50), 0);
}

TEST(LatencyStats, SummariesPerSeries) {
  LatencyStats stats;
  std::vector<double> values;
  for (int i = 1; i <= 1000; ++i) values.push_back(i * 0.5);
  std::shuffle(values.begin(), values.end(), std::mt19937(3));
  for (double v : values) stats.record("rpc/RenderFrame", v);
  stats.record("stage/render", 4.0);
  stats.record("stage/render", 2.0);

  const std::vector<LatencySummary> summaries = stats.summaries();
  ASSERT_EQ(summaries.size(), 2u);
  EXPECT_EQ(summaries[0].name, "rpc/RenderFrame");
  EXPECT_EQ(summaries[0].count, 1000u);
  EXPECT_DOUBLE_EQ(summaries[0].p50_ms, 250.0);
  EXPECT_DOUBLE_EQ(summaries[0].p90_ms, 450.0);
  EXPECT_DOUBLE_EQ(summaries[0].p99_ms, 495.0);
  EXPECT_DOUBLE_EQ(summaries[0].max_ms, 500.0);
  EXPECT_EQ(summaries[1].name, "stage/render");
  EXPECT_EQ(summaries[1].count, 2u);
  EXPECT_DOUBLE_EQ(summaries[1].p50_ms, 2.0);
  EXPECT_DOUBLE_EQ(summaries[1].max_ms, 4.0);
}

TEST(LatencyStats, PercentilesFollowTheRecentWindowButMaxAndCountCoverAll) {
  LatencyStats stats(/*window=*/10);
  stats.record("x", 1000.0);  // an old outlier
  for (int i = 1; i <= 10; ++i) stats.record("x", i);
  const LatencySummary s = stats.summaries().at(0);
  EXPECT_EQ(s.count, 11u);
  EXPECT_DOUBLE_EQ(s.max_ms, 1000.0);
  EXPECT_DOUBLE_EQ(s.p99_ms, 10.0);  // the outlier left the window
  EXPECT_DOUBLE_EQ(s.p50_ms, 5.0);
}

}  // namespace
}  // namespace caustica::server
