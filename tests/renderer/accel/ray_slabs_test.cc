// The fused multiply-add slab test against the same intervals computed in double precision: it
// must never miss a box the ray's segment enters (the traversal would lose hits), must report an
// entry distance no later than the true one, and must still reject boxes clearly missed.
#include "renderer/accel/ray_slabs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace caustica {
namespace {

// The entry and exit distances of the ray with reciprocal `inv` (as the traversal computes it)
// through box b, in double precision, clipped to [t_min, t_max].
struct Interval {
  double enter, leave;
};
Interval exact_interval(const Aabb& b, Vec3f origin, Vec3f inv, float t_min, float t_max) {
  double enter = t_min, leave = t_max;
  for (int a = 0; a < 3; ++a) {
    const double t0 = (double(b.lower[a]) - origin[a]) * inv[a];
    const double t1 = (double(b.upper[a]) - origin[a]) * inv[a];
    enter = std::max(enter, std::min(t0, t1));
    leave = std::min(leave, std::max(t0, t1));
  }
  return {enter, leave};
}

// Checks one ray and box: a clear hit in double is a hit no later than the true entry, a clear
// miss is a miss. A miss is clear beyond the test's stated slack: relative 1e-3 of the distances,
// plus what it widens each slab by for the rounding of -o / d (2^-22 |o / d| on each side and the
// roundings themselves: under 2^-20 |o / d|). Returns +1 for a hit, -1 for a miss, 0 when too
// close to call.
int check(const Aabb& b, Vec3f origin, Vec3f direction, float t_min, float t_max) {
  const RaySlabs s = ray_slabs(origin, direction, b);
  const Vec3f inv = safe_reciprocal(direction);
  const Interval exact = exact_interval(b, origin, inv, t_min, t_max);
  const float got = slab_entry(s, b, t_min, t_max);
  const double scale = std::max({std::fabs(exact.enter), std::fabs(exact.leave), 1e-30});
  if (exact.leave - exact.enter > 1e-9 * scale) {
    EXPECT_LE(got, exact.enter + 1e-6 * scale)
        << "missed or entered late: origin " << origin.x << " " << origin.y << " " << origin.z;
    return 1;
  }
  const double widening =
      0x1p-20 * std::max({std::fabs(double(origin.x) * inv.x), std::fabs(double(origin.y) * inv.y),
                          std::fabs(double(origin.z) * inv.z)});
  if (exact.enter - exact.leave > 1e-3 * scale + widening) {
    EXPECT_EQ(got, INFINITY) << "hit a box it misses by " << exact.enter - exact.leave;
    return -1;
  }
  return 0;
}

TEST(RaySlabs, NeverMissesABoxFarFromTheWorldOrigin) {
  // Origins far out and boxes close by: the rounding of -o / d is then large against the
  // distances, and a test that ignored it would lose boxes the ray passes through near an edge.
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  int hits = 0, misses = 0;
  for (int i = 0; i < 200000; ++i) {
    const float far = std::pow(10.0f, float(i % 6));  // 1 .. 1e5
    const Vec3f origin(far * unit(rng), far * unit(rng), far * unit(rng));
    Vec3f direction(unit(rng), unit(rng), unit(rng));
    if (length(direction) < 1e-3f) continue;
    direction = normalize(direction);
    // A box of size about 1e-3 at a distance of about 1e-2 along the ray, nudged sideways by up
    // to about its size, so that many rays graze it.
    const float t = 0.01f * (1.0f + unit(rng));
    const Vec3f centre = origin + direction * t + Vec3f(unit(rng), unit(rng), unit(rng)) * 1e-3f;
    const Vec3f half = Vec3f(1.0f + unit(rng), 1.0f + unit(rng), 1.0f + unit(rng)) * 5e-4f;
    const Aabb box{centre - half, centre + half};
    const int r = check(box, origin, direction, 0.0f, 1.0f);
    hits += r > 0;
    misses += r < 0;
  }
  EXPECT_GT(hits, 10000);
  EXPECT_GT(misses, 10000);
}

// An entry distance no later than `exact` and earlier by no more than the bound on the rounding
// (2^-21 of the distances' terms, at most 1e-5 here).
void expect_entry(float got, float exact) {
  EXPECT_LE(got, exact);
  EXPECT_GE(got, exact - 1e-5f);
}

TEST(RaySlabs, AxisParallelRays) {
  // A zero component: the slab of that axis either holds the origin (no bound) or not (a miss).
  const Aabb box{Vec3f(-1.0f, 2.0f, -1.0f), Vec3f(1.0f, 3.0f, 1.0f)};
  auto entry = [&](Vec3f origin, Vec3f direction, float t_min, float t_max) {
    return slab_entry(ray_slabs(origin, direction, box), box, t_min, t_max);
  };
  expect_entry(entry(Vec3f(0.5f, 0.0f, -0.5f), Vec3f(0, 1, 0), 0.0f, 10.0f), 2.0f);
  EXPECT_EQ(entry(Vec3f(1.5f, 0.0f, 0.0f), Vec3f(0, 1, 0), 0.0f, 10.0f), INFINITY);
  // On the slab's plane itself: touching counts as entering.
  EXPECT_LE(entry(Vec3f(1.0f, 0.0f, 1.0f), Vec3f(0, 1, 0), 0.0f, 10.0f), 2.0f);
  EXPECT_EQ(entry(Vec3f(0.0f, 0.0f, 0.0f), Vec3f(0, -1, 0), 0.0f, 10.0f), INFINITY);
  // Out of [t_min, t_max].
  EXPECT_EQ(entry(Vec3f(0.0f, 0.0f, 0.0f), Vec3f(0, 1, 0), 0.0f, 1.5f), INFINITY);
  EXPECT_EQ(entry(Vec3f(0.0f, 0.0f, 0.0f), Vec3f(0, 1, 0), 3.5f, 10.0f), INFINITY);
}

TEST(RaySlabs, HugeCoordinateOnAParallelAxisStillHits) {
  // o / d overflows on x (o.x = 1e20, d.x = 0): that axis bounds nothing, and the box is found.
  const Aabb box{Vec3f(0.99e20f, 5.0f, -1.0f), Vec3f(1.01e20f, 6.0f, 1.0f)};
  const RaySlabs s = ray_slabs(Vec3f(1e20f, 0.0f, 0.0f), Vec3f(0, 1, 0), box);
  expect_entry(slab_entry(s, box, 0.0f, 100.0f), 5.0f);
  EXPECT_EQ(slab_entry(s, box, 0.0f, 4.0f), INFINITY);
}

// A 4-wide node's empty slots hold Aabb{} (lower corner FLT_MAX, upper -FLT_MAX) and the
// traversal tests them like any other child, trusting that no ray enters them: rays of every
// direction, axis-parallel ones among them, from origins up to 1e30 out (where -o / d overflows on
// some axes and those axes bound nothing), over the whole line.
TEST(RaySlabs, EveryRayMissesTheEmptyBox) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> unit(-1.0f, 1.0f);
  const Aabb empty{};
  for (int i = 0; i < 200000; ++i) {
    const float far = std::pow(10.0f, float(i % 31));  // 1 .. 1e30
    const Vec3f origin(far * unit(rng), far * unit(rng), far * unit(rng));
    Vec3f direction(unit(rng), unit(rng), unit(rng));
    if (i % 7 == 0) direction[i % 3] = 0.0f;  // parallel to a plane
    if (i % 11 == 0) {                        // along an axis
      direction = Vec3f(0.0f);
      direction[i % 3] = 1.0f;
    }
    if (length(direction) < 1e-3f) continue;
    direction = normalize(direction);
    const Aabb within{Vec3f(-far), Vec3f(far)};  // the structure the empty slot belongs to
    ASSERT_EQ(slab_entry(ray_slabs(origin, direction, within), empty, -INFINITY, INFINITY),
              INFINITY)
        << i;
  }
}

