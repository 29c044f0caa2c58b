// The sibling-pair nodes (sibling_pair.h) and the triangle structure stored in them
// (sibling_pair_bvh.h): boxes decoded bit for bit, the tree's invariants against the binary tree
// it was built from, its SAH cost, and closest and any hits against brute force.
#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <random>
#include <stdexcept>
#include <vector>

#include "renderer/accel/sibling_pair_traversal.h"
#include "renderer/scene/shapes.h"
#include "tests/renderer/accel/structure_checks.h"
#include "tests/renderer/accel/triangle_soup.h"

namespace caustica {
namespace {

bool same_box_bits(const Aabb& a, const Aabb& b) { return std::memcmp(&a, &b, sizeof(Aabb)) == 0; }

std::vector<TriangleVertices> sphere_triangles() {
  std::vector<TriangleVertices> tris;
  append_triangles(make_sphere(Vec3f(0.3f, -0.2f, 0.1f), 1.7f, 64, 128), tris);
  return tris;
}

// Boxes with shared planes, flat boxes, signed zeros and one box inside the other.
TEST(SiblingPairNode, DecodesBothChildrenBitForBit) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-4.0f, 4.0f);
  const float picks[] = {-0.0f, 0.0f, 1.0f, -1.0f, 2.5f};
  auto coordinate = [&] { return rng() % 3 == 0 ? picks[rng() % 5] : u(rng); };
  for (int i = 0; i < 20000; ++i) {
    Aabb box[2];
    for (Aabb& b : box) {
      for (int a = 0; a < 3; ++a) {
        float x = coordinate(), y = rng() % 4 == 0 ? x : coordinate();
        if (y < x) std::swap(x, y);
        b.lower[a] = x;
        b.upper[a] = y;
      }
    }
    if (i % 7 == 0) box[1] = box[0];
    SiblingPairNode n;
    ASSERT_TRUE(encode_sibling_pair(box[0], 12345u, box[1], kLeafFlag | 678u, n));
    EXPECT_EQ(sibling_reference(n.child[0]), 12345u);
    EXPECT_EQ(sibling_reference(n.child[1]), kLeafFlag | 678u);
    Aabb decoded[2];
    sibling_child_boxes(n, sibling_pair_box(box[0], box[1]), decoded[0], decoded[1]);
    ASSERT_TRUE(same_box_bits(decoded[0], box[0])) << i;
    ASSERT_TRUE(same_box_bits(decoded[1], box[1])) << i;
  }
}

struct SiblingBuild {
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(2) << 30);
  Buffer<TriangleVertices> input;
  std::vector<BvhNode> binary_nodes;
  uint32_t binary_root = 0;
  Aabb binary_bounds;
  std::vector<uint32_t> binary_ids;
  SiblingPairBvh bvh;
  explicit SiblingBuild(const std::vector<TriangleVertices>& tris) : input(*backend, tris.size()) {
    input.upload(tris);
    BinaryTriangleBvh binary =
        build_sah_refined_lbvh(*backend, input.data(), uint32_t(tris.size()), Curve::kHilbert);
    binary_nodes = binary.bvh.nodes.download();
    binary_root = binary.bvh.root;
    binary_bounds = binary.bvh.bounds;
    binary_ids = binary.triangle_ids.download();
    bvh = build_sibling_pair_bvh(*backend, std::move(binary));
  }
};

