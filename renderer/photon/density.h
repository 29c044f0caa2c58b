// Density estimation over a photon map: exact k nearest neighbours within a maximum radius
// (a max-heap pruned by the current k-th distance, near child first), and the radiance estimate
// L = f_r / (pi r^2) * sum w(d/r) dPhi with a normalised uniform, cone or Epanechnikov kernel
// (Jensen 2001 sec. 7.2; Fabianowski 2011 sec. 5.3 for the kernels).
//
// Two things make a renderer's many searches cheaper without changing what they find:
// - a search group: threads whose points lie close together (a GPU warp of requests in Hilbert
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
  uint32_t index;  // map (curve) order
};

// Two heap entries side by side, read with one 16-byte load.
struct alignas(16) NeighbourPair {
  Neighbour entry[2];
};

// The k nearest photons found so far as a max-heap whose root (the farthest, which every
// candidate is measured against) is kept in a register, and whose entry e >= 1 lives in
// pairs[(e - 1) / 2]. On a GPU each node has four children, entries 4i+1 .. 4i+4 in pairs[2i]
// and pairs[2i + 1], so a step down the heap is two independent 16-byte loads and a comparison of
// registers. The steps are a chain of dependent shared-memory reads there, the largest part of
// the gather's time, and four children halve them: three below the root for k = 64. Eight
// children were faster at k = 64 only and slower at small k. On the CPU each node has two
// children, pairs[i]: the four-child heap's extra comparisons cost more there than its fewer
// steps saved (docs/performance.md has the figures).
// In an array of pairs (which a Scratch<NeighbourPair> interleaves between threads) each 16-byte
// load keeps to its own banks.
// `pairs` (a NeighbourPair* or anything indexed like one, such as a Scratch<NeighbourPair>)
// holds pairs_for(k) pairs.
template <typename Pairs>
struct NeighbourHeap {
#if defined(__CUDA_ARCH__)
  static constexpr uint32_t kArity = 4;
#else
  static constexpr uint32_t kArity = 2;
#endif
  Pairs pairs;
  Neighbour top{};
  uint32_t size = 0;

  // Entries 1..k-1 in whole groups of four children (the same on the host, which sizes a GPU's
  // scratch, and enough for pairs of children); the slots past entry k - 1 hold sentinels that no
  // entry loses to.
  CAUSTICA_HDI static constexpr uint32_t pairs_for(uint32_t k) { return 2 * ((k + 2) / 4); }

  // Entry i: after a search, entries [0, size) are the neighbours found, in no particular order.
  CAUSTICA_HDI Neighbour operator[](uint32_t i) const { return i == 0 ? top : slot(i); }

  // Adds x, which the caller has checked against the limit, to a heap of fewer than k entries or
  // in place of the farthest of k. Returns the new limit: the farthest distance once there are k.
  CAUSTICA_HDI float offer(Neighbour x, uint32_t k) {
    if (size == k) return replace_farthest(x);
#if defined(__CUDA_ARCH__)
    // On a GPU each candidate climbs from the end until there are k: the lanes of a warp fill
    // their heaps at different photons, and one construction once full ran for each lane alone,
    // which measured slower.
    uint32_t i = size++;
    while (i > 0) {
      const uint32_t parent = (i - 1) / kArity;
      const Neighbour above = (*this)[parent];
      if (above.distance_squared >= x.distance_squared) break;
      put(i, above);
      i = parent;
    }
    put(i, x);
#else
    // On the CPU candidates are appended until there are k, then one heap construction (Floyd's,
    // O(k), below): they arrive nearest first, so that climbing took most of them all the way up
    // (the render pass 0.79 against 0.71 s). The two backends' heaps then hold the same
    // neighbours in different orders.
    put(size++, x);
#endif
    if (size < k) return INFINITY;
    for (uint32_t e = k; e <= 2 * pairs_for(k); ++e) slot(e) = {-1.0f, 0u};
#if !defined(__CUDA_ARCH__)
    if (k > 1) {
      for (uint32_t i = (k - 2) / kArity + 1; i-- > 0;) sift_down(i, (*this)[i]);
    }
#endif
    return top.distance_squared;
  }

