// Stack traversal of a TriangleBvh: closest hit and any hit, both walking the leaves along a ray
// nearest first (leaf_walk.h). One function body serves both backends; on a GPU the lanes of a warp
// that trace any hits together also share their walks' subtrees (any_hit_shared).
#pragma once

#include <cstring>

#include "renderer/accel/leaf_walk.h"
#include "renderer/accel/ray_slabs.h"
#include "renderer/accel/triangle_bvh.h"
#include "renderer/base/warp.h"

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
// matters is to meet a blocker soon (docs/performance.md, "Fewer instructions per box and
// triangle test").
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

// Visits inner node `node`: pushes every child box the ray enters but the nearest, farthest first
// (with its entry distance in stack_t when kShrinks), and moves `node` to the nearest. False when
// the ray enters none.
template <bool kShrinks>
CAUSTICA_HDI bool enter_nearest_child(const TriangleBvhView& bvh, const RaySlabs& slabs,
                                      float t_min, float t_max, uint32_t& node, uint32_t* stack,
                                      float* stack_t, int& top) {
  const OrderedNode n = load_ordered_node(bvh.nodes + node, slabs);
  float t[4], key[4];
  uint32_t child[4];
  // No box is entered past t_max (slab_entry clips its far distance there): the entry distances
  // need no comparison with t_max before the sort.
  intersect_children(n, slabs, t_min, t_max, t);
  sort_near_first<kShrinks>(n.child, t, key, child);
  for (int c = 3; c >= 1; --c) {
    if (key[c] != INFINITY) {
      stack[top] = child[c];
      if constexpr (kShrinks) stack_t[top] = key[c];
      ++top;
    }
  }
  if (key[0] == INFINITY) return false;
  node = child[0];
  return true;
}

// The entry distances beside a TriangleBvh walk's stack, kept only when hits shrink t_max: without
// them enter_nearest_child is handed no array, as any_hit_shared's walks are.
template <bool kShrinks>
struct EntryDistances {
  float stack_t[kTraversalStackSize];
};
template <>
struct EntryDistances<false> {
  static constexpr float* stack_t = nullptr;
};

// The walker of a TriangleBvh for walk_leaves (leaf_walk.h): the stack's references, and beside
// them their entry distances, as enter_nearest_child pushes them. The walk needs to know nothing of
// a node but its reference.
template <bool kShrinks>
struct TriangleBvhWalker : EntryDistances<kShrinks> {
  struct Carried {};

  static CAUSTICA_HDI Carried root(const TriangleBvhView&) { return {}; }
  CAUSTICA_HDI bool enter_nearest_child(const TriangleBvhView& bvh, const RaySlabs& slabs,
                                        float t_min, float t_max, uint32_t& node, Carried&,
                                        int& top) {
    return detail::enter_nearest_child<kShrinks>(bvh, slabs, t_min, t_max, node, stack,
                                                 this->stack_t, top);
  }
  CAUSTICA_HDI float entry_t(int i) const { return this->stack_t[i]; }
  CAUSTICA_HDI void take(int i, uint32_t& node, Carried&) const { node = stack[i]; }
  static CAUSTICA_HDI uint32_t first_triangle(uint32_t leaf) { return leaf_first(leaf); }
  static CAUSTICA_HDI uint32_t triangle_count(uint32_t leaf) { return leaf_count(leaf); }

  uint32_t stack[kTraversalStackSize];
};

}  // namespace detail

CAUSTICA_HDI Hit closest_hit(const TriangleBvhView& bvh, const Ray& ray) {
  return nearest_walked_hit(
      bvh.triangles, bvh.triangle_ids, ray, [&](const float& t_max, auto test) {
        detail::walk_leaves<true, detail::TriangleBvhWalker>(bvh, ray, t_max, test);
      });
}

// True when anything blocks the open segment (t_min, t_max) of the ray, walked by one thread.
CAUSTICA_HDI bool any_hit_alone(const TriangleBvhView& bvh, const Ray& ray) {
  return walked_segment_blocked(bvh.triangles, ray, [&](const float& t_max, auto test) {
    detail::walk_leaves<false, detail::TriangleBvhWalker>(bvh, ray, t_max, test);
  });
}