// Walks the sibling-pair tree and the binary tree together: every decoded box is the binary
// child's box bit for bit, an internal child stands for the binary child, a leaf covers exactly
// the binary child's range of up to kMaxLeafTriangles triangles and is where the 4-wide collapse
// would end a leaf, every node and triangle is reached once, and each node's internal children
// lie on the next level. Returns the SAH cost walked on the host.
double check_sibling_invariants(const std::vector<TriangleVertices>& tris) {
  SiblingBuild b(tris);
  const size_t n = tris.size();
  const SiblingPairBvh& t = b.bvh;
  EXPECT_EQ(t.triangle_count, n);
  EXPECT_EQ(t.triangle_ids.download(), b.binary_ids);
  const std::vector<SiblingPairNode> nodes = t.nodes.download();
  EXPECT_EQ(nodes.size(), t.level_starts.back());
  EXPECT_LT(nodes.size(), n);
  const std::vector<uint32_t>& levels = t.level_starts;
  auto level_of = [&](uint32_t node) {
    size_t l = 0;
    while (levels[l + 1] <= node) ++l;
    return l;
  };
  std::vector<int> node_seen(nodes.size(), 0), triangle_seen(n, 0);
  const double root_area = t.bounds.half_area();
  double cost = 1.0;
  std::function<void(uint32_t, uint32_t, uint32_t, uint32_t, const Aabb&)> walk =
      [&](uint32_t node, uint32_t binary, uint32_t first, uint32_t last, const Aabb& box) {
        ASSERT_LT(node, nodes.size());
        ASSERT_EQ(++node_seen[node], 1) << "node " << node << " reached twice";
        Aabb child_box[2];
        sibling_child_boxes(nodes[node], box, child_box[0], child_box[1]);
        for (int c = 0; c < 2; ++c) {
          const BvhChild& expected = b.binary_nodes[binary].child[c];
          ASSERT_TRUE(same_box_bits(child_box[c], expected.bounds()))
              << "node " << node << " child " << c;
          const uint32_t from = c == 0 ? first : binary + 1, to = c == 0 ? binary : last;
          const uint32_t reference = sibling_reference(nodes[node].child[c]);
          const double area = child_box[c].half_area() / root_area;
          if (is_leaf(reference)) {
            ASSERT_EQ(sibling_leaf_first(reference), from);
            ASSERT_EQ(sibling_leaf_count(reference), to - from + 1);
            ASSERT_LE(to - from + 1, kMaxLeafTriangles);
            ASSERT_TRUE(binary_subtree_becomes_leaf(b.binary_nodes.data(), expected.index,
                                                    to - from + 1, expected.bounds(),
                                                    b.binary_bounds));
            for (uint32_t i = from; i <= to; ++i) ++triangle_seen[i];
            cost += area * (to - from + 1);
          } else {
            ASSERT_FALSE(is_leaf(expected.index));
            ASSERT_EQ(level_of(reference), level_of(node) + 1);
            cost += area;
            walk(reference, expected.index, from, to, child_box[c]);
          }
          if (::testing::Test::HasFatalFailure()) return;
        }
      };
  if (n < 2) return 1.0;
  // The root decodes from its children's union, the binary tree's bounds up to the sign of zero.
  EXPECT_EQ(t.bounds.lower, b.binary_bounds.lower);
  EXPECT_EQ(t.bounds.upper, b.binary_bounds.upper);
  walk(0, b.binary_root, 0, uint32_t(n - 1), t.bounds);
  if (::testing::Test::HasFatalFailure()) return cost;
  for (int s : node_seen) EXPECT_EQ(s, 1);
  for (int s : triangle_seen) EXPECT_EQ(s, 1);
  EXPECT_NEAR(sah_cost(*b.backend, t), cost, 1e-4 * cost);
  return cost;
}

TEST(SiblingPair, InvariantsAndSahCostOnRandomSoups) {
  for (size_t n : {size_t(2), size_t(3), size_t(5), size_t(300), size_t(40000)}) {
    SCOPED_TRACE(n);
    check_sibling_invariants(random_soup(n, uint32_t(3 + n)));
  }
}

TEST(SiblingPair, InvariantsOnBundledScenesAndAClosedMesh) {
  check_sibling_invariants(scene_triangles("cornell-caustics"));
  check_sibling_invariants(scene_triangles("ring"));
  check_sibling_invariants(sphere_triangles());
  check_sibling_invariants(
      std::vector<TriangleVertices>(700, {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)}));
}

void check_sibling_rays(const std::vector<TriangleVertices>& tris, int rays, uint32_t seed) {
  SiblingBuild b(tris);
  check_rays(tris, b.bvh.view(), rays, seed);
}

TEST(SiblingPair, MatchesBruteForce) {
  check_sibling_rays(random_soup(4000, 99), 6000, 1);
  check_sibling_rays(sphere_triangles(), 6000, 8);
  check_sibling_rays(scene_triangles("cornell-caustics"), 6000, 2);
  check_sibling_rays(scene_triangles("ring"), 2000, 4);
  for (size_t n = 1; n <= 9; ++n) {
    SCOPED_TRACE(n);
    SiblingBuild b(random_soup(n, uint32_t(100 + n)));
    check_rays(random_soup(n, uint32_t(100 + n)), b.bvh.view(), 400, uint32_t(n), true);
  }
}

// A leaf's first triangle has 26 bits: a larger tree is refused before anything is built.
TEST(SiblingPair, RefusesMoreTrianglesThanItsLeavesAddress) {
  auto backend = make_cpu_backend(size_t(1) << 28);
  BinaryTriangleBvh too_many;
  too_many.bvh.leaf_count = kMaxSiblingPairTriangles + 1;
  too_many.bvh.nodes.bind(*backend);
  too_many.triangles.bind(*backend);
  too_many.triangle_ids.bind(*backend);
  EXPECT_THROW(build_sibling_pair_bvh(*backend, std::move(too_many)), std::invalid_argument);
}

}  // namespace
}  // namespace caustica
