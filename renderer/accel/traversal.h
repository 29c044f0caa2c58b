// Stack traversal of a TriangleBvh: closest hit and any hit, both walking the leaves along a ray
// nearest first. One function body serves both backends.
#pragma once

#include "renderer/accel/ray_slabs.h"
#include "renderer/accel/triangle_bvh.h"

namespace caustica {

// Each 4-wide node pushes at most three entries, and the collapsed tree is about half as deep as
// the binary one (at most ~62 levels for 30-bit codes plus index tie-breaks).
constexpr int kTraversalStackSize = 96;

namespace detail {

// Entry distances of the ray into the four child boxes of `n`; +infinity for a miss. An empty
// slot needs no test of its own: its box is Aabb{} (bvh4.cc), lower corner FLT_MAX and upper
// -FLT_MAX, which every ray misses (slab_entry), so a node visit does not compare its four
// children with kEmptyChild (2% of a shadow ray's instructions).
CAUSTICA_HDI void intersect_children(const OrderedNode& n, const RaySlabs& s, float t_min,
                                     float t_max, float t_out[4]) {
  for (int c = 0; c < 4; ++c) {
    t_out[c] = slab_entry(s, n.enter[0][c], n.enter[1][c], n.enter[2][c], n.leave[0][c],
                          n.leave[1][c], n.leave[2][c], t_min, t_max);
  }
}

// The four (distance, child) pairs of `n` nearest first, misses (+infinity) last, by a fixed
// sorting network: every index is known at compile time, so the pairs stay in registers on a GPU
// (an insertion sort indexed by a running count put them in local memory), and the swaps are
// selects, not branches, which would mispredict. With kWhole false only the nearest is sure to
// come first, by three exchanges of the five: enough for a walk that ends at any hit, where what
// matters is to meet a blocker soon (H200, dragon shadow rays, alternated runs: 2080..2144 ->
// 2140..2193 Mrays/s, the same answers).
template <bool kWhole = true>
CAUSTICA_HDI void sort_near_first(const uint32_t children[4], const float t[4], float key[4],
                                  uint32_t child[4]) {
  for (int c = 0; c < 4; ++c) {
    key[c] = t[c];
    child[c] = children[c];
  }
  auto order = [&](int a, int b) {
    const bool swap = key[b] < key[a];
    const float ka = key[a], kb = key[b];
    const uint32_t ca = child[a], cb = child[b];
    key[a] = swap ? kb : ka;
    key[b] = swap ? ka : kb;
    child[a] = swap ? cb : ca;
    child[b] = swap ? ca : cb;
  };
  order(0, 1);
  order(2, 3);
  order(0, 2);
  if constexpr (kWhole) {
    order(1, 3);
    order(1, 2);
  }
}

// Chooses the next node for a traversal that has already tested the leaf children among
// `children` (their t set to +infinity): the children with t[c] <= t_limit, nearest first, the
// rest pushed on the stack; with none, the top of the stack. Returns false when the traversal is
// over.
CAUSTICA_HDI bool descend_near_first(const uint32_t children[4], const float t[4], float t_limit,
                                     uint32_t* stack, int& top, uint32_t& node) {
  float limited[4], key[4];
  uint32_t child[4];
  for (int c = 0; c < 4; ++c) limited[c] = t[c] <= t_limit ? t[c] : INFINITY;
  sort_near_first(children, limited, key, child);
  if (key[3] != INFINITY) stack[top++] = child[3];
  if (key[2] != INFINITY) stack[top++] = child[2];
  if (key[1] != INFINITY) stack[top++] = child[1];
  if (key[0] != INFINITY) {
    node = child[0];
    return true;
  }
  if (top == 0) return false;
  node = stack[--top];
  return true;
}

// Walks the leaves along `ray` nearest first: `test(sorted)` tests one triangle, may shrink t_max
// (a closest hit, kShrinks) and returns true to end the walk (an any hit). Leaves wait on the
// stack with the subtrees, in the same near-first order, and a ray walks nodes until it holds a
// leaf ("while-while", Aila and Laine 2009): the lanes of a warp then test triangles together,
// where testing each node's leaves as they were met had one lane at a time test while the others
// waited (H200, dragon: shadow rays 1502..1553 -> 1930..1963 Mrays/s, primary 3347..3374 ->
// 3882..3929, incoherent 1240..1243 -> 1495..1508). When hits shrink t_max, each entry keeps its
// distance on the stack and is dropped unloaded when it is popped behind the nearest hit.
template <bool kShrinks, typename Test>
CAUSTICA_HDI void walk_leaves(const TriangleBvhView& bvh, const Ray& ray, const float& t_max,
                              Test test) {
  if (bvh.count == 0) return;
  // In registers: `ray` may be a reference into global memory, read again at every node.
  const RaySlabs slabs = ray_slabs(ray.origin, ray.direction);
  const float t_min = ray.t_min;
  if (slab_entry(slabs, bvh.bounds, t_min, t_max) > t_max) return;
  if (bvh.count == 1) {
    test(0u);
    return;
  }
  uint32_t stack[kTraversalStackSize];
  float stack_t[kShrinks ? kTraversalStackSize : 1];
  int top = 0;
  uint32_t node = 0;
  // Takes the next entry still in front of t_max; false when there is none.
  auto pop = [&] {
    while (top > 0) {
      --top;
      if (!kShrinks || stack_t[top] <= t_max) {
        node = stack[top];
        return true;
      }
    }
    return false;
  };
  while (true) {
    while (!is_leaf(node)) {
      const OrderedNode n = load_ordered_node(bvh.nodes + node, slabs);
      float t[4], key[4];
      uint32_t child[4];
      // No box is entered past t_max but by the slack on its far distance, which costs a visit
      // at most: the entry distances need no comparison with t_max before the sort.
      intersect_children(n, slabs, t_min, t_max, t);
      sort_near_first<kShrinks>(n.child, t, key, child);
      for (int c = 3; c >= 1; --c) {
        if (key[c] != INFINITY) {
          stack[top] = child[c];
          if constexpr (kShrinks) stack_t[top] = key[c];
          ++top;
        }
      }
      if (key[0] != INFINITY) {
        node = child[0];
      } else if (!pop()) {
        return;
      }
    }
    const uint32_t first = leaf_first(node), end = first + leaf_count(node);
    for (uint32_t i = first; i < end; ++i) {
      if (test(i)) return;
    }
    if (!pop()) return;
  }
}

}  // namespace detail

CAUSTICA_HDI Hit closest_hit(const TriangleBvhView& bvh, const Ray& ray) {
  Hit hit;
  WatertightRay wray(ray);
  const float t_min = ray.t_min;
  float t_max = ray.t_max;
  detail::walk_leaves<true>(bvh, ray, t_max, [&](uint32_t sorted) {
    float t, u, v;
    if (intersect_triangle(wray, bvh.triangles[sorted], t_min, t_max, t, u, v)) {
      t_max = t;
      hit.t = t;
      hit.u = u;
      hit.v = v;
      hit.triangle = bvh.triangle_ids[sorted];
    }
    return false;
  });
  return hit;
}

// True when anything blocks the open segment (t_min, t_max) of the ray: shadow rays.
CAUSTICA_HDI bool any_hit(const TriangleBvhView& bvh, const Ray& ray) {
  WatertightRay wray(ray);
  const float t_min = ray.t_min, t_max = ray.t_max;
  bool blocked = false;
  detail::walk_leaves<false>(bvh, ray, t_max, [&](uint32_t sorted) {
    float t, u, v;
    blocked = intersect_triangle(wray, bvh.triangles[sorted], t_min, t_max, t, u, v);
    return blocked;
  });
  return blocked;
}

// The shadow ray for the open segment from `surface` (a lit point, already moved off its surface)
// to `light` (a point on a light), leaving out the `light_gap` fraction of its length next to the
// light, where an area light's own triangle lies. It starts at the light's end: a ray leaving a
// surface first opens every box around its origin, whose triangles never block it, while one
// arriving from the light meets an occluder first and stops there (dragon with a light above,
// 59% of rays blocked: 1111 -> 1520 Mrays/s on an H200, 3.4 -> 5.2 on two CPU cores).
CAUSTICA_HDI Ray shadow_ray(Vec3f surface, Vec3f light, float light_gap) {
  const Vec3f d = surface - light;
  const float length_d = length(d);
  // A segment of no length blocks nothing: (0, 0) is empty.
  return Ray{light, length_d > 0.0f ? d / length_d : Vec3f(0.0f, 0.0f, 1.0f), length_d * light_gap,
             length_d};
}

// True when anything blocks that segment.
CAUSTICA_HDI bool segment_blocked(const TriangleBvhView& bvh, Vec3f surface, Vec3f light,
                                  float light_gap) {
  return any_hit(bvh, shadow_ray(surface, light, light_gap));
}

}  // namespace caustica
