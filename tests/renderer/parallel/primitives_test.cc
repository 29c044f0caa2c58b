// Each primitive against the std algorithm it stands for, on random data of several sizes,
// including empty and one-element inputs and sizes that cross the serial/chunked threshold.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "renderer/parallel/buffer.h"
#include "renderer/parallel/parallel_for.h"
#include "tests/renderer/parallel/host_download_check.h"
#include "tests/renderer/parallel/scratch_check.h"

namespace caustica {
namespace {

class PrimitivesTest : public ::testing::TestWithParam<size_t> {
 protected:
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(1) << 30);
  std::mt19937 rng{1234};
};

INSTANTIATE_TEST_SUITE_P(Sizes, PrimitivesTest,
                         ::testing::Values(0, 1, 2, 7, 1000, 16384, 100003, 1 << 20));

TEST_P(PrimitivesTest, SortPairs32MatchesStableSort) {
  const size_t n = GetParam();
  std::vector<uint32_t> keys(n), values(n);
  for (size_t i = 0; i < n; ++i) {
    keys[i] = rng() & 0x3fffffffu;
    if (i % 5 == 0) keys[i] &= 0xff;  // many duplicates exercise stability
    values[i] = uint32_t(i);
  }
  std::vector<std::pair<uint32_t, uint32_t>> expected(n);
  for (size_t i = 0; i < n; ++i) expected[i] = {keys[i], values[i]};
  std::stable_sort(expected.begin(), expected.end(),
                   [](auto a, auto b) { return a.first < b.first; });

  Buffer<uint32_t> k(*backend, n), v(*backend, n);
  k.upload(keys);
  v.upload(values);
  backend->sort_pairs(k.data(), v.data(), n, 30);
  auto got_k = k.download(), got_v = v.download();
  for (size_t i = 0; i < n; ++i) {
    ASSERT_EQ(got_k[i], expected[i].first) << i;
    ASSERT_EQ(got_v[i], expected[i].second) << i;
  }
}

TEST_P(PrimitivesTest, SortPairs64MatchesStableSort) {
  const size_t n = GetParam();
  std::vector<uint64_t> keys(n);
  std::vector<uint32_t> values(n);
  for (size_t i = 0; i < n; ++i) {
    keys[i] = (uint64_t(rng()) << 32 | rng()) >> (i % 3 == 0 ? 40 : 0);
    values[i] = uint32_t(i);
  }
  std::vector<std::pair<uint64_t, uint32_t>> expected(n);
  for (size_t i = 0; i < n; ++i) expected[i] = {keys[i], values[i]};
  std::stable_sort(expected.begin(), expected.end(),
                   [](auto a, auto b) { return a.first < b.first; });
  Buffer<uint64_t> k(*backend, n);
  Buffer<uint32_t> v(*backend, n);
  k.upload(keys);
  v.upload(values);
  backend->sort_pairs(k.data(), v.data(), n, 64);
  auto got_k = k.download();
  auto got_v = v.download();
  for (size_t i = 0; i < n; ++i) {
    ASSERT_EQ(got_k[i], expected[i].first) << i;
    ASSERT_EQ(got_v[i], expected[i].second) << i;
  }
}

TEST_P(PrimitivesTest, ExclusiveScanMatchesStd) {
  const size_t n = GetParam();
  std::vector<uint32_t> in(n);
  for (auto& x : in) x = rng() % 100;
  std::vector<uint32_t> expected(n);
  std::exclusive_scan(in.begin(), in.end(), expected.begin(), 0u);
  Buffer<uint32_t> b(*backend, n);
  b.upload(in);
  uint32_t total = backend->exclusive_scan(b.data(), b.data(), n);  // in place
  EXPECT_EQ(b.download(), expected);
  EXPECT_EQ(total, std::accumulate(in.begin(), in.end(), 0u));
}

TEST_P(PrimitivesTest, FloatScanMatchesStdWithinRounding) {
  const size_t n = GetParam();
  std::vector<float> in(n);
  for (auto& x : in) x = float(rng() % 1000) / 7.0f;
  std::vector<double> expected(n);
  double running = 0;
  for (size_t i = 0; i < n; ++i) {
    expected[i] = running;
    running += in[i];
  }
  Buffer<float> b(*backend, n), out(*backend, n);
  b.upload(in);
  float total = backend->exclusive_scan(b.data(), out.data(), n);
  auto got = out.download();
  for (size_t i = 0; i < n; ++i) ASSERT_NEAR(got[i], expected[i], 1e-7 * (expected[i] + 1)) << i;
  EXPECT_NEAR(total, running, 1e-7 * (running + 1));
}

TEST_P(PrimitivesTest, ReductionsMatchStd) {
  const size_t n = GetParam();
  std::vector<uint32_t> ints(n);
  std::vector<float> floats(n);
  std::vector<Aabb> boxes(n);
  Aabb expected_box;
  for (size_t i = 0; i < n; ++i) {
    ints[i] = rng();
    floats[i] = float(int(rng() % 2001) - 1000) * 0.5f;
    Vec3f p(float(rng() % 1000), float(rng() % 1000) - 500.0f, float(rng() % 10));
    boxes[i] = Aabb{p, p + Vec3f(1.0f)};
    expected_box.extend(boxes[i]);
  }
  Buffer<uint32_t> bi(*backend, n);
  Buffer<float> bf(*backend, n);
  Buffer<Aabb> bb(*backend, n);
  bi.upload(ints);
  bf.upload(floats);
  bb.upload(boxes);
  uint64_t int_sum = 0;
  for (uint32_t x : ints) int_sum += x;
  EXPECT_EQ(backend->reduce_sum(bi.data(), n), int_sum);
  double float_sum = 0;
  for (float x : floats) float_sum += x;
  EXPECT_DOUBLE_EQ(backend->reduce_sum(bf.data(), n), float_sum);  // halves sum exactly
  float expected_max = n ? *std::max_element(floats.begin(), floats.end()) : -FLT_MAX;
  EXPECT_EQ(backend->reduce_max(bf.data(), n), expected_max);
  Aabb got = backend->reduce_bounds(bb.data(), n);
  EXPECT_EQ(got.lower, expected_box.lower);
  EXPECT_EQ(got.upper, expected_box.upper);
  Buffer<Aabb> left(*backend, 1);
  backend->reduce_bounds_to(bb.data(), n, left.data());
  const Aabb kept = left.download()[0];
  EXPECT_EQ(kept.lower, expected_box.lower);
  EXPECT_EQ(kept.upper, expected_box.upper);
}

TEST_P(PrimitivesTest, SelectFlaggedMatchesCopyIf) {
  const size_t n = GetParam();
  std::vector<uint32_t> in(n);
  std::vector<uint8_t> flags(n);
  std::vector<uint32_t> expected, expected_idx;
  for (size_t i = 0; i < n; ++i) {
    in[i] = rng();
    flags[i] = rng() % 3 == 0;
    if (flags[i]) {
      expected.push_back(in[i]);
      expected_idx.push_back(uint32_t(i));
    }
  }
  Buffer<uint32_t> bin(*backend, n), out(*backend, n);
  Buffer<uint8_t> bflags(*backend, n);
  bin.upload(in);
  bflags.upload(flags);
  size_t count = backend->select_flagged(bin.data(), bflags.data(), n, out.data());
  ASSERT_EQ(count, expected.size());
  auto got = out.download();
  got.resize(count);
  EXPECT_EQ(got, expected);
  count = backend->select_flagged(nullptr, bflags.data(), n, out.data());
  got = out.download();
  got.resize(count);
  EXPECT_EQ(got, expected_idx);
}

TEST_P(PrimitivesTest, RunLengthEncodeMatchesSerialRuns) {
  const size_t n = GetParam();
  std::vector<uint32_t> in(n);
  uint32_t v = 0;
  for (auto& x : in) {
    if (rng() % 4 == 0) v = rng() % 7;  // runs of random length, repeated values across runs
    x = v;
  }
  std::vector<uint32_t> uniq, counts;
  for (size_t i = 0; i < n; ++i) {
    if (i == 0 || in[i] != in[i - 1]) {
      uniq.push_back(in[i]);
      counts.push_back(0);
    }
    ++counts.back();
  }
  Buffer<uint32_t> bin(*backend, n), bu(*backend, n), bc(*backend, n);
  bin.upload(in);
  size_t runs = backend->run_length_encode(bin.data(), n, bu.data(), bc.data());
  ASSERT_EQ(runs, uniq.size());
  auto got_u = bu.download(), got_c = bc.download();
  got_u.resize(runs);
  got_c.resize(runs);
  EXPECT_EQ(got_u, uniq);
  EXPECT_EQ(got_c, counts);
}

TEST_P(PrimitivesTest, ParallelForVisitsEveryIndexOnce) {
  const size_t n = GetParam();
  Buffer<uint32_t> hits(*backend, n);
  hits.fill_zero();
  uint32_t* h = hits.data();
  parallel_for(*backend, "count_visits", n, [=](size_t i) { h[i] += uint32_t(i % 13) + 1; });
  auto got = hits.download();
  for (size_t i = 0; i < n; ++i) ASSERT_EQ(got[i], i % 13 + 1);
}

// Each element gets scratch of its own, of the size asked for.
TEST_P(PrimitivesTest, ParallelForWithScratchGivesEachElementItsOwn) {
  const size_t n = GetParam();
  for (uint32_t count : {1u, 5u, 64u}) {
    Buffer<uint32_t> sums(*backend, n);
    ASSERT_TRUE(parallel_for_with_scratch<uint32_t>(*backend, "scratch_check", n, count,
                                                    ScratchCheck{count, sums.data()}));
    auto got = sums.download();
    for (size_t i = 0; i < n; ++i) ASSERT_EQ(got[i], ScratchCheck::expected_sum(i, count)) << i;
  }
}

TEST_P(PrimitivesTest, DownloadIntoHostBuffer) {
  std::vector<uint32_t> values(GetParam());
  for (uint32_t& v : values) v = rng();
  expect_download_into_host_buffer(*backend, values);
}

TEST(BackendBudget, AllocationBeyondBudgetThrowsBudgetExceeded) {
  auto backend = make_cpu_backend(1000);
  Buffer<uint8_t> ok(*backend, 600);
  EXPECT_EQ(backend->bytes_in_use(), 600u);
  EXPECT_THROW(Buffer<uint8_t>(*backend, 600), BudgetExceeded);
  ok = Buffer<uint8_t>();
  EXPECT_EQ(backend->bytes_in_use(), 0u);
  EXPECT_EQ(backend->peak_bytes(), 600u);
}

}  // namespace
}  // namespace caustica