 private:
  // x, nearer than the farthest of a full heap, takes its place. Returns the new farthest
  // distance. The search's hot path: below the root the hole is an address, that of the child
  // just moved up, so no step recomputes it from an entry number.
  CAUSTICA_HDI float replace_farthest(Neighbour x) {
    if (size < 2) {
      top = x;
      return top.distance_squared;
    }
    uint32_t which;
    Neighbour largest = largest_child(0, which);
    if (largest.distance_squared <= x.distance_squared) {
      top = x;
      return top.distance_squared;
    }
    top = largest;
    Neighbour* hole = &child_slot(0, which);
    for (uint32_t i = 1 + which; kArity * i + 1 < size; i = kArity * i + 1 + which) {
      largest = largest_child(i, which);
      if (largest.distance_squared <= x.distance_squared) break;
      *hole = largest;
      hole = &child_slot(i, which);
    }
    *hole = x;
    return top.distance_squared;
  }

  // The largest of node i's children, and which of them it is. On a GPU, by selects on the two
  // pairs as loaded; on the CPU, by indexing memory with the comparison, since a select between
  // two 8-byte values compiled to a branch there that mispredicted half the time.
  CAUSTICA_HDI Neighbour largest_child(uint32_t i, uint32_t& which) const {
#if defined(__CUDA_ARCH__)
    const NeighbourPair low = pairs[2 * i], high = pairs[2 * i + 1];
    const bool low_second = low.entry[1].distance_squared > low.entry[0].distance_squared;
    const bool high_second = high.entry[1].distance_squared > high.entry[0].distance_squared;
    const Neighbour a = low_second ? low.entry[1] : low.entry[0];
    const Neighbour b = high_second ? high.entry[1] : high.entry[0];
    const bool in_high = b.distance_squared > a.distance_squared;
    which = in_high ? 2 + uint32_t(high_second) : uint32_t(low_second);
    return in_high ? b : a;
#else
    const NeighbourPair& children = pairs[i];
    which = children.entry[1].distance_squared > children.entry[0].distance_squared;
    return children.entry[which];
#endif
  }
  // Places x at node i of a full heap, whose subtrees are heaps, moving the hole down.
  CAUSTICA_HDI void sift_down(uint32_t i, Neighbour x) {
    while (kArity * i + 1 < size) {
      uint32_t which;
      const Neighbour largest = largest_child(i, which);
      if (largest.distance_squared <= x.distance_squared) break;
      put(i, largest);
      i = kArity * i + 1 + which;
    }
    put(i, x);
  }
  // Child `which` of node i: entry kArity * i + 1 + which.
  CAUSTICA_HDI Neighbour& child_slot(uint32_t i, uint32_t which) const {
    return slot(kArity * i + 1 + which);
  }
  CAUSTICA_HDI Neighbour& slot(uint32_t i) const { return pairs[(i - 1) >> 1].entry[(i - 1) & 1]; }
  CAUSTICA_HDI void put(uint32_t i, Neighbour x) {
    if (i == 0) {
      top = x;
    } else {
      slot(i) = x;
    }
  }
};

// The threads searching together: `lanes` is a mask of GPU warp lanes that make the same calls
// in step, or 0 for a thread searching alone (always on the CPU). A group's decisions are votes,
// so every member visits every node it needs; which order the group takes changes only speed.
struct SearchGroup {
  uint32_t lanes = 0;

  // Whether any member's `wish` holds.
  CAUSTICA_HDI bool any(bool wish) const {
#if defined(__CUDA_ARCH__)
    return __any_sync(voters(), wish);
#else
    return wish;
#endif
  }
  // Whether more than half of the members' `wish` holds.
  CAUSTICA_HDI bool most(bool wish) const {
#if defined(__CUDA_ARCH__)
    return 2 * __popc(__ballot_sync(voters(), wish)) > __popc(voters());
#else
    return wish;
#endif
  }
  // The members whose `wish` holds, as a group of their own.
  CAUSTICA_HDI SearchGroup among(bool wish) const {
#if defined(__CUDA_ARCH__)
    return {__ballot_sync(voters(), wish) & lanes};
#else
    return {};
#endif
  }

