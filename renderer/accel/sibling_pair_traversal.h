// Stack traversal of a SiblingPairBvh (sibling_pair_bvh.h): closest hit and any hit, walking the
// leaves along a ray nearest first (leaf_walk.h), one function body for both backends.
//
// A node holds only the planes its children do not inherit, so a child's box is known only with
// its parent's. The walk carries the box of the node it stands on and decodes both children's
// from it (sibling_child_boxes); the stack entry of a deferred child holds that child's whole
// box, decoded when it was deferred, beside its reference (and its entry distance for a closest
// hit). Restoring a box at a pop from anything less, such as the parent's reference, would need
// the parent's box, and so every box up to the root: the stack is where the boxes the path left
// behind are kept. A deferred leaf needs no box, but its entry keeps the same shape.
#pragma once

#include "renderer/accel/leaf_walk.h"
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

// The walker of a SiblingPairBvh for walk_leaves (leaf_walk.h): the walk carries the box of the
// node it stands on, and a stack entry keeps a deferred child's box with its reference and entry
// distance. Aligned like a local array of its own, so that a GPU moves the entries by vector loads
// and stores rather than word by word.
template <bool kShrinks>
struct alignas(16) SiblingPairWalker {
  using Carried = Aabb;

  static CAUSTICA_HDI Carried root(const SiblingPairView& bvh) { return bvh.bounds; }
  CAUSTICA_HDI bool enter_nearest_child(const SiblingPairView& bvh, const RaySlabs& slabs,
                                        float t_min, float t_max, uint32_t& node, Aabb& box,
                                        int& top) {
    const SiblingPairNode n = bvh.nodes[node];
    Aabb box0, box1;
    sibling_child_boxes(n, box, box0, box1);
    const float t0 = slab_entry(slabs, box0, t_min, t_max);
    const float t1 = slab_entry(slabs, box1, t_min, t_max);
    const uint32_t c0 = sibling_reference(n.child[0]), c1 = sibling_reference(n.child[1]);
    if (t0 == INFINITY && t1 == INFINITY) return false;
    const bool first_near = t0 <= t1;
    if (t0 != INFINITY && t1 != INFINITY) {
      stack[top++] = first_near ? SiblingPairEntry{c1, t1, box1} : SiblingPairEntry{c0, t0, box0};
    }
    node = first_near ? c0 : c1;
    box = first_near ? box0 : box1;
    return true;
  }
  CAUSTICA_HDI float entry_t(int i) const { return stack[i].t; }
  CAUSTICA_HDI void take(int i, uint32_t& node, Aabb& box) const {
    node = stack[i].reference;
    box = stack[i].box;
  }
  static CAUSTICA_HDI uint32_t first_triangle(uint32_t leaf) { return sibling_leaf_first(leaf); }
  static CAUSTICA_HDI uint32_t triangle_count(uint32_t leaf) { return sibling_leaf_count(leaf); }

  SiblingPairEntry stack[kSiblingPairStackSize];
};

}  // namespace detail

CAUSTICA_HDI Hit closest_hit(const SiblingPairView& bvh, const Ray& ray) {
  return nearest_walked_hit(
      bvh.triangles, bvh.triangle_ids, ray, [&](const float& t_max, auto test) {
        detail::walk_leaves<true, detail::SiblingPairWalker>(bvh, ray, t_max, test);
      });
}

// True when anything blocks the open segment (t_min, t_max) of the ray.
CAUSTICA_HDI bool any_hit(const SiblingPairView& bvh, const Ray& ray) {
  return walked_segment_blocked(bvh.triangles, ray, [&](const float& t_max, auto test) {
    detail::walk_leaves<false, detail::SiblingPairWalker>(bvh, ray, t_max, test);
  });
}

}  // namespace caustica
