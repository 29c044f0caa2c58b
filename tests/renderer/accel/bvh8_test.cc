// The H-PLOC tree and its 8-wide compressed collapse: every triangle once, boxes that hold what
// they bound, the layout's rules, the same tree from every build, and a tree no worse than the
// radix tree's. Hits against brute force are EveryStructure's (structure_test.cc).
#include "renderer/accel/bvh8.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <vector>

#include "renderer/accel/hploc.h"
#include "renderer/accel/structure.h"
#include "renderer/scene/shapes.h"
#include "tests/renderer/accel/structure_checks.h"
#include "tests/renderer/accel/structure_snapshot.h"
#include "tests/renderer/accel/triangle_soup.h"

namespace caustica {
namespace {

struct Input {
  std::unique_ptr<Backend> backend = make_cpu_backend(size_t(2) << 30);
  Buffer<TriangleVertices> triangles;
  explicit Input(const std::vector<TriangleVertices>& tris) : triangles(*backend, tris.size()) {
    triangles.upload(tris);
  }
  uint32_t count() const { return uint32_t(triangles.size()); }
};

// Walks the binary tree: every leaf once, every internal node once, each child's box exactly the
// union of what it holds and its size its triangle count. Returns the sum of the inner nodes'
// areas over the root's, the SAH cost of the inner nodes.
double check_hploc_tree(const ClusteredTriangleBvh& t, const std::vector<TriangleVertices>& tris) {
  const size_t n = tris.size();
  EXPECT_EQ(t.count, n);
  const std::vector<BvhNode> nodes = t.nodes.download();
  const std::vector<TriangleVertices> sorted = t.triangles.download();
  const std::vector<uint32_t> ids = t.triangle_ids.download();
  EXPECT_EQ(nodes.size(), n - 1);
  std::vector<int> id_seen(n, 0), leaf_seen(n, 0), node_seen(nodes.size(), 0);
  for (size_t i = 0; i < n; ++i) {
    EXPECT_LT(ids[i], n);
    if (ids[i] < n) {
      ++id_seen[ids[i]];
      EXPECT_EQ(sorted[i].p1, tris[ids[i]].p1);
    }
  }
  for (int c : id_seen) EXPECT_EQ(c, 1);
  double inner_area = 0.0;
  // Returns the subtree's box and size.
  std::function<std::pair<Aabb, uint32_t>(uint32_t)> walk = [&](uint32_t id) {
    if (is_leaf(id)) {
      const uint32_t leaf = leaf_index(id);
      EXPECT_LT(leaf, n);
      if (leaf >= n) return std::pair<Aabb, uint32_t>{Aabb{}, 0};
      ++leaf_seen[leaf];
      return std::pair<Aabb, uint32_t>{triangle_bounds(sorted[leaf]), 1};
    }
    EXPECT_LT(id, nodes.size());
    if (id >= nodes.size()) return std::pair<Aabb, uint32_t>{Aabb{}, 0};
    EXPECT_EQ(++node_seen[id], 1) << "node " << id << " reached twice";
    Aabb box;
    uint32_t size = 0;
    for (int c = 0; c < 2; ++c) {
      const BvhChild& child = nodes[id].child[c];
      const auto [b, s] = walk(child.index);
      EXPECT_EQ(child.lower, b.lower) << "node " << id << " child " << c;
      EXPECT_EQ(child.upper, b.upper) << "node " << id << " child " << c;
      EXPECT_EQ(child.unused, s) << "node " << id << " child " << c << ": size";
      box.extend(b);
      size += s;
    }
    inner_area += box.half_area();
    return std::pair<Aabb, uint32_t>{box, size};
  };
  const auto [root_box, root_size] = walk(t.root);
  EXPECT_EQ(root_size, n);
  EXPECT_EQ(root_box.lower, t.bounds.lower);
  EXPECT_EQ(root_box.upper, t.bounds.upper);
  for (int c : leaf_seen) EXPECT_EQ(c, 1);
  for (int c : node_seen) EXPECT_EQ(c, 1);
  return inner_area / t.bounds.half_area();
}

// The exact planes of slot s's quantised box.
void exact_child_box(const Bvh8Node& n, int s, double lower[3], double upper[3]) {
  const uint8_t* lo[3] = {n.lower_x, n.lower_y, n.lower_z};
  const uint8_t* hi[3] = {n.upper_x, n.upper_y, n.upper_z};
  for (int a = 0; a < 3; ++a) {
    const double step = std::ldexp(1.0, int(n.exponent[a]) - 127);
    lower[a] = double(n.p[a]) + lo[a][s] * step;
    upper[a] = double(n.p[a]) + hi[a][s] * step;
  }
}

// Walks the 8-wide tree: every node once, at most `depth` levels; each used slot's quantised box
// holds the exact box of its subtree; internal children at consecutive indices in slot order;
// leaves of 1 to 3 triangles whose offsets tile the node's triangle range from 0; every triangle
// in exactly one leaf, with the id of the triangle stored there.
void check_bvh8(const Bvh8& b, const std::vector<TriangleVertices>& tris) {
  const size_t n = tris.size();
  ASSERT_EQ(b.count, n);
  const std::vector<Bvh8Node> nodes = b.nodes.download();
  const std::vector<TriangleVertices> stored = b.triangles.download();
  const std::vector<uint32_t> ids = b.triangle_ids.download();
  ASSERT_EQ(stored.size(), n);
  ASSERT_GE(nodes.size(), 1u);
  ASSERT_LE(nodes.size(), std::max<size_t>(1, n - 1));
  std::vector<int> node_seen(nodes.size(), 0), triangle_seen(n, 0);
  uint32_t deepest = 0;
  size_t leaves = 0;
  std::function<Aabb(uint32_t, uint32_t)> walk = [&](uint32_t index, uint32_t level) {
    Aabb box;
    EXPECT_LT(index, nodes.size());
    if (index >= nodes.size()) return box;
    EXPECT_EQ(++node_seen[index], 1) << "node " << index << " reached twice";
    deepest = std::max(deepest, level);
    const Bvh8Node& node = nodes[index];
    uint32_t rank = 0, offset = 0, used = 0;
    uint8_t imask = 0;
    for (int s = 0; s < 8; ++s) {
      const uint8_t meta = node.meta[s];
      if (meta == 0) continue;
      ++used;
      Aabb child;
      if (bvh8_slot_is_internal(meta)) {
        EXPECT_EQ(meta & 7, s) << "node " << index;
        imask |= uint8_t(1u << s);
        child = walk(node.child_base + rank++, level + 1);
      } else {
        const uint32_t count = bvh8_leaf_triangles(meta);
        EXPECT_EQ(meta >> 5, (1u << count) - 1u) << "node " << index << " slot " << s;
        EXPECT_GE(count, 1u);
        EXPECT_EQ(meta & 31u, offset) << "node " << index << " slot " << s;
        ++leaves;
        for (uint32_t k = 0; k < count; ++k, ++offset) {
          const uint32_t at = node.triangle_base + offset;
          EXPECT_LT(at, n);
          if (at >= n) continue;
          EXPECT_LT(ids[at], n);
          if (ids[at] >= n) continue;
          ++triangle_seen[ids[at]];
          EXPECT_EQ(stored[at].p2, tris[ids[at]].p2);
          child.extend(triangle_bounds(stored[at]));
        }
      }
      double lo[3], hi[3];
      exact_child_box(node, s, lo, hi);
      for (int a = 0; a < 3; ++a) {
        EXPECT_LE(lo[a], child.lower[a]) << "node " << index << " slot " << s << " axis " << a;
        EXPECT_GE(hi[a], child.upper[a]) << "node " << index << " slot " << s << " axis " << a;
      }
      box.extend(child);
    }
    EXPECT_EQ(imask, node.imask) << "node " << index;
    EXPECT_GE(used, n >= 2 ? 2u : 1u) << "node " << index;
    return box;
  };
  const Aabb all = walk(0, 1);
  EXPECT_EQ(all.lower, b.bounds.lower);
  EXPECT_EQ(all.upper, b.bounds.upper);
  EXPECT_EQ(deepest, b.depth);
  for (int c : node_seen) EXPECT_EQ(c, 1);
  for (int c : triangle_seen) EXPECT_EQ(c, 1);
  std::printf(
      "%zu triangles: %zu 8-wide nodes (%.1f B/triangle), %zu leaves (%.2f triangles each), "
      "%u levels\n",
      n, nodes.size(), double(nodes.size() * sizeof(Bvh8Node)) / double(n), leaves,
      double(n) / double(leaves), b.depth);
}

void check_both(const std::vector<TriangleVertices>& tris) {
  Input in(tris);
  {
    SCOPED_TRACE("h-ploc");
    check_hploc_tree(build_hploc_bvh(*in.backend, in.triangles.data(), in.count(), Curve::kMorton),
                     tris);
  }
  SCOPED_TRACE("8-wide");
  check_bvh8(build_bvh8(*in.backend, in.triangles.data(), in.count(), Curve::kHilbert), tris);
}

std::vector<TriangleVertices> sphere_triangles() {
  std::vector<TriangleVertices> tris;
  append_triangles(make_sphere(Vec3f(0.3f, -0.2f, 0.1f), 1.7f, 64, 128), tris);
  return tris;
}

// Sizes around the merging threshold and the leaf limit, and large enough for many merges.
TEST(Bvh8, InvariantsOnRandomSoups) {
  for (size_t n : {size_t(2), size_t(3), size_t(4), size_t(9), size_t(kHplocMaxClusters),
                   size_t(kHplocMaxClusters + 1), size_t(2 * kHplocMaxClusters + 1), size_t(1000),
                   size_t(40000)}) {
    SCOPED_TRACE(n);
    check_both(random_soup(n, uint32_t(11 + n)));
  }
}

TEST(Bvh8, InvariantsOnBundledScenesAndAClosedMesh) {
  check_both(scene_triangles("cornell-caustics"));
  check_both(scene_triangles("ring"));
  check_both(sphere_triangles());
}

// Equal boxes tie at every merge: the pairs' positions decide.
TEST(Bvh8, InvariantsWhenEveryTriangleCoincides) {
  check_both(std::vector<TriangleVertices>(700, {Vec3f(0, 0, 0), Vec3f(1, 0, 0), Vec3f(0, 1, 0)}));
}

// The node numbers come from atomic counters taken by threads in any order; the tree does not.
TEST(Bvh8, EveryBuildIsTheSameTree) {
  const std::vector<TriangleVertices> tris = random_soup(60000, 3);
  Input in(tris);
  const Bvh8 first = build_bvh8(*in.backend, in.triangles.data(), in.count(), Curve::kMorton);
  const Bvh8 second = build_bvh8(*in.backend, in.triangles.data(), in.count(), Curve::kMorton);
  EXPECT_EQ(structure_snapshot(*in.backend, first.view(), first.node_count()),
            structure_snapshot(*in.backend, second.view(), second.node_count()));
}

// Clustering by merged area finds tighter inner boxes than the curve's octree cells.
TEST(Bvh8, HplocInnerNodesCostLessThanTheRadixTrees) {
  for (const std::vector<TriangleVertices>& tris :
       {sphere_triangles(), random_soup(40000, 5), scene_triangles("cornell-caustics")}) {
    Input in(tris);
    const double hploc = check_hploc_tree(
        build_hploc_bvh(*in.backend, in.triangles.data(), in.count(), Curve::kMorton), tris);
    const double radix = internal_area_cost(
        build_triangle_lbvh(*in.backend, in.triangles.data(), in.count(), Curve::kMorton));
    std::printf("%zu triangles: inner-node SAH h-ploc %.1f, radix tree %.1f\n", tris.size(), hploc,
                radix);
    EXPECT_LT(hploc, radix);
  }
}

}  // namespace
}  // namespace caustica