 private:
#if defined(__CUDA_ARCH__)
  // The lanes that vote: a thread searching alone votes by itself. One mask for both cases, where
  // a branch on whether the group is a lone thread cost three or four instructions a vote, at
  // three or more votes a node of the gather's walks.
  __device__ uint32_t voters() const { return lanes | (1u << (threadIdx.x & 31u)); }
#endif
};

// A record of the leaves a walk visited, for a later walk that needs no more of them: this one
// records nothing and replays nothing (binned_estimate.h has one that does).
struct NoLeafLog {
  CAUSTICA_HDI void record(uint32_t) {}
  CAUSTICA_HDI bool replays() const { return false; }
  CAUSTICA_HDI uint32_t next() { return ~0u; }
};

namespace detail {

// How a walk reads the two layouts of the photon map's nodes (PhotonMapNodes): children(node,
// frame, ...) gives both children's boxes and references (bvh.h's convention) and the frames a
// walk keeps for each, to read that child's own children later.
//
// Box pairs store both boxes in full: a walk keeps nothing per node but its index.
struct BoxPairNodes {
  const BvhNode* nodes;
  struct Frame {};

  CAUSTICA_HDI void children(uint32_t node, Frame, Aabb& box0, Aabb& box1, uint32_t& c0,
                             uint32_t& c1, Frame&, Frame&) const {
    const BvhChild a = nodes[node].child[0], b = nodes[node].child[1];
    box0 = a.bounds();
    box1 = b.bounds();
    c0 = a.index;
    c1 = b.index;
  }
};

// Sibling pairs store the planes a child does not inherit (accel/sibling_pair.h): a walk keeps
// each node's box, its children's decode from it, and a deferred subtree waits on the stack with
// its box.
struct SiblingPairNodes {
  const SiblingPairNode* nodes;
  using Frame = Aabb;