TEST(RaySlabs, OrderedNodeRowsFollowTheDirectionSigns) {
  Bvh4Node node{};
  for (int c = 0; c < 4; ++c) {
    node.lower_x[c] = float(c);
    node.upper_x[c] = float(c) + 0.5f;
    node.lower_y[c] = 10.0f + c;
    node.upper_y[c] = 10.5f + c;
    node.lower_z[c] = 20.0f + c;
    node.upper_z[c] = 20.5f + c;
    node.child[c] = uint32_t(c);
  }
  const OrderedNode n = load_ordered_node(
      &node, ray_slabs(Vec3f(0.0f), Vec3f(1.0f, -1.0f, 0.0f), Aabb{Vec3f(-100.0f), Vec3f(100.0f)}));
  for (int c = 0; c < 4; ++c) {
    EXPECT_EQ(n.enter[0][c], node.lower_x[c]);
    EXPECT_EQ(n.leave[0][c], node.upper_x[c]);
    EXPECT_EQ(n.enter[1][c], node.upper_y[c]);
    EXPECT_EQ(n.leave[1][c], node.lower_y[c]);
    EXPECT_EQ(n.enter[2][c], node.lower_z[c]);  // +0: safe_reciprocal keeps the sign, positive
    EXPECT_EQ(n.child[c], node.child[c]);
  }
}

}  // namespace
}  // namespace caustica
