// Morton codes against a bit-by-bit reference, and the counter-based sampler's contract.
#include <gtest/gtest.h>

#include <cstdlib>
#include <random>
#include <set>
#include <vector>

#include "renderer/base/morton.h"
#include "renderer/base/rng.h"

namespace caustica {
namespace {

uint32_t morton_reference(uint32_t x, uint32_t y, uint32_t z) {
  uint32_t code = 0;
  for (int b = 0; b < 10; ++b) {
    code |= ((x >> b) & 1u) << (3 * b);
    code |= ((y >> b) & 1u) << (3 * b + 1);
    code |= ((z >> b) & 1u) << (3 * b + 2);
  }
  return code;
}

TEST(Morton, MatchesBitwiseInterleaving) {
  std::mt19937 rng(7);
  for (int i = 0; i < 100000; ++i) {
    uint32_t x = rng() % 1024, y = rng() % 1024, z = rng() % 1024;
    uint32_t code = morton3_30(x, y, z);
    ASSERT_EQ(code, morton_reference(x, y, z));
    ASSERT_EQ(compact_bits_10(code), x);
    ASSERT_EQ(compact_bits_10(code >> 1), y);
    ASSERT_EQ(compact_bits_10(code >> 2), z);
  }
  EXPECT_EQ(morton3_30(1023, 1023, 1023), 0x3fffffffu);
}

// The first side^3 codes of a Hilbert curve fill the cube [0, side)^3 at its start, each cell
// taking its own code, and consecutive codes are face neighbours: the property that keeps a run
// of requests in Hilbert order compact (a Morton order jumps, also inside such a cube).
TEST(Hilbert, CellsTakeOneCodeEachAndConsecutiveCodesShareAFace) {
  for (uint32_t side : {2u, 8u, 32u}) {
    const uint32_t n = side * side * side;
    std::vector<int64_t> cell_of(n, -1);
    for (uint32_t z = 0; z < side; ++z)
      for (uint32_t y = 0; y < side; ++y)
        for (uint32_t x = 0; x < side; ++x) {
          const uint32_t code = hilbert3_30(x, y, z);
          ASSERT_LT(code, n) << x << " " << y << " " << z;
          ASSERT_EQ(cell_of[code], -1) << "code " << code << " twice";
          cell_of[code] = x + int64_t(side) * (y + int64_t(side) * z);
        }
    for (uint32_t c = 1; c < n; ++c) {
      const int64_t a = cell_of[c - 1], b = cell_of[c];
      const int64_t dx = a % side - b % side, dy = a / side % side - b / side % side,
                    dz = a / side / side - b / side / side;
      ASSERT_EQ(std::abs(dx) + std::abs(dy) + std::abs(dz), 1) << "codes " << c - 1 << ", " << c;
    }
  }
  EXPECT_EQ(hilbert3_30(0, 0, 0), 0u);
  const Aabb b{Vec3f(-1, 0, 1), Vec3f(1, 4, 21)};
  EXPECT_EQ(hilbert_code(Vec3f(0, 2, 11), b), hilbert3_30(512, 512, 512));
  EXPECT_EQ(hilbert_code(Vec3f(-5, -5, -5), b), 0u);
}

TEST(Morton, QuantisesPointsInBoundsAndClampsOutside) {
  Aabb b{Vec3f(-1, 0, 10), Vec3f(1, 4, 12)};
  EXPECT_EQ(morton_code(b.lower, b), 0u);
  EXPECT_EQ(morton_code(b.upper, b), 0x3fffffffu);
  EXPECT_EQ(morton_code(Vec3f(-5, -5, -5), b), 0u);
  EXPECT_EQ(morton_code(Vec3f(0, 2, 11), b), morton3_30(512, 512, 512));
  // A flat box (zero extent in y) still codes x and z.
  Aabb flat{Vec3f(0, 1, 0), Vec3f(1, 1, 1)};
  EXPECT_EQ(morton_code(Vec3f(1, 1, 1), flat), morton3_30(1023, 0, 1023));
}

// Huge boxes (diagonal over a quarter of the scene's) sort before all others; within a class
// the order is the Morton order of the centres.
TEST(Morton, ExtendedCodesPutHugeBoxesFirst) {
  const Aabb scene{Vec3f(0, 0, 0), Vec3f(100, 100, 100)};     // diagonal 173
  const Aabb wall{Vec3f(0, 0, 99), Vec3f(100, 100, 100)};     // 141: huge
  const Aabb ceiling{Vec3f(0, 99, 0), Vec3f(100, 100, 100)};  // 141: huge
  const Aabb block{Vec3f(10, 10, 10), Vec3f(30, 30, 30)};     // 34.6: not
  const Aabb grain{Vec3f(1, 1, 1), Vec3f(1.1f, 1.1f, 1.1f)};
  const Aabb point{Vec3f(99, 99, 99), Vec3f(99, 99, 99)};
  EXPECT_EQ(size_class(wall, scene), 0u);
  EXPECT_EQ(size_class(block, scene), 1u);
  EXPECT_EQ(size_class(grain, scene), 1u);
  EXPECT_EQ(size_class(point, scene), 1u);
  for (const Aabb& small : {block, grain, point}) {
    EXPECT_LT(extended_morton_code(wall, scene), extended_morton_code(small, scene));
    EXPECT_LT(extended_morton_code(ceiling, scene), extended_morton_code(small, scene));
    EXPECT_EQ(extended_morton_code(small, scene), (1u << 30) | morton_code(small.center(), scene));
  }
  EXPECT_EQ(extended_morton_code(wall, scene), morton_code(wall.center(), scene));
}

TEST(Sampler, IsAPureFunctionOfItsCounters) {
  Sampler a(42, 7, 3), b(42, 7, 3);
  for (int i = 0; i < 100; ++i) ASSERT_EQ(a.next_u32(), b.next_u32());
  Sampler c(42, 8, 3), d(43, 7, 3), e(42, 7, 4);
  Sampler ref(42, 7, 3);
  uint32_t first = ref.next_u32();
  EXPECT_NE(c.next_u32(), first);
  EXPECT_NE(d.next_u32(), first);
  EXPECT_NE(e.next_u32(), first);
}

TEST(Sampler, FloatsAreUniformInUnitInterval) {
  // Chi-squared over 64 bins for 640k draws from many streams: 99.9% quantile at 63 dof is ~104.
  constexpr int kBins = 64, kDraws = 640000;
  std::vector<int> bins(kBins);
  for (int i = 0; i < kDraws; ++i) {
    Sampler s(1, uint32_t(i / 4), 0);
    for (int j = 0; j < i % 4; ++j) s.next_float();
    float u = s.next_float();
    ASSERT_GE(u, 0.0f);
    ASSERT_LT(u, 1.0f);
    ++bins[int(u * kBins)];
  }
  double expected = double(kDraws) / kBins, chi2 = 0;
  for (int c : bins) chi2 += (c - expected) * (c - expected) / expected;
  EXPECT_LT(chi2, 104.0);
}

}  // namespace
}  // namespace caustica