  CAUSTICA_HDI void children(uint32_t node, const Aabb& box, Aabb& box0, Aabb& box1, uint32_t& c0,
                             uint32_t& c1, Aabb& frame0, Aabb& frame1) const {
    const SiblingPairNode n = nodes[node];
    sibling_child_boxes(n, box, box0, box1);
    c0 = sibling_reference(n.child[0]);
    c1 = sibling_reference(n.child[1]);
    frame0 = box0;
    frame1 = box1;
  }
};

// visit_photon_leaves over the nodes `tree` reads, `root` being the root's frame.
template <typename Nodes, typename VisitLeaf, typename LeafLog>
CAUSTICA_HDI void walk_photon_leaves(const PhotonMapView& map, Nodes tree,
                                     typename Nodes::Frame root, Vec3f p, const float& limit,
                                     SearchGroup group, VisitLeaf& visit_leaf, LeafLog& log) {
  if (map.count == 0) return;
  // Deferred subtrees keep their box distance: by the time one is popped the limit has usually
  // shrunk below it, and the subtree is dropped without loading its node.
  uint32_t stack[kKnnStackSize];
  float stack_distance[kKnnStackSize];
  typename Nodes::Frame stack_frame[kKnnStackSize];
  typename Nodes::Frame frame = root;
  int top = 0;
  constexpr uint32_t kNone = ~0u;
  // A map of one leaf has no node: its leaf is visited alone.
  const bool replays = log.replays();
  uint32_t node = map.leaf_count == 1 || replays ? kNone : map.root;
  while (true) {
    uint32_t leaf0 = 0u, leaf1 = kNone;
    bool go0 = false, go1 = false;
    float d0 = 0.0f, d1 = 0.0f;
    uint32_t c0 = 0, c1 = 0;
    typename Nodes::Frame f0{}, f1{};
    if (replays) {
      leaf0 = log.next();
      leaf1 = log.next();
    } else if (node != kNone) {
      Aabb box0, box1;
      tree.children(node, frame, box0, box1, c0, c1, f0, f1);
      d0 = distance_squared(box0, p);
      d1 = distance_squared(box1, p);
      const bool want0 = group.any(d0 < limit), want1 = group.any(d1 < limit);
      leaf0 = want0 && is_leaf(c0) ? leaf_index(c0) : kNone;
      leaf1 = want1 && is_leaf(c1) ? leaf_index(c1) : kNone;
      go0 = want0 && !is_leaf(c0);
      go1 = want1 && !is_leaf(c1);
    }
    // One call site: the leaf visit inlines the whole heap insertion.
    CAUSTICA_NO_UNROLL
    for (int l = 0; l < 2; ++l) {
      const uint32_t leaf = l == 0 ? leaf0 : leaf1;  // an array would live in local memory
      if (leaf != kNone) {
        log.record(leaf);
        visit_leaf(leaf);
      }
    }
    if (replays) {
      if (leaf1 == kNone) return;
      continue;
    }
    if (node == kNone) return;
    if (go0 && go1) {
      if (group.most(d1 < d0)) {
        uint32_t c = c0;
        c0 = c1;
        c1 = c;
        float d = d0;
        d0 = d1;
        d1 = d;
        const typename Nodes::Frame f = f0;
        f0 = f1;
        f1 = f;
      }
      stack[top] = c1;
      stack_distance[top] = d1;
      stack_frame[top++] = f1;
      node = c0;
      frame = f0;
    } else if (go0) {
      node = c0;
      frame = f0;
    } else if (go1) {
      node = c1;
      frame = f1;
    } else {
      do {
        if (top == 0) return;
        --top;
      } while (!group.any(stack_distance[top] < limit));
      node = stack[top];
      frame = stack_frame[top];
    }
  }
}

}  // namespace detail

// Calls visit_leaf(leaf) for every leaf of `map` whose box lies within squared distance `limit`
// of `p`, nearer subtrees first; visit_leaf may shrink `limit` as it goes. Every member of `group`
// must make this call with the same map; each branch is a vote, so the members stay in step, and
// a member handed a leaf it does not need rejects its photons by distance. `log` records the
// leaves visited or, when it replays, hands them out instead of the tree (in no particular order).
// The map's node layout is one branch per search, the same for a whole launch.
template <typename VisitLeaf, typename LeafLog = NoLeafLog>
CAUSTICA_HDI void visit_photon_leaves(const PhotonMapView& map, Vec3f p, const float& limit,
                                      SearchGroup group, VisitLeaf visit_leaf,
                                      LeafLog&& log = NoLeafLog{}) {
  if (map.node_layout == PhotonMapNodes::kSiblingPairs) {
    detail::walk_photon_leaves(map, detail::SiblingPairNodes{map.pair_nodes}, map.bounds, p, limit,
                               group, visit_leaf, log);
  } else {
    detail::walk_photon_leaves(map, detail::BoxPairNodes{map.nodes}, {}, p, limit, group,
                               visit_leaf, log);
  }
}

// The GPU searches' batches of photons (visit_photon_batches).
constexpr uint32_t kPhotonBatch = 8;

// v[j] by selects on the bits of j: indexing the array at run time would put it in local memory.
CAUSTICA_HDI float pick(const float v[kPhotonBatch], uint32_t j) {
  static_assert(kPhotonBatch == 8, "three levels of selects");
  const float a0 = j & 1 ? v[1] : v[0], a1 = j & 1 ? v[3] : v[2];
  const float a2 = j & 1 ? v[5] : v[4], a3 = j & 1 ? v[7] : v[6];
  const float b0 = j & 2 ? a1 : a0, b1 = j & 2 ? a3 : a2;
  return j & 4 ? b1 : b0;
}

