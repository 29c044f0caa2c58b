// The range query over a photon map: every photon within a squared distance of a point, by
// leaves nearer subtrees first, the distance allowed to shrink as the caller goes (a k-nearest
// search shrinks it to its k-th distance; a fixed-radius gather keeps it). Estimators build on it
// (knn_estimate.h; binned_estimate.h).
//
// A search group makes a renderer's many queries cheaper without changing what they find:
// threads whose points lie close together (a GPU warp of requests in Hilbert order) walk the tree
// as one, each node visited when any of them needs it, so they read the same nodes and photons in
// step instead of diverging.
#pragma once

#include <cmath>
#include <cstdint>

#include "renderer/photon/photon_map.h"

namespace caustica {

constexpr int kKnnStackSize = 64;

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

// The threads of the caller's warp in a parallel_for over `n` threads (the caller being thread
// `i`), as a search group: on a GPU every lane of the warp whose index is below n, which makes the
// same calls as long as the kernel's control flow keeps the warp together; on the CPU a lone
// thread.
CAUSTICA_HDI SearchGroup launch_warp(size_t i, size_t n) {
#if defined(__CUDA_ARCH__)
  const size_t first = i - (i & 31u);
  const size_t in_warp = n - first < 32 ? n - first : 32;
  return {in_warp == 32 ? ~0u : (1u << in_warp) - 1u};
#else
  (void)i;
  (void)n;
  return {};
#endif
}

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

}  // namespace caustica
