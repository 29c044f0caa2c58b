// The stack walk of a BVH's leaves along a ray, nearest first, that the closest and any hits of
// TriangleBvh (traversal.h) and SiblingPairBvh (sibling_pair_traversal.h) share, one function body
// for both backends. Each layout brings what differs, a walker (below): how a node's children are
// entered and what a stack entry keeps.
#pragma once

#include <cstdint>

#include "renderer/accel/bvh.h"
#include "renderer/accel/ray_slabs.h"
#include "renderer/base/ray.h"

namespace caustica {
namespace detail {

// Walks the leaves of `bvh` (a view with `count` triangles inside `bounds`) along `ray` nearest
// first: `test(sorted)` tests one triangle, may shrink t_max (a closest hit) and returns true to
// end the walk (an any hit). Leaves wait on the stack with the subtrees, in the same near-first
// order, and a ray walks nodes until it holds a leaf ("while-while", Aila and Laine 2009): the
// lanes of a warp then test triangles together, where testing each node's leaves as they were met
// had one lane at a time test while the others waited (docs/performance.md, "GPU floors and what
// limits each figure").
//
// `Walker<kShrinks>` is the layout's part: the stack, declared here as one object, and how the walk
// steps through the layout's nodes. Beside `node`, the reference the walk stands on (bvh.h:
// kLeafFlag | leaf, or an inner node), the walk keeps a Walker::Carried, what the layout needs to
// know of that node (root(bvh) for the root). enter_nearest_child(bvh, slabs, t_min, t_max, node,
// carried, top) moves from an inner node to the nearest child box the ray enters, pushing the
// others, and is false when the ray enters none; take(i, node, carried) moves to stack entry i.
// With kShrinks (hits shrink t_max, a closest hit) each entry keeps its entry distance, entry_t(i),
// and is dropped unloaded when it is popped behind the nearest hit. first_triangle(leaf) and
// triangle_count(leaf) give a leaf's range of sorted triangles.
//
// The walk's scalars stay out of the Walker: on a GPU they would share the stack's local memory,
// where the stack's run-time indices keep the compiler from moving them into registers.
template <bool kShrinks, template <bool> class Walker, typename View, typename Test>
CAUSTICA_HDI void walk_leaves(const View& bvh, const Ray& ray, const float& t_max, Test test) {
  if (bvh.count == 0) return;
  // In registers: `ray` may be a reference into global memory, read again at every node.
  const RaySlabs slabs = ray_slabs(ray.origin, ray.direction, bvh.bounds);
  const float t_min = ray.t_min;
  if (slab_entry(slabs, bvh.bounds, t_min, t_max) > t_max) return;
  if (bvh.count == 1) {
    test(0u);
    return;
  }
  Walker<kShrinks> walker;
  typename Walker<kShrinks>::Carried carried = walker.root(bvh);
  int top = 0;
  uint32_t node = 0;
  // Takes the next entry still in front of t_max; false when there is none.
  auto pop = [&] {
    while (top > 0) {
      --top;
      if (!kShrinks || walker.entry_t(top) <= t_max) {
        walker.take(top, node, carried);
        return true;
      }
    }
    return false;
  };
  while (true) {
    while (!is_leaf(node)) {
      if (!walker.enter_nearest_child(bvh, slabs, t_min, t_max, node, carried, top) && !pop()) {
        return;
      }
    }
    const uint32_t first = walker.first_triangle(node), end = first + walker.triangle_count(node);
    for (uint32_t i = first; i < end; ++i) {
      if (test(i)) return;
    }
    if (!pop()) return;
  }
}

}  // namespace detail
}  // namespace caustica