// offer(d2, first + j) for the batch's photons nearer than `limit`, in photon order, each checked
// again as offer shrinks the limit. The lanes of a warp take this loop together, each at its own
// next photon, so the warp steps through as many offers as its busiest lane makes, not one round
// per photon that any lane takes.
template <typename Offer>
CAUSTICA_HDI void offer_nearer(const float d2[kPhotonBatch], uint32_t first, const float& limit,
                               Offer& offer) {
  uint32_t nearer = 0;  // the photons nearer than the limit, one bit each
  for (uint32_t j = 0; j < kPhotonBatch; ++j) nearer |= uint32_t(d2[j] < limit) << j;
  while (nearer != 0) {
#if defined(__CUDA_ARCH__)
    const uint32_t j = uint32_t(__ffs(int(nearer)) - 1);
#else
    const uint32_t j = uint32_t(__builtin_ctz(nearer));
#endif
    nearer &= nearer - 1;
    const float d = pick(d2, j);
    if (d < limit) offer(d, first + j);
  }
}

#if defined(__CUDA_ARCH__)

// Whether the batches of a leaf starting at photon `first` can be loaded as 16-byte words: four
// positions make three such words, so the first must be a multiple of 4 (every leaf is, when
// photons_per_leaf is) in a 16-byte aligned buffer.
__device__ inline bool vector_loadable(const Vec3f* positions, uint32_t first) {
  static_assert(kPhotonBatch % 4 == 0, "four positions make three 16-byte words");
  return first % 4 == 0 && reinterpret_cast<uintptr_t>(positions) % 16 == 0;
}

// The squared distances from `p` of the photons first .. first + kPhotonBatch, loaded as six
// 16-byte words (vector_loadable).
__device__ __forceinline__ void batch_distances(const Vec3f* positions, uint32_t first, Vec3f p,
                                                float d2[kPhotonBatch]) {
  const float4* from = reinterpret_cast<const float4*>(positions + first);
  for (uint32_t w = 0; w < kPhotonBatch / 4; ++w) {
    const float4 a = __ldg(from + 3 * w), b = __ldg(from + 3 * w + 1), c = __ldg(from + 3 * w + 2);
    d2[4 * w + 0] = length_squared(Vec3f(a.x, a.y, a.z) - p);
    d2[4 * w + 1] = length_squared(Vec3f(a.w, b.x, b.y) - p);
    d2[4 * w + 2] = length_squared(Vec3f(b.z, b.w, c.x) - p);
    d2[4 * w + 3] = length_squared(Vec3f(c.y, c.z, c.w) - p);
  }
}

#endif

// Walks the photons of `map` within squared distance `limit` of `p` leaf by leaf
// (visit_photon_leaves, `log` as there): on a GPU each whole batch of kPhotonBatch photons of a
// leaf that vector_loadable admits goes to on_batch(first, d2) with their squared distances, all
// loaded before any is looked at (one at a time, each photon's load waited behind the previous
// one's heap insertion); every other photon nearer than the limit, and on the CPU every one
// (where eight positions and distances held at once spill x86's vector registers), goes to
// on_photon(d2, index). Both may shrink `limit`.
template <typename OnBatch, typename OnPhoton, typename LeafLog = NoLeafLog>
CAUSTICA_HDI void visit_photon_batches(const PhotonMapView& map, Vec3f p, float& limit,
                                       SearchGroup group, OnBatch on_batch, OnPhoton on_photon,
                                       LeafLog&& log = NoLeafLog{}) {
  visit_photon_leaves(
      map, p, limit, group,
      [&](uint32_t leaf) {
        uint32_t i = map.leaf_begin(leaf);
        const uint32_t end = map.leaf_end(leaf);
#if defined(__CUDA_ARCH__)
        // Asked once a leaf, not at every batch (8 instructions each).
        if (vector_loadable(map.positions, i)) {
          for (; i + kPhotonBatch <= end; i += kPhotonBatch) {
            float d2[kPhotonBatch];
            batch_distances(map.positions, i, p, d2);
            on_batch(i, d2);
          }
        }
#endif
        // The rest one at a time (rolled on a GPU, since the body is big).
        CAUSTICA_NO_UNROLL
        for (; i < end; ++i) {
          const float d2 = length_squared(map.positions[i] - p);
          if (d2 < limit) on_photon(d2, i);
        }
      },
      log);
}

