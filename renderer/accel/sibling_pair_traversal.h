// Stack traversal of a SiblingPairBvh (sibling_pair_bvh.h): closest hit and any hit, walking the
// leaves along a ray nearest first, one function body for both backends.
//
// A node holds only the planes its children do not inherit, so a child's box is known only with
// its parent's. The walk carries the box of the node it stands on and decodes both children's
// from it (sibling_child_boxes); the stack entry of a deferred child holds that child's whole
// box, decoded when it was deferred, beside its reference (and its entry distance for a closest
// hit). Restoring a box at a pop from anything less, such as the parent's reference, would need
// the parent's box, and so every box up to the root: the stack is where the boxes the path left
// behind are kept. A deferred leaf needs no box, but its entry keeps the same shape.
#pragma once

#include "renderer/accel/ray_slabs.h"
#include "renderer/accel/sibling_pair_bvh.h"
#include "renderer/accel/triangle.h"
#include "renderer/base/ray.h"

namespace caustica {
namespace detail {

struct SiblingPairEntry {
  uint32_t reference;  // sibling_reference: kLeafFlag | run, or a node
  float t;             // the ray's entry distance into the box
  Aabb box;
};

// Walks the leaves along `ray` nearest first: `test(sorted)` tests one triangle, may shrink t_max
// (a closest hit, kShrinks) and returns true to end the walk (an any hit). Entries popped behind
// the nearest hit so far are dropped without loading their node.
template <bool kShrinks, typename Test>
CAUSTICA_HDI void walk_sibling_pair_leaves(const SiblingPairView& bvh, const Ray& ray,
                                           const float& t_max, Test test) {
  if (bvh.count == 0) return;
  const RaySlabs slabs = ray_slabs(ray.origin, ray.direction, bvh.bounds);
  const float t_min = ray.t_min;
  if (slab_entry(slabs, bvh.bounds, t_min, t_max) > t_max) return;
  if (bvh.count == 1) {
    test(0u);
    return;
  }
  SiblingPairEntry stack[kSiblingPairStackSize];
  int top = 0;
  uint32_t node = 0;
  Aabb box = bvh.bounds;
  auto pop = [&] {
    while (top > 0) {
      --top;
      if (!kShrinks || stack[top].t <= t_max) {
        node = stack[top].reference;
        box = stack[top].box;
        return true;
      }
    }
    return false;
  };
  while (true) {
    while (!is_leaf(node)) {
      const SiblingPairNode n = bvh.nodes[node];
      Aabb box0, box1;
      sibling_child_boxes(n, box, box0, box1);
      const float t0 = slab_entry(slabs, box0, t_min, t_max);
      const float t1 = slab_entry(slabs, box1, t_min, t_max);
      const uint32_t c0 = sibling_reference(n.child[0]), c1 = sibling_reference(n.child[1]);
      if (t0 == INFINITY && t1 == INFINITY) {
        if (!pop()) return;
        continue;
      }
      const bool first_near = t0 <= t1;
      if (t0 != INFINITY && t1 != INFINITY) {
        stack[top++] = first_near ? SiblingPairEntry{c1, t1, box1} : SiblingPairEntry{c0, t0, box0};
      }
      node = first_near ? c0 : c1;
      box = first_near ? box0 : box1;
    }
    const uint32_t first = sibling_leaf_first(node), end = first + sibling_leaf_count(node);
    for (uint32_t i = first; i < end; ++i) {
      if (test(i)) return;
    }
    if (!pop()) return;
  }
}

}  // namespace detail

CAUSTICA_HDI Hit closest_hit(const SiblingPairView& bvh, const Ray& ray) {
  return nearest_walked_hit(bvh.triangles, bvh.triangle_ids, ray,
                            [&](const float& t_max, auto test) {
                              detail::walk_sibling_pair_leaves<true>(bvh, ray, t_max, test);
                            });
}

// True when anything blocks the open segment (t_min, t_max) of the ray.
CAUSTICA_HDI bool any_hit(const SiblingPairView& bvh, const Ray& ray) {
  return walked_segment_blocked(bvh.triangles, ray, [&](const float& t_max, auto test) {
    detail::walk_sibling_pair_leaves<false>(bvh, ray, t_max, test);
  });
}

}  // namespace caustica