#if defined(__CUDA_ARCH__)
namespace detail {

// What a lane needs to walk part of a ray's tree: the ray made ready for box and triangle tests,
// and the lane that owns the ray.
struct SharedAnyHitRay {
  RaySlabs slabs;
  WatertightRay wray;
  float t_min, t_max;
  uint32_t owner;
};

// Entries a lane gives away from the bottom of its stack, at most, while it walks one piece of
// work (its own ray, or a subtree it took); the stack keeps room for them below its own entries.
constexpr int kMaxGivenEntries = 32;

// any_hit for the rays of the lanes that call it together. Each lane walks its own ray as
// any_hit_alone does; a lane whose ray has ended (blocked, or its stack empty) takes the bottom
// entry of a busy lane's stack, the largest subtree waiting there, with that lane's ray, and walks
// it with a stack of its own. So no lane idles while a ray of the warp still has subtrees to test:
// in shadow rays a warp's busiest lane does far more work than its mean lane, and the warps whose
// lanes differ most end the launch (docs/performance.md, "Shadow-ray lanes share their walks").
// Lanes meet after each leaf: a blocker found by any of them ends its ray for all. The answer is
// any_hit_alone's: whether any triangle meets the open segment, in whatever order it is found.
__device__ inline bool any_hit_shared(const TriangleBvhView& bvh, const Ray& ray) {
  const unsigned group = __activemask();
  unsigned lane;
  asm("mov.u32 %0, %%laneid;" : "=r"(lane));
  SharedAnyHitRay r{ray_slabs(ray.origin, ray.direction, bvh.bounds), WatertightRay(ray), ray.t_min,
                    ray.t_max, lane};
  uint32_t stack[kMaxGivenEntries + kTraversalStackSize];
  int bottom = 0, top = 0;  // the entries are stack[bottom, top)
  uint32_t node = 0;
  bool busy = slab_entry(r.slabs, bvh.bounds, r.t_min, r.t_max) <= r.t_max;
  unsigned blocked = 0;  // the same in every lane of the group: owners whose ray is blocked
  // Takes the top entry; with none left the lane is idle.
  auto pop = [&] {
    busy = top > bottom;
    if (busy) node = stack[--top];
    return busy;
  };
  while (true) {
    bool found = false;
    if ((blocked >> r.owner) & 1u) busy = false;  // found blocked at the last meeting
    if (busy) {
      while (!is_leaf(node)) {
        if (!enter_nearest_child<false>(bvh, r.slabs, r.t_min, r.t_max, node, stack, nullptr,
                                        top) &&
            !pop()) {
          break;
        }
      }
      if (busy) {
        const uint32_t first = leaf_first(node), end = first + leaf_count(node);
        for (uint32_t i = first; i < end; ++i) {
          if (triangle_blocks(r.wray, bvh.triangles[i], r.t_min, r.t_max)) {
            found = true;
            break;
          }
        }
        pop();
      }
    }
    // Three votes, none waiting on another's answer, so that their latencies overlap: a lane
    // whose ray another lane has just found blocked still counts as busy until the next meeting,
    // where it stops (the measurement is in docs/performance.md, "Shadow-ray lanes share their
    // walks").
    const unsigned found_owners = __reduce_or_sync(group, found ? 1u << r.owner : 0u);
    const unsigned idle = __ballot_sync(group, !busy);
    const unsigned donors =
        __ballot_sync(group, busy && !found && top > bottom && bottom < kMaxGivenEntries);
    blocked |= found_owners;
    if (idle == group) break;
    if (idle != 0 && donors != 0) {
      const unsigned below = (1u << lane) - 1u;
      const int idle_count = __popc(idle), donor_count = __popc(donors);
      const int pairs = idle_count < donor_count ? idle_count : donor_count;
      const int idle_rank = __popc(idle & below), donor_rank = __popc(donors & below);
      const bool receives = !busy && idle_rank < pairs;
      const bool gives = ((donors >> lane) & 1u) && donor_rank < pairs;
      // A lane that takes nothing reads its own values back.
      const int source = receives ? nth_set_lane(donors, idle_rank) : int(lane);
      const uint32_t given = __shfl_sync(group, stack[bottom], source);
      r = shuffle_words(group, r, source);
      if (gives) ++bottom;
      if (receives) {
        node = given;
        bottom = top = 0;
        busy = true;
      }
    }
  }
  return (blocked >> lane) & 1u;
}

}  // namespace detail
#endif

// True when anything blocks the open segment (t_min, t_max) of the ray: shadow rays. On a GPU the
// lanes that call it together share their walks (detail::any_hit_shared).
CAUSTICA_HDI bool any_hit(const TriangleBvhView& bvh, const Ray& ray) {
#if defined(__CUDA_ARCH__)
  if (bvh.count >= 2) return detail::any_hit_shared(bvh, ray);
#endif
  return any_hit_alone(bvh, ray);
}

// The shadow ray for the open segment from `surface` (a lit point, already moved off its surface)
// to `light` (a point on a light), leaving out the `light_gap` fraction of its length next to the
// light, where an area light's own triangle lies. It starts at the light's end: a ray leaving a
// surface first opens every box around its origin, whose triangles never block it, while one
// arriving from the light meets an occluder first and stops there (docs/performance.md).
CAUSTICA_HDI Ray shadow_ray(Vec3f surface, Vec3f light, float light_gap) {
  const Vec3f d = surface - light;
  const float length_d = length(d);
  // A segment of no length blocks nothing: (0, 0) is empty.
  return Ray{light, length_d > 0.0f ? d / length_d : Vec3f(0.0f, 0.0f, 1.0f), length_d * light_gap,
             length_d};
}

// True when anything in `structure` (any StructureView, structure.h) blocks that segment.
template <typename Structure>
CAUSTICA_HDI bool segment_blocked(const Structure& structure, Vec3f surface, Vec3f light,
                                  float light_gap) {
  return any_hit(structure, shadow_ray(surface, light, light_gap));
}

}  // namespace caustica
