// The hierarchy over VKDE kernels' supports (photon/kernel_map.h) against brute force: a point
// query finds exactly the kernels whose support holds the point, every kernel sits in one leaf,
// and nodes exist only where an interval outgrows the leaf size.
#include "renderer/photon/kernel_map.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>
#include <set>
#include <vector>

#include "renderer/base/sampling.h"
#include "renderer/parallel/backend.h"

namespace caustica {
namespace {

// Kernels on the faces of a unit cube, with random footprints; `duplicates` of them share
// centres (equal codes).
std::vector<VkdeKernel> cube_kernels(size_t n, size_t duplicates, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<VkdeKernel> out;
  while (out.size() < n) {
    const int axis = int(u(rng) * 3) % 3;
    Vec3f p(u(rng), u(rng), u(rng));
    Vec3f normal(0.0f);
    const float side = u(rng) < 0.5f ? 0.0f : 1.0f;
    if (axis == 0) p.x = side, normal.x = side > 0 ? -1.0f : 1.0f;
    if (axis == 1) p.y = side, normal.y = side > 0 ? -1.0f : 1.0f;
    if (axis == 2) p.z = side, normal.z = side > 0 ? -1.0f : 1.0f;
    const Frame frame = Frame::from_normal(normal);
    const float scale = 0.002f + 0.05f * u(rng) * u(rng);
    const PhotonFootprint fp{frame.to_world(Vec3f(scale * (0.5f + u(rng)), 0.0f, 0.0f)),
                             frame.to_world(Vec3f(scale * (u(rng) - 0.5f), scale * u(rng), 0.0f))};
    const Photon photon{p, Vec3f(1.0f, 0.5f, 0.25f), normal};
    VkdeSettings s;
    s.spread = 1.0f;
    s.pivot = 0.1f;  // axes of about 0.03 to 0.1
    VkdeKernel k;
    if (!vkde_kernel(photon, fp, normal, 1.0f, s, k)) continue;
    const size_t copies = out.size() < duplicates ? 3 : 1;
    for (size_t c = 0; c < copies && out.size() < n; ++c) out.push_back(k);
  }
  return out;
}

std::vector<uint32_t> brute_force(const std::vector<VkdeKernel>& kernels, Vec3f x) {
  std::vector<uint32_t> out;
  for (uint32_t i = 0; i < kernels.size(); ++i)
    if (vkde_distance_squared(kernels[i], x) < 1.0f) out.push_back(i);
  return out;
}

// The leaves under `child`, each as [first, first + count), and whether every inner node holds
// more than `leaf_size` kernels.
void collect_leaves(const std::vector<KernelMapNode>& nodes, const KernelMapChild& child,
                    uint32_t leaf_size, std::vector<std::pair<uint32_t, uint32_t>>& leaves,
                    bool& nodes_outgrow_leaves, uint32_t& kernels_under) {
  if (is_leaf(child.index)) {
    leaves.push_back({leaf_index(child.index), child.count});
    kernels_under = child.count;
    return;
  }
  const KernelMapNode& node = nodes[child.index];
  uint32_t left = 0, right = 0;
  collect_leaves(nodes, node.child[0], leaf_size, leaves, nodes_outgrow_leaves, left);
  collect_leaves(nodes, node.child[1], leaf_size, leaves, nodes_outgrow_leaves, right);
  kernels_under = left + right;
  if (kernels_under <= leaf_size) nodes_outgrow_leaves = false;
}

class KernelMapTest : public testing::TestWithParam<uint32_t> {};

TEST_P(KernelMapTest, PointQueriesFindExactlyTheKernelsHoldingThePoint) {
  const uint32_t leaf_size = GetParam();
  auto backend = make_cpu_backend(size_t(1) << 30);
  const std::vector<VkdeKernel> kernels = cube_kernels(4000, 300, 7);
  Buffer<VkdeKernel> buffer(*backend, 0);
  buffer.upload(kernels);
  const KernelMap map = build_kernel_map(*backend, buffer, leaf_size);
  ASSERT_EQ(map.size(), kernels.size());
  const std::vector<VkdeKernel> sorted = map.kernels.download();
  const std::vector<KernelMapNode> nodes = map.nodes.download();

  // Every kernel in exactly one leaf, the leaves tiling the sorted order.
  std::vector<std::pair<uint32_t, uint32_t>> leaves;
  bool outgrow = true;
  uint32_t under = 0;
  collect_leaves(nodes, map.root, leaf_size, leaves, outgrow, under);
  EXPECT_EQ(under, kernels.size());
  EXPECT_TRUE(outgrow) << "an inner node holds no more than the leaf size";
  std::sort(leaves.begin(), leaves.end());
  uint32_t next = 0;
  for (const auto& [first, count] : leaves) {
    EXPECT_EQ(first, next);
    EXPECT_GT(count, 0u);
    next = first + count;
  }
  EXPECT_EQ(next, kernels.size());
  // Leaves are no bigger than needed: only an interval of equal codes outgrows the leaf size.
  EXPECT_GT(leaves.size(), kernels.size() / (2 * leaf_size + 3));

  // Point queries: at kernel centres and at random points on the faces.
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Vec3f> queries;
  for (size_t i = 0; i < kernels.size(); i += 7) queries.push_back(kernels[i].center);
  for (int i = 0; i < 1500; ++i) queries.push_back(Vec3f(u(rng), u(rng), i % 2 ? 0.0f : 1.0f));
  size_t found_total = 0;
  for (const Vec3f& x : queries) {
    std::vector<uint32_t> found;
    visit_kernels_at(map.view(), x, [&](uint32_t i, const VkdeKernel& k) {
      EXPECT_EQ(&k, &map.view().kernels[i]);
      if (vkde_distance_squared(k, x) < 1.0f) found.push_back(i);
    });
    // Compare as kernel contents: the map holds them in code order.
    std::vector<uint32_t> expected = brute_force(sorted, x);
    std::sort(found.begin(), found.end());
    EXPECT_EQ(found, expected);
    found_total += found.size();
  }
  EXPECT_GT(found_total, 2 * queries.size());  // the queries land in several kernels
}

INSTANTIATE_TEST_SUITE_P(LeafSizes, KernelMapTest, testing::Values(1u, 5u, 40u, 100000u));

TEST(KernelMap, SortedKernelsAreThePermutedInput) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  const std::vector<VkdeKernel> kernels = cube_kernels(500, 0, 11);
  Buffer<VkdeKernel> buffer(*backend, 0);
  buffer.upload(kernels);
  const std::vector<VkdeKernel> sorted = build_kernel_map(*backend, buffer, 5).kernels.download();
  auto key = [](const VkdeKernel& k) {
    return std::make_tuple(k.center.x, k.center.y, k.center.z, k.major.x, k.minor.y);
  };
  std::multiset<std::tuple<float, float, float, float, float>> a, b;
  for (const VkdeKernel& k : kernels) a.insert(key(k));
  for (const VkdeKernel& k : sorted) b.insert(key(k));
  EXPECT_EQ(a, b);
}

TEST(KernelMap, EmptyAndSingleKernelMaps) {
  auto backend = make_cpu_backend(size_t(1) << 30);
  Buffer<VkdeKernel> none(*backend, 0);
  const KernelMap empty = build_kernel_map(*backend, none, 5);
  int visits = 0;
  visit_kernels_at(empty.view(), Vec3f(0.0f), [&](uint32_t, const VkdeKernel&) { ++visits; });
  EXPECT_EQ(visits, 0);
  Buffer<VkdeKernel> one(*backend, 0);
  one.upload(cube_kernels(1, 0, 5));
  const KernelMap single = build_kernel_map(*backend, one, 5);
  EXPECT_TRUE(is_leaf(single.root.index));
  visit_kernels_at(single.view(), one.download()[0].center,
                   [&](uint32_t, const VkdeKernel&) { ++visits; });
  EXPECT_EQ(visits, 1);
}

// n_auto = c (sum of kernel areas) / (surface area), at least 5.
TEST(KernelMap, LeafSizeFollowsTheExpectedKernelsPerPoint) {
  EXPECT_EQ(kernel_leaf_size(100.0, 10.0), 80u);
  EXPECT_EQ(kernel_leaf_size(100.0, 10.0, 2.0), 20u);
  EXPECT_EQ(kernel_leaf_size(1.0, 10.0), 5u);
  EXPECT_EQ(kernel_leaf_size(1.0, 0.0), 5u);
}

}  // namespace
}  // namespace caustica
