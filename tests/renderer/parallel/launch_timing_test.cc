// The backend's launch profiler on the CPU: launches summed per name while timing is on, nothing
// recorded while it is off, and a clear that empties the table.
#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <vector>

#include "renderer/parallel/buffer.h"
#include "renderer/parallel/parallel_for.h"
#include "tests/renderer/parallel/scratch_check.h"

namespace caustica {
namespace {

const LaunchTime* find_launch(const std::vector<LaunchTime>& times, const std::string& name) {
  auto it =
      std::find_if(times.begin(), times.end(), [&](const LaunchTime& t) { return t.name == name; });
  return it == times.end() ? nullptr : &*it;
}

TEST(LaunchTiming, SumsLaunchesPerName) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  EXPECT_FALSE(backend->launch_timing()) << "off by default";
  const size_t n = 100000;
  Buffer<uint32_t> values(*backend, n);
  uint32_t* v = values.data();

  backend->set_launch_timing(true);
  parallel_for(*backend, "fill_index", n, [=](size_t i) { v[i] = uint32_t(i); });
  parallel_for(*backend, "add_one", n, [=](size_t i) { v[i] += 1; });
  parallel_for(*backend, "add_one", n, [=](size_t i) { v[i] += 1; });
  parallel_for(*backend, "add_one", 0, [=](size_t i) { v[i] += 1; });  // no launch
  std::vector<LaunchTime> times = backend->launch_times();
  ASSERT_EQ(times.size(), 2u);
  const LaunchTime* fill = find_launch(times, "fill_index");
  const LaunchTime* add = find_launch(times, "add_one");
  ASSERT_NE(fill, nullptr);
  ASSERT_NE(add, nullptr);
  EXPECT_EQ(fill->launches, 1u);
  EXPECT_EQ(add->launches, 2u);
  EXPECT_GE(fill->total_ms, 0.0);
  EXPECT_GE(add->total_ms, 0.0);
  EXPECT_GE(times[0].total_ms, times[1].total_ms) << "the most time first";
  EXPECT_EQ(values.download()[7], 9u);

  // Off: launches run, nothing more is recorded, what was gathered stays.
  backend->set_launch_timing(false);
  parallel_for(*backend, "add_one", n, [=](size_t i) { v[i] += 1; });
  parallel_for(*backend, "untimed", n, [=](size_t i) { v[i] += 1; });
  times = backend->launch_times();
  ASSERT_EQ(times.size(), 2u);
  EXPECT_EQ(find_launch(times, "add_one")->launches, 2u);
  EXPECT_EQ(find_launch(times, "untimed"), nullptr);

  backend->clear_launch_times();
  EXPECT_TRUE(backend->launch_times().empty());
}

// The primitives are launches too, each under its own name, counted once even where one is built
// on another (run-length encoding on selection).
TEST(LaunchTiming, PrimitivesAreNamedLaunches) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  const size_t n = 50000;
  std::vector<uint32_t> host(n);
  for (size_t i = 0; i < n; ++i) host[i] = uint32_t(i / 3);
  Buffer<uint32_t> keys(*backend, n), values(*backend, n), unique(*backend, n), counts(*backend, n);
  keys.upload(host);
  values.upload(host);

  backend->set_launch_timing(true);
  backend->sort_pairs(keys.data(), values.data(), n, 32);
  EXPECT_EQ(backend->exclusive_scan(values.data(), values.data(), 4), 1u);  // 0 + 0 + 0 + 1
  EXPECT_EQ(backend->run_length_encode(keys.data(), n, unique.data(), counts.data()), (n + 2) / 3);
  const std::vector<LaunchTime> times = backend->launch_times();
  ASSERT_EQ(times.size(), 3u);
  for (const char* name : {"sort_pairs", "exclusive_scan", "run_length_encode"}) {
    const LaunchTime* t = find_launch(times, name);
    ASSERT_NE(t, nullptr) << name;
    EXPECT_EQ(t->launches, 1u) << name;
    EXPECT_GE(t->total_ms, 0.0) << name;
  }
}

// Scratch launches are named like the others (on the CPU there is always room for the scratch).
TEST(LaunchTiming, ScratchLaunchesAreNamed) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  Buffer<uint32_t> sums(*backend, 1000);
  backend->set_launch_timing(true);
  ASSERT_TRUE(parallel_for_with_scratch<uint32_t>(*backend, "with_scratch", 1000, 4,
                                                  ScratchCheck{4, sums.data()}));
  const std::vector<LaunchTime> times = backend->launch_times();
  ASSERT_EQ(times.size(), 1u);
  EXPECT_EQ(times[0].name, "with_scratch");
  EXPECT_EQ(times[0].launches, 1u);
}

}  // namespace
}  // namespace caustica
