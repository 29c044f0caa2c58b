// Checks shared by the structure suites: tree invariants, and closest and any hits against brute
// force over every triangle.
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <cstring>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "renderer/accel/ray_queries.h"
#include "renderer/accel/traversal.h"
#include "renderer/base/morton.h"
#include "renderer/base/sampling.h"
#include "renderer/parallel/buffer.h"
#include "renderer/scene/load_scene.h"

namespace caustica {

inline void append_triangles(const Mesh& m, std::vector<TriangleVertices>& tris) {
  for (size_t t = 0; t < m.triangle_count(); ++t)
    tris.push_back({m.positions[m.indices[3 * t]], m.positions[m.indices[3 * t + 1]],
                    m.positions[m.indices[3 * t + 2]]});
}

inline std::vector<TriangleVertices> scene_triangles(const std::string& name) {
  absl::StatusOr<Scene> scene =
      load_scene(std::string(CAUSTICA_SCENES_DIR) + "/" + name + "/scene.json");
  EXPECT_TRUE(scene.ok()) << scene.status();
  std::vector<TriangleVertices> tris;
  if (!scene.ok()) return tris;
  for (const Mesh& m : scene->meshes) append_triangles(m, tris);
  return tris;
}

// The 4-wide collapse: every triangle in exactly one leaf; leaves are runs of 1 to
// kMaxLeafTriangles sorted triangles whose box is exactly theirs, and a leaf of several has a box
// of the small size class or no larger than a part of it; child boxes lie inside their parents;
// every node has at least two children, empty slots last; and the collapse stopped exactly at the
// small subtrees: each node covers a contiguous range, an internal child covers more than
// kMaxLeafTriangles triangles or has a huge box, and a node with a free slot has only leaves.
// Reports the node and leaf counts.
inline void check_wide_invariants(const TriangleBvh& bvh,
                                  const std::vector<TriangleVertices>& tris) {
  const size_t n = tris.size();
  ASSERT_EQ(bvh.bvh.triangle_count, n);
  auto wide = bvh.bvh.nodes.download();
  auto sorted = bvh.triangles.download();
  ASSERT_GE(wide.size(), 1u);
  ASSERT_LE(wide.size(), n - 1);
  std::vector<int> triangle_seen(n, 0), node_seen(wide.size(), 0);
  size_t leaves = 0, leaf_sizes[kMaxLeafTriangles + 1] = {};
  struct Range {
    uint32_t first, last;
  };
  // Checks the subtree of `node`, whose box is `box`, and sets the range of triangles it covers.
  std::function<void(uint32_t, const Aabb&, Range&)> walk = [&](uint32_t node, const Aabb& box,
                                                                Range& covered) {
    ASSERT_LT(node, wide.size());
    ASSERT_EQ(++node_seen[node], 1) << "node " << node << " reached twice";
    const Bvh4Node& w = wide[node];
    std::vector<Range> ranges;
    int internal = 0;
    for (int c = 0; c < 4; ++c) {
      const uint32_t child = w.child[c];
      if (child == kEmptyChild) continue;
      ASSERT_EQ(int(ranges.size()), c) << "node " << node << ": empty slot before a child";
      const Aabb child_box = w.child_bounds(c);
      ASSERT_TRUE(box.contains(child_box)) << "node " << node << " child " << c;
      Range r;
      if (is_leaf(child)) {
        const uint32_t first = leaf_first(child), count = leaf_count(child);
        ASSERT_GE(count, 1u);
        ASSERT_LE(count, kMaxLeafTriangles);
        ASSERT_LE(size_t(first) + count, n);
        Aabb tight;
        for (uint32_t i = first; i < first + count; ++i) {
          ++triangle_seen[i];
          tight.extend(triangle_bounds(sorted[i]));
        }
        ASSERT_EQ(child_box.lower, tight.lower) << "leaf at node " << node << " child " << c;
        ASSERT_EQ(child_box.upper, tight.upper) << "leaf at node " << node << " child " << c;
        if (count > 1 && size_class(child_box, bvh.bvh.bounds) == 0u) {
          // A huge box is allowed only when one part of the run already spans it (a wall's two
          // triangles), so that grouping made no box larger.
          bool spanned = false;
          for (uint32_t split = first + 1; split < first + count; ++split) {
            Aabb low, high;
            for (uint32_t i = first; i < first + count; ++i) {
              (i < split ? low : high).extend(triangle_bounds(sorted[i]));
            }
            spanned = spanned || low.half_area() >= child_box.half_area() ||
                      high.half_area() >= child_box.half_area();
          }
          ASSERT_TRUE(spanned) << "leaf at node " << node << " child " << c
                               << " groups triangles into a huge box larger than any part";
        }
        ++leaves;
        ++leaf_sizes[count];
        r = {first, first + count - 1};
      } else {
        ++internal;
        walk(child, child_box, r);
        if (::testing::Test::HasFatalFailure()) return;
        ASSERT_TRUE(r.last - r.first + 1 > kMaxLeafTriangles ||
                    size_class(child_box, bvh.bvh.bounds) == 0u)
            << "node " << child
            << " covers few enough triangles, in a box small enough, to be a leaf";
      }
      ranges.push_back(r);
    }
    ASSERT_GE(ranges.size(), 2u) << "node " << node;
    if (ranges.size() < 4) {
      ASSERT_EQ(internal, 0) << "node " << node << " left a slot unused";
    }
    std::sort(ranges.begin(), ranges.end(),
              [](const Range& x, const Range& y) { return x.first < y.first; });
    for (size_t i = 1; i < ranges.size(); ++i) {
      ASSERT_EQ(ranges[i].first, ranges[i - 1].last + 1) << "node " << node << " has a gap";
    }
    covered = {ranges.front().first, ranges.back().last};
  };
  Range all;
  walk(0, bvh.bvh.bounds, all);
  if (::testing::Test::HasFatalFailure()) return;
  EXPECT_EQ(all.first, 0u);
  EXPECT_EQ(all.last, n - 1);
  for (int c : node_seen) ASSERT_EQ(c, 1);
  for (int c : triangle_seen) ASSERT_EQ(c, 1);

  // Every node has at least two children, so the leaves outnumber the nodes.
  EXPECT_LT(wide.size(), leaves);
  EXPECT_GE(leaves, (n + kMaxLeafTriangles - 1) / kMaxLeafTriangles);
  std::string sizes;
  for (uint32_t k = 1; k <= kMaxLeafTriangles; ++k) {
    // Appended in two steps: "..." + std::to_string(...) trips GCC 12's -Wrestrict false positive.
    if (k > 1) sizes += ' ';
    sizes += std::to_string(leaf_sizes[k]);
  }
  ::testing::Test::RecordProperty("bvh4_nodes", int(wide.size()));
  ::testing::Test::RecordProperty("bvh4_leaves", int(leaves));
  std::printf(
      "%zu triangles: %zu 4-wide nodes (%.1f B/triangle), %zu leaves (%.2f triangles "
      "each; of 1..%u triangles: %s)\n",
      n, wide.size(), double(wide.size() * sizeof(Bvh4Node)) / double(n), leaves,
      double(n) / double(leaves), kMaxLeafTriangles, sizes.c_str());
}

// Walks a binary tree from the root: every leaf reached once, every child box inside its parent's
// and a leaf's exactly its triangle's, and the radix tree's layout.
inline void check_binary_invariants(const BinaryTriangleBvh& t,
                                    const std::vector<TriangleVertices>& tris) {
  const size_t n = tris.size();
  ASSERT_EQ(t.bvh.leaf_count, n);
  ASSERT_EQ(t.bvh.node_count(), 2 * n - 1);
  ASSERT_EQ(t.bvh.nodes.size(), n - 1);
  auto nodes = t.bvh.nodes.download();
  auto sorted = t.triangles.download();
  auto ids = t.triangle_ids.download();
  // Leaves in sorted order hold the triangles their ids name.
  std::vector<int> id_seen(n, 0);
  for (size_t i = 0; i < n; ++i) {
    ASSERT_LT(ids[i], n);
    ++id_seen[ids[i]];
    ASSERT_EQ(sorted[i].p0, tris[ids[i]].p0);
  }
  for (int c : id_seen) ASSERT_EQ(c, 1);

  std::vector<int> leaf_seen(n, 0), internal_seen(n - 1, 0);
  struct Item {
    uint32_t node;
    Aabb box;
  };
  std::vector<Item> todo{{t.bvh.root, t.bvh.bounds}};
  size_t visited = 0;
  while (!todo.empty()) {
    Item it = todo.back();
    todo.pop_back();
    ASSERT_LT(it.node, n - 1);
    ++internal_seen[it.node];
    ++visited;
    for (int c = 0; c < 2; ++c) {
      const Aabb child_box = nodes[it.node].child[c].bounds();
      ASSERT_TRUE(it.box.contains(child_box)) << "node " << it.node << " child " << c;
      uint32_t child = nodes[it.node].child[c].index;
      if (is_leaf(child)) {
        uint32_t leaf = leaf_index(child);
        ASSERT_LT(leaf, n);
        ++leaf_seen[leaf];
        Aabb tb = triangle_bounds(sorted[leaf]);
        ASSERT_EQ(child_box.lower, tb.lower);
        ASSERT_EQ(child_box.upper, tb.upper);
      } else {
        todo.push_back({child, child_box});
      }
    }
  }
  EXPECT_EQ(visited, n - 1);
  for (int c : internal_seen) ASSERT_EQ(c, 1);
  for (int c : leaf_seen) ASSERT_EQ(c, 1);

  // Binary radix tree: internal node k splits its leaf range between leaves k and k + 1.
  std::vector<std::pair<uint32_t, uint32_t>> range(n - 1);
  std::function<std::pair<uint32_t, uint32_t>(uint32_t)> span = [&](uint32_t child) {
    if (is_leaf(child)) return std::make_pair(leaf_index(child), leaf_index(child));
    auto l = span(nodes[child].child[0].index), r = span(nodes[child].child[1].index);
    EXPECT_EQ(l.second, child);
    EXPECT_EQ(r.first, child + 1);
    return std::make_pair(l.first, r.second);
  };
  auto all = span(t.bvh.root);
  EXPECT_EQ(all.first, 0u);
  EXPECT_EQ(all.second, n - 1);
}

// Two builds of one binary tree, byte for byte: root, leaf order and nodes.
inline void expect_same_binary_tree(const BinaryTriangleBvh& first,
                                    const BinaryTriangleBvh& second) {
  EXPECT_EQ(first.bvh.root, second.bvh.root);
  EXPECT_EQ(first.triangle_ids.download(), second.triangle_ids.download());
  const std::vector<BvhNode> a = first.bvh.nodes.download(), b = second.bvh.nodes.download();
  ASSERT_EQ(a.size(), b.size());
  // An empty vector's data() may be null, which memcmp must not be given even for no bytes.
  if (!a.empty()) {
    EXPECT_EQ(0, std::memcmp(a.data(), b.data(), a.size() * sizeof(BvhNode)));
  }
}

// The SAH cost of a binary tree without its leaves' part, which every tree over the same triangles
// shares: the sum of its internal nodes' box areas, relative to the root's.
inline double internal_area_cost(const BinaryTriangleBvh& t) {
  const std::vector<BvhNode> nodes = t.bvh.nodes.download();
  double sum = 0.0;
  for (const BvhNode& node : nodes)
    sum += merge(node.child[0].bounds(), node.child[1].bounds()).half_area();
  return sum / t.bvh.bounds.half_area();
}

inline Hit brute_force(const std::vector<TriangleVertices>& tris, const Ray& ray) {
  Hit best;
  WatertightRay w(ray);
  float t_max = ray.t_max;
  for (size_t i = 0; i < tris.size(); ++i) {
    float t, u, v;
    if (intersect_triangle(w, tris[i], ray.t_min, t_max, t, u, v)) {
      t_max = t;
      best.t = t;
      best.u = u;
      best.v = v;
      best.triangle = uint32_t(i);
    }
  }
  return best;
}

// Rays from a sphere around the mesh towards random points inside its box (or, with
// `aim_at_triangles`, towards random triangles' centroids): most hit something. Even-numbered
// rays start inside the box, in random directions.
inline std::vector<Ray> random_check_rays(const std::vector<TriangleVertices>& tris,
                                          const Aabb& bounds, int ray_count, uint32_t seed,
                                          bool aim_at_triangles) {
  Vec3f c = bounds.center();
  float r = length(bounds.extent());
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Ray> rays;
  for (int i = 0; i < ray_count; ++i) {
    Ray ray;
    bool inside = i % 2 == 0;  // half the rays start inside the box, in random directions
    Vec3f target = bounds.lower + bounds.extent() * Vec3f(u(rng), u(rng), u(rng));
    if (aim_at_triangles) {
      const TriangleVertices& aim = tris[rng() % tris.size()];
      target = (aim.p0 + aim.p1 + aim.p2) * (1.0f / 3.0f);
    }
    if (inside) {
      ray.origin = target;
      ray.direction = sample_uniform_sphere(u(rng), u(rng));
    } else {
      ray.origin = c + sample_uniform_sphere(u(rng), u(rng)) * r;
      ray.direction = normalize(target - ray.origin);
    }
    rays.push_back(ray);
  }
  return rays;
}

// Whether a hit found through a structure is brute force's: the same distance, and the same
// triangle unless coplanar or duplicate triangles tie exactly, when the one found must also be hit
// at that very distance.
inline void expect_same_hit(const std::vector<TriangleVertices>& tris, const Ray& ray,
                            const Hit& got, const Hit& expected, size_t i) {
  ASSERT_EQ(got.valid(), expected.valid()) << "ray " << i;
  if (!expected.valid()) return;
  ASSERT_EQ(got.t, expected.t) << "ray " << i;
  if (got.triangle != expected.triangle) {
    ASSERT_LT(got.triangle, tris.size()) << "ray " << i;
    float t, u, v;
    ASSERT_TRUE(intersect_triangle(WatertightRay(ray), tris[got.triangle], ray.t_min, FLT_MAX, t,
                                   u, v));
    ASSERT_EQ(t, expected.t) << "ray " << i;
  } else {
    ASSERT_EQ(got.u, expected.u) << "ray " << i;
    ASSERT_EQ(got.v, expected.v) << "ray " << i;
  }
}

// check_rays through the batch entry points (ray_queries.h), which every view answers: the rays
// of random_check_rays through trace_closest, and through trace_any those rays, each hit's
// shadow ray stopping just short of it, and (from outside the box) segments past and short of
// it from the light's end, all against brute force.
template <typename View>
void check_rays_batch(Backend& backend, const std::vector<TriangleVertices>& tris,
                      const View& view, int ray_count, uint32_t seed,
                      bool aim_at_triangles = false) {
  const std::vector<Ray> rays = random_check_rays(tris, view.bounds, ray_count, seed,
                                                  aim_at_triangles);
  std::vector<Hit> expected(rays.size());
  std::vector<Ray> shadow_rays;
  std::vector<uint8_t> expected_blocked;
  auto add_shadow = [&](const Ray& r) {
    shadow_rays.push_back(r);
    expected_blocked.push_back(brute_force(tris, r).valid() ? 1 : 0);
  };
  int hits = 0;
  for (size_t i = 0; i < rays.size(); ++i) {
    expected[i] = brute_force(tris, rays[i]);
    add_shadow(rays[i]);
    if (!expected[i].valid()) continue;
    ++hits;
    Ray shadow = rays[i];
    shadow.t_max = expected[i].t * 0.999f;
    add_shadow(shadow);
    if (i % 2 == 0) continue;  // started inside the box: see check_rays
    const Vec3f beyond = rays[i].origin + rays[i].direction * (expected[i].t * 1.5f);
    const Vec3f short_of = rays[i].origin + rays[i].direction * (expected[i].t * 0.999f);
    add_shadow(shadow_ray(rays[i].origin, beyond, 1e-3f));
    add_shadow(shadow_ray(rays[i].origin, short_of, 0.0f));
  }
  EXPECT_GT(hits, ray_count / 10);

  Buffer<Ray> ray_buffer(backend, rays.size()), shadow_buffer(backend, shadow_rays.size());
  ray_buffer.upload(rays);
  shadow_buffer.upload(shadow_rays);
  Buffer<Hit> got_hits(backend, rays.size());
  Buffer<uint8_t> got_blocked(backend, shadow_rays.size());
  trace_closest(backend, view, ray_buffer.data(), rays.size(), got_hits.data());
  trace_any(backend, view, shadow_buffer.data(), shadow_rays.size(), got_blocked.data());
  const std::vector<Hit> got = got_hits.download();
  const std::vector<uint8_t> blocked = got_blocked.download();
  for (size_t i = 0; i < rays.size(); ++i) {
    expect_same_hit(tris, rays[i], got[i], expected[i], i);
    if (::testing::Test::HasFatalFailure()) return;
  }
  for (size_t i = 0; i < shadow_rays.size(); ++i) {
    ASSERT_EQ(blocked[i], expected_blocked[i]) << "shadow ray " << i;
  }
}

// Rays from a sphere around the mesh towards random points inside its box (or, with
// `aim_at_triangles`, towards random triangles' centroids): most hit something. Closest and any
// hits through `view` (a StructureView over `tris` in their order) must be brute force's.
template <typename View>
void check_rays(const std::vector<TriangleVertices>& tris, const View& view, int ray_count,
                uint32_t seed, bool aim_at_triangles = false) {
  const std::vector<Ray> rays = random_check_rays(tris, view.bounds, ray_count, seed,
                                                  aim_at_triangles);
  int hits = 0;
  for (int i = 0; i < ray_count; ++i) {
    const Ray& ray = rays[i];
    const bool inside = i % 2 == 0;
    Hit expected = brute_force(tris, ray);
    Hit got = closest_hit(view, ray);
    ASSERT_EQ(got.valid(), expected.valid()) << "ray " << i;
    ASSERT_EQ(any_hit(view, ray), expected.valid()) << "ray " << i;
    if (expected.valid()) {
      ++hits;
      ASSERT_EQ(got.t, expected.t) << "ray " << i;
      // Coplanar or duplicate triangles may tie exactly; then the one found must also be hit
      // at that very distance.
      if (got.triangle != expected.triangle) {
        float t, u, v;
        ASSERT_TRUE(intersect_triangle(WatertightRay(ray), tris[got.triangle], ray.t_min, FLT_MAX,
                                       t, u, v));
        ASSERT_EQ(t, expected.t) << "ray " << i;
      }
      // A shadow ray stopping just short of the hit sees nothing.
      Ray shadow = ray;
      shadow.t_max = expected.t * 0.999f;
      ASSERT_EQ(any_hit(view, shadow), brute_force(tris, shadow).valid()) << "ray " << i;
      // The same from the light's end (segment_blocked): a segment past the nearest hit is
      // blocked, one stopping short of it is not. Only from outside the box: an inside ray may
      // start on a triangle, which a shadow ray's end never does (offset_origin).
      if (inside) continue;
      const Vec3f beyond = ray.origin + ray.direction * (expected.t * 1.5f);
      const Vec3f short_of = ray.origin + ray.direction * (expected.t * 0.999f);
      ASSERT_TRUE(segment_blocked(view, ray.origin, beyond, 1e-3f)) << "ray " << i;
      ASSERT_FALSE(segment_blocked(view, ray.origin, short_of, 0.0f)) << "ray " << i;
      const Ray reversed = shadow_ray(ray.origin, beyond, 1e-3f);
      ASSERT_EQ(any_hit(view, reversed), brute_force(tris, reversed).valid()) << "ray " << i;
    }
  }
  EXPECT_GT(hits, ray_count / 10);
}

}  // namespace caustica
