// The hybrid build (hybrid_bvh.h): the binary tree's invariants, the LBVH's splits kept above the
// cut, the same tree from every build, and closest and any hits against brute force.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <functional>
#include <stdexcept>
#include <vector>

#include "renderer/accel/hybrid_bvh.h"
#include "renderer/accel/sah_subtrees.h"
#include "renderer/scene/shapes.h"
#include "tests/renderer/accel/structure_checks.h"
#include "tests/renderer/accel/triangle_soup.h"

namespace caustica {
namespace {

struct HybridBuild {
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(2) << 30);
  Buffer<TriangleVertices> input;
  BinaryTriangleBvh binary;
  HybridBuild(const std::vector<TriangleVertices>& tris, uint32_t limit)
      : input(*backend, tris.size()) {
    input.upload(tris);
    binary =
        build_hybrid_bvh(*backend, input.data(), uint32_t(tris.size()), Curve::kHilbert, limit);
  }
};

std::vector<TriangleVertices> sphere_triangles() {
  std::vector<TriangleVertices> tris;
  append_triangles(make_sphere(Vec3f(0.3f, -0.2f, 0.1f), 1.7f, 64, 128), tris);
  return tris;
}

void check_hybrid_invariants(const std::vector<TriangleVertices>& tris, uint32_t limit) {
  HybridBuild b(tris, limit);
  {
    SCOPED_TRACE("binary");
    check_binary_invariants(b.binary, tris);
  }
  if (::testing::Test::HasFatalFailure()) return;
  SCOPED_TRACE("collapsed");
  const TriangleBvh wide = collapse_triangle_bvh(*b.backend, std::move(b.binary));
  check_wide_invariants(wide, tris);
}

// Below, at and above the limits of both stages, with cuts that leave a few subtrees of several
// data-parallel levels each, and at the chosen limit.
TEST(Hybrid, InvariantsOnRandomSoups) {
  for (uint32_t limit : {uint32_t(2), uint32_t(600), uint32_t(4096), kHybridLbvhSubtreeTriangles}) {
    for (size_t n : {size_t(2), size_t(3), size_t(BinnedSahSchedule{}.per_node_limit() + 1),
                     size_t(kSahSubtreeTriangles + 1), size_t(5000), size_t(40000)}) {
      SCOPED_TRACE(testing::Message() << n << " triangles, limit " << limit);
      check_hybrid_invariants(random_soup(n, uint32_t(11 + n)), limit);
    }
  }
}

TEST(Hybrid, InvariantsOnBundledSceneAndAClosedMesh) {
  check_hybrid_invariants(scene_triangles("cornell-caustics"), 1024);
  check_hybrid_invariants(sphere_triangles(), 2048);
  // Coincident triangles: no segment's centroids can be binned.
  check_hybrid_invariants(
      std::vector<TriangleVertices>(3000, {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)}), 1000);
}

