// Density estimation over a photon map: exact k nearest neighbours within a maximum radius
// (a max-heap pruned by the current k-th distance, near child first), and the radiance estimate
// L = f_r / (pi r^2) * sum w(d/r) dPhi with a normalised uniform, cone or Epanechnikov kernel
// (Jensen 2001 sec. 7.2; Fabianowski 2011 sec. 5.3 for the kernels).
//
// Two things make a renderer's many searches cheaper without changing what they find:
// - a search group: threads whose points lie close together (a GPU warp of requests in Morton
//   order) walk the tree as one, each node visited when any of them needs it, so they read the
//   same nodes and photons in step instead of diverging;
// - a carried bound: the k-th distance at a nearby point q bounds it at p by r_k(q) + |p - q|
//   (the k photons within r_k(q) of q lie within that of p), so a search can start from that
//   radius instead of the maximum and offer its heap only photons that may belong to it.
#pragma once

#include <cmath>

#include "renderer/photon/photon_map.h"
#include "renderer/scene/scene.h"

namespace caustica {

constexpr uint32_t kMaxNearest = 1024;  // the largest k validation admits
constexpr int kKnnStackSize = 64;

// 8-byte aligned so that a heap entry moves as one load or store.
struct alignas(8) Neighbour {
  float distance_squared;
  uint32_t index;  // map (Morton) order
};

// The threads searching together: `lanes` is a mask of GPU warp lanes that make the same calls
// in step, or 0 for a thread searching alone (always on the CPU). A group's decisions are votes,
// so every member visits every node it needs; which order the group takes changes only speed.
struct SearchGroup {
  uint32_t lanes = 0;