// Calls offer(d2, index) for every photon of `map` at squared distance d2 < `limit` from `p`, by
// leaves nearer subtrees first; offer may shrink `limit` as it goes, and each photon is checked
// against the limit as it stands. Every member of `group` must make this call with the same map.
template <typename Offer>
CAUSTICA_HDI void for_each_photon_within(const PhotonMapView& map, Vec3f p, float& limit,
                                         SearchGroup group, Offer offer) {
  visit_photon_batches(
      map, p, limit, group,
      [&](uint32_t first, const float d2[kPhotonBatch]) { offer_nearer(d2, first, limit, offer); },
      offer);
}

// Finds the (up to) k photons nearest to `p` with squared distance < max_distance_squared and
// leaves them in `heap` (heap.size of them). Every member of `group` must make this call with the
// same map and k.
template <typename Pairs>
CAUSTICA_HDI uint32_t find_nearest(const PhotonMapView& map, Vec3f p, uint32_t k,
                                   float max_distance_squared, NeighbourHeap<Pairs>& heap,
                                   SearchGroup group = {}) {
  heap.size = 0;
  if (k == 0) return 0;
  float limit = max_distance_squared;  // shrinks to the k-th distance once the heap is full
  for_each_photon_within(map, p, limit, group, [&](float d2, uint32_t index) {
    limit = min_f(limit, heap.offer({d2, index}, k));
  });
  return heap.size;
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
// `pairs` is a NeighbourHeap's storage for k.
template <typename Pairs>
CAUSTICA_HDI RadianceEstimate estimate_radiance_within(const PhotonMapView& map, Vec3f p,
                                                       Vec3f normal, Vec3f albedo, uint32_t k,
                                                       float max_radius, Kernel kernel, Pairs pairs,
                                                       float bound_squared, SearchGroup group) {
  NeighbourHeap<Pairs> heap{pairs};
  const float max_d2 = max_radius * max_radius;
  // One call site for both searches, since each inlines the whole search.
  float limit = bound_squared < max_d2 ? bound_squared : max_d2;
  SearchGroup searching = group;
  bool searches = true;
  uint32_t found = 0;
  while (true) {
    if (searches) found = find_nearest(map, p, k, limit, heap, searching);
    // Rare: the members whose bound held fewer than k search again from the maximum.
    const bool missed = searches && limit < max_d2 && found < k;
    if (!group.any(missed)) break;
    searching = group.among(missed);
    searches = missed;
    limit = max_d2;
  }
  if (found == 0) return {Vec3f(0.0f), max_d2};
  const float r2 = found == k ? heap.top.distance_squared : max_d2;
  if (r2 <= 0.0f) return {Vec3f(0.0f), r2};
  Vec3f flux(0.0f);
  const float inv_r2 = 1.0f / r2;
  // Unrolled so that several photons' flux loads are in flight at once.
  CAUSTICA_UNROLL_BY(4)
  for (uint32_t i = 0; i < found; ++i) {
    const Neighbour n = heap[i];
    const PhotonFlux ph = map.flux_of(n.index);
    if (!octahedral_along(ph.incoming, normal)) continue;
    flux += ph.power * kernel_weight(kernel, n.distance_squared * inv_r2);
  }
  return {albedo * flux * (kInvPi * kInvPi * inv_r2), r2};
}

// The same for a lone search with no bound.
template <typename Pairs>
CAUSTICA_HDI Vec3f estimate_radiance(const PhotonMapView& map, Vec3f p, Vec3f normal, Vec3f albedo,
                                     uint32_t k, float max_radius, Kernel kernel, Pairs pairs) {
  return estimate_radiance_within(map, p, normal, albedo, k, max_radius, kernel, pairs, INFINITY,
                                  {})
      .radiance;
}

}  // namespace caustica