// Above the cut the hybrid is the LBVH itself: every node covering more than the limit has the
// LBVH's index (its split position), child boxes and children, a single-triangle child keeps its
// triangle, and a child at or below the limit covers the same triangles, rebuilt.
void check_lbvh_above_cut(const std::vector<TriangleVertices>& tris, uint32_t limit) {
  HybridBuild b(tris, limit);
  Buffer<TriangleVertices> input(*b.backend, tris.size());
  input.upload(tris);
  const BinaryTriangleBvh lbvh =
      build_triangle_lbvh(*b.backend, input.data(), uint32_t(tris.size()), Curve::kHilbert);
  const std::vector<BvhNode> l_nodes = lbvh.bvh.nodes.download(),
                             h_nodes = b.binary.bvh.nodes.download();
  const std::vector<uint32_t> l_ids = lbvh.triangle_ids.download(),
                              h_ids = b.binary.triangle_ids.download();
  ASSERT_GT(tris.size(), limit);
  ASSERT_EQ(b.binary.bvh.root, lbvh.bvh.root);
  EXPECT_EQ(b.binary.bvh.bounds.lower, lbvh.bvh.bounds.lower);
  EXPECT_EQ(b.binary.bvh.bounds.upper, lbvh.bvh.bounds.upper);
  size_t kept = 0, rebuilt = 0;
  std::function<void(uint32_t, uint32_t, uint32_t)> walk = [&](uint32_t node, uint32_t first,
                                                               uint32_t last) {
    ++kept;
    for (int c = 0; c < 2; ++c) {
      const BvhChild& l = l_nodes[node].child[c];
      const BvhChild& h = h_nodes[node].child[c];
      ASSERT_EQ(0, std::memcmp(&l.lower, &h.lower, sizeof(Vec3f))) << "node " << node;
      ASSERT_EQ(0, std::memcmp(&l.upper, &h.upper, sizeof(Vec3f))) << "node " << node;
      const uint32_t from = c == 0 ? first : node + 1, to = c == 0 ? node : last;
      if (to - from + 1 > limit) {
        ASSERT_EQ(h.index, l.index) << "node " << node << " child " << c;
        walk(l.index, from, to);
      } else if (from == to) {
        ASSERT_EQ(h.index, l.index) << "node " << node << " child " << c;
        ASSERT_EQ(h_ids[from], l_ids[from]);
      } else {
        ++rebuilt;
        ASSERT_FALSE(is_leaf(h.index));
        ASSERT_GE(h.index, from);
        ASSERT_LT(h.index, to);
        std::vector<uint32_t> l_range(l_ids.begin() + from, l_ids.begin() + to + 1),
            h_range(h_ids.begin() + from, h_ids.begin() + to + 1);
        std::sort(l_range.begin(), l_range.end());
        std::sort(h_range.begin(), h_range.end());
        ASSERT_EQ(l_range, h_range) << "subtree [" << from << ", " << to << "]";
      }
      if (::testing::Test::HasFatalFailure()) return;
    }
  };
  walk(lbvh.bvh.root, 0, uint32_t(tris.size() - 1));
  EXPECT_GT(kept, 1u);
  EXPECT_GT(rebuilt, 1u);
}

TEST(Hybrid, TopLevelsAreTheLbvhsSplits) {
  check_lbvh_above_cut(random_soup(40000, 5), 600);
  check_lbvh_above_cut(random_soup(40000, 6), 4096);
  check_lbvh_above_cut(sphere_triangles(), 1024);
}

// The binned stage's atomics reduce to the same values in any order and its sorts are stable, the
// segments are ordered by position whatever order the LBVH listed them in: every build is the same
// tree.
TEST(Hybrid, EveryBuildIsTheSameTree) {
  const std::vector<TriangleVertices> tris = random_soup(60000, 3);
  for (uint32_t limit : {uint32_t(1000), kHybridLbvhSubtreeTriangles}) {
    HybridBuild first(tris, limit), second(tris, limit);
    expect_same_binary_tree(first.binary, second.binary);
  }
}

// Binned SAH below the cut places the subtrees' splits by the surface, not by the curve's cells:
// the inner nodes cost less than the LBVH's.
TEST(Hybrid, InnerNodesCostLessThanTheRadixTrees) {
  for (const std::vector<TriangleVertices>& tris : {sphere_triangles(), random_soup(40000, 5)}) {
    HybridBuild b(tris, 4096);
    Buffer<TriangleVertices> input(*b.backend, tris.size());
    input.upload(tris);
    const BinaryTriangleBvh radix =
        build_triangle_lbvh(*b.backend, input.data(), uint32_t(tris.size()), Curve::kHilbert);
    EXPECT_LT(internal_area_cost(b.binary), internal_area_cost(radix));
  }
}

TEST(Hybrid, MatchesBruteForceWithSeveralCuts) {
  const std::vector<TriangleVertices> tris = random_soup(20000, 77);
  for (uint32_t limit : {uint32_t(2), uint32_t(700), uint32_t(5000)}) {
    SCOPED_TRACE(limit);
    HybridBuild b(tris, limit);
    const TriangleBvh wide = collapse_triangle_bvh(*b.backend, std::move(b.binary));
    check_rays(tris, wide.view(), 3000, limit);
  }
}

TEST(Hybrid, RejectsALimitBelowTwo) {
  auto backend = make_cpu_backend(size_t(1) << 28);
  Buffer<TriangleVertices> input(*backend, 10);
  input.upload(random_soup(10, 1));
  EXPECT_THROW(build_hybrid_bvh(*backend, input.data(), 10, Curve::kHilbert, 1),
               std::invalid_argument);
}

}  // namespace
}  // namespace caustica