  // Whether any member's `wish` holds.
  CAUSTICA_HDI bool any(bool wish) const {
#if defined(__CUDA_ARCH__)
    if (lanes != 0) return __any_sync(lanes, wish);
#endif
    return wish;
  }
  // Whether more than half of the members' `wish` holds.
  CAUSTICA_HDI bool most(bool wish) const {
#if defined(__CUDA_ARCH__)
    if (lanes != 0) return 2 * __popc(__ballot_sync(lanes, wish)) > __popc(lanes);
#endif
    return wish;
  }
  // The members whose `wish` holds, as a group of their own.
  CAUSTICA_HDI SearchGroup among(bool wish) const {
#if defined(__CUDA_ARCH__)
    if (lanes != 0) return {__ballot_sync(lanes, wish)};
#endif
    return {};
  }
};

namespace detail {

// Places `x` at position i of the max-heap heap[0..size), whose subtrees below i are heaps,
// moving the hole down instead of swapping.
template <typename Heap>
CAUSTICA_HDI void sift_down(Heap heap, uint32_t size, uint32_t i, Neighbour x) {
  while (true) {
    uint32_t child = 2 * i + 1;
    if (child >= size) break;
    if (child + 1 < size && heap[child + 1].distance_squared > heap[child].distance_squared) ++child;
    if (heap[child].distance_squared <= x.distance_squared) break;
    heap[i] = heap[child];
    i = child;
  }
  heap[i] = x;
}

// Turns heap[0..size) into a max-heap (Floyd's bottom-up construction, O(size)).
template <typename Heap>
CAUSTICA_HDI void make_heap(Heap heap, uint32_t size) {
  for (uint32_t i = size / 2; i-- > 0;) sift_down(heap, size, i, heap[i]);
}

}  // namespace detail

// Calls visit_leaf(leaf) for every leaf of `map` whose box lies within squared distance `limit`
// of `p`, nearer subtrees first; visit_leaf may shrink `limit` as it goes. Every member of `group`
// must make this call with the same map; each branch is a vote, so the members stay in step, and
// a member handed a leaf it does not need rejects its photons by distance.
template <typename VisitLeaf>
CAUSTICA_HDI void visit_photon_leaves(const PhotonMapView& map, Vec3f p, const float& limit,
                                      SearchGroup group, VisitLeaf visit_leaf) {
  if (map.count == 0) return;
  if (map.leaf_count == 1) {
    visit_leaf(0u);
    return;
  }
  // Deferred subtrees keep their box distance: by the time one is popped the limit has usually
  // shrunk below it, and the subtree is dropped without loading its node.
  uint32_t stack[kKnnStackSize];
  float stack_distance[kKnnStackSize];
  int top = 0;
  uint32_t node = map.root;
  while (true) {
    const BvhChild a = map.nodes[node].child[0], b = map.nodes[node].child[1];
    float d0 = distance_squared(a.bounds(), p);
    float d1 = distance_squared(b.bounds(), p);
    uint32_t c0 = a.index, c1 = b.index;
    const bool want0 = group.any(d0 < limit), want1 = group.any(d1 < limit);
    if (want0 && is_leaf(c0)) visit_leaf(leaf_index(c0));
    if (want1 && is_leaf(c1)) visit_leaf(leaf_index(c1));
    bool go0 = want0 && !is_leaf(c0), go1 = want1 && !is_leaf(c1);
    if (go0 && go1) {
      if (group.most(d1 < d0)) {
        uint32_t c = c0;
        c0 = c1;
        c1 = c;
        float d = d0;
        d0 = d1;
        d1 = d;
      }
      stack[top] = c1;
      stack_distance[top++] = d1;
      node = c0;
    } else if (go0) {
      node = c0;
    } else if (go1) {
      node = c1;
    } else {
      do {
        if (top == 0) return;
        --top;
      } while (!group.any(stack_distance[top] < limit));
      node = stack[top];
    }
  }
}

// Finds the (up to) k photons nearest to `p` with squared distance < max_distance_squared.
// `heap` (a Neighbour* or anything indexed like one, such as a Scratch<Neighbour>) must hold k
// entries; on return heap[0..count) holds them, as a max-heap (heap[0] the farthest) when
// count == k and in no particular order otherwise. Returns count. Every member of `group` must
// make this call with the same map and k.
template <typename Heap>
CAUSTICA_HDI uint32_t find_nearest(const PhotonMapView& map, Vec3f p, uint32_t k,
                                   float max_distance_squared, Heap heap, SearchGroup group = {}) {
  if (k == 0) return 0;
  uint32_t size = 0;
  float limit = max_distance_squared;  // shrinks to the k-th distance once the heap is full
  visit_photon_leaves(map, p, limit, group, [&](uint32_t leaf) {
    const uint32_t end = map.leaf_end(leaf);
    for (uint32_t i = map.leaf_begin(leaf); i < end; ++i) {
      float d2 = length_squared(map.positions[i] - p);
      if (d2 >= limit) continue;
      if (size < k) {
        // Candidates are only appended until there are k; then one heap construction.
        heap[size++] = {d2, i};
        if (size == k) {
          detail::make_heap(heap, size);
          limit = heap[0].distance_squared;
        }
      } else {
        detail::sift_down(heap, size, 0, {d2, i});  // the farthest makes room
        limit = heap[0].distance_squared;
      }
    }
  });
  return size;
}

// Kernel weight at normalised distance x = d / r in [0, 1], scaled so that it integrates to
// pi r^2 over the disk like the uniform kernel does.
CAUSTICA_HDI float kernel_weight(Kernel kernel, float x_squared) {
  switch (kernel) {
    case Kernel::kUniform:
      return 1.0f;
    case Kernel::kCone:  // Jensen's cone filter with k = 1: 1 - x, normalised by 1 / (1 - 2/3)
      return 3.0f * (1.0f - sqrtf(x_squared));
    case Kernel::kEpanechnikov:  // 1 - x^2, normalised by 2
      return 2.0f * (1.0f - x_squared);
  }
  return 1.0f;
}

// An estimate and the squared radius its photons were gathered from.
struct RadianceEstimate {
  Vec3f radiance;
  float radius_squared;
};

// A squared radius within which the k nearest photons of `p` surely lie, given the squared
// radius `near_radius_squared` that held them at the nearby point `near`: (r + |p - near|)^2,
// widened by 1e-4 for rounding.
CAUSTICA_HDI float carried_radius_squared(float near_radius_squared, Vec3f near, Vec3f p) {
  const float r = (sqrtf(near_radius_squared) + length(p - near)) * 1.0001f;
  return r * r;
}

// Reflected radiance at a diffuse point from the photons of `map` arriving on the side of
// `normal`: (albedo / pi) * sum w dPhi / (pi r^2), with r the k-th distance, or the maximum
// radius when fewer than k photons lie within it. `bound_squared`, when below the maximum, is a
// squared radius known to hold the k nearest (carried_radius_squared); should it prove too small
// the search is repeated from the maximum, so a bound changes speed, never the estimate's photons.
// `heap` holds k Neighbours.
template <typename Heap>
CAUSTICA_HDI RadianceEstimate estimate_radiance_within(const PhotonMapView& map, Vec3f p,
                                                       Vec3f normal, Vec3f albedo, uint32_t k,
                                                       float max_radius, Kernel kernel, Heap heap,
                                                       float bound_squared, SearchGroup group) {
  const float max_d2 = max_radius * max_radius;
  const bool bounded = bound_squared < max_d2;
  uint32_t found = find_nearest(map, p, k, bounded ? bound_squared : max_d2, heap, group);
  const bool missed = bounded && found < k;  // rare: the members that missed search again
  const SearchGroup again = group.among(missed);
  if (missed) found = find_nearest(map, p, k, max_d2, heap, again);
  if (found == 0) return {Vec3f(0.0f), max_d2};
  const float r2 = found == k ? heap[0].distance_squared : max_d2;
  if (r2 <= 0.0f) return {Vec3f(0.0f), r2};
  Vec3f flux(0.0f);
  const float inv_r2 = 1.0f / r2;
  for (uint32_t i = 0; i < found; ++i) {
    const PhotonFlux& ph = map.flux[heap[i].index];
    if (dot(decode_octahedral(ph.incoming), normal) <= 0.0f) continue;
    flux += ph.power * kernel_weight(kernel, heap[i].distance_squared * inv_r2);
  }
  return {albedo * flux * (kInvPi * kInvPi * inv_r2), r2};
}

// The same for a lone search with no bound.
template <typename Heap>
CAUSTICA_HDI Vec3f estimate_radiance(const PhotonMapView& map, Vec3f p, Vec3f normal, Vec3f albedo,
                                     uint32_t k, float max_radius, Kernel kernel, Heap heap) {
  return estimate_radiance_within(map, p, normal, albedo, k, max_radius, kernel, heap, INFINITY, {})
      .radiance;
}

}  // namespace caustica
