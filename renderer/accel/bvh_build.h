// The binary radix tree over sorted Morton or Hilbert codes (Karras 2012), built bottom-up in one
// pass after Apetrei, "Fast and Simple Agglomerative LBVH Construction" (CGVC 2014): internal node
// k sits between leaves k and k+1; a node covering leaves [l, r] becomes a child of whichever
// neighbour split, l-1 or r, has the longer common prefix. Each leaf's thread climbs until it is
// the first of two siblings to reach their parent (an atomic exchange decides), merging boxes on
// the way, so topology and bounds come out of the same pass with O(n) total work and no binary
// searches.
//
// A template so that each caller computes its leaf boxes on the fly (from sorted triangles or
// photons) instead of writing and re-reading an array of them.
#pragma once

#include "renderer/accel/bvh.h"
#include "renderer/base/atomic.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

namespace detail {

constexpr uint32_t kUnvisited = 0xffffffffu;

// The split key between leaves k and k+1: the xor of their codes, with ties between equal codes
// broken by the indices (Karras sec. 4), so every split differs and the tree is unique. A smaller
// value means a longer common prefix.
CAUSTICA_HDI uint64_t split_key(const uint32_t* codes, uint32_t k) {
  uint32_t x = codes[k] ^ codes[k + 1];
  return x != 0 ? (uint64_t(x) << 32) : uint64_t(k ^ (k + 1));
}

}  // namespace detail

// What a build does with each internal node once it is complete: nothing, by default.
struct IgnoreNodes {
  CAUSTICA_HDI void operator()(uint32_t, uint32_t, uint32_t) const {}
};

// What the host needs of a build, fetched in one copy when it ends: the primitives' bounds
// (written before the build by Backend::reduce_bounds_to) and the root (written by the build).
struct BvhSummary {
  Aabb bounds;
  uint32_t root;
};

// Launches the binary radix tree's build over `n` primitives whose codes are sorted ascending, with
// `summary` (in the backend's memory) holding their bounds, and returns without waiting: the root
// is written to `summary`, and finish_bvh gives the Bvh its bounds and root from a copy of it, so
// that builds launched together wait for the device once;
// `leaf_box(i)` (a CAUSTICA_HD functor) gives the box of the i-th primitive in that order; it is
// called exactly once per leaf, so it may also move that primitive into its sorted place.
// `on_node(node, first, last)` is called once for each internal node, with the range of leaves it
// covers, when both its children are written. Equal codes are split by index, so any input gives a
// valid tree.
template <typename LeafBox, typename OnNode = IgnoreNodes>
Bvh launch_bvh_from_sorted_codes(Backend& backend, const uint32_t* sorted_codes, uint32_t n,
                                 BvhSummary* summary, LeafBox leaf_box,
                                 OnNode on_node = IgnoreNodes{}) {
  Bvh bvh;
  bvh.leaf_count = n;
  bvh.nodes.bind(backend);
  if (n == 1)
    parallel_for(backend, "lbvh_single_leaf", 1, [=] CAUSTICA_HD(size_t) { (void)leaf_box(0u); });
  if (n < 2) return bvh;

  bvh.nodes.resize_discard(n - 1);
  // other_end[k]: the far end of the range of node k's first child to arrive, or kUnvisited.
  Buffer<uint32_t> other_end(backend, n - 1);
  backend.fill_bytes(other_end.data(), 0xff, other_end.size() * sizeof(uint32_t));

  BvhNode* nodes = bvh.nodes.data();
  uint32_t* other = other_end.data();
  uint32_t* root_out = &summary->root;
  const uint32_t last = n - 1;

  parallel_for(backend, "lbvh_hierarchy", n, [=] CAUSTICA_HD(size_t leaf) {
    uint32_t l = uint32_t(leaf), r = uint32_t(leaf);
    uint32_t current = kLeafFlag | uint32_t(leaf);
    Aabb box = leaf_box(uint32_t(leaf));
    while (true) {
      uint32_t parent, seen;
      int side;  // which child of `parent` we are; the sibling is the other
      if (l == 0 || (r != last &&
                     detail::split_key(sorted_codes, r) < detail::split_key(sorted_codes, l - 1))) {
        parent = r;  // we are the left child of the split after our range
        side = 0;
      } else {
        parent = l - 1;  // we are the right child of the split before our range
        side = 1;
      }
      nodes[parent].child[side] = BvhChild{box.lower, current, box.upper};
      seen = atomic_exchange(&other[parent], side == 0 ? l : r);
      if (seen == detail::kUnvisited) return;  // the sibling will finish this node
      if (side == 0) {
        r = seen;
      } else {
        l = seen;
      }
      const BvhChild sibling = nodes[parent].child[1 - side];
      box = merge(box, sibling.bounds());
      current = parent;
      on_node(current, l, r);
      if (l == 0 && r == last) {
        *root_out = current;
        return;
      }
    }
  });
  return bvh;
}

// The bounds and root of a build that launch_bvh_from_sorted_codes launched, from its summary
// copied to the host once the build is done.
inline void finish_bvh(Bvh& bvh, const BvhSummary& summary) {
  bvh.bounds = summary.bounds;
  bvh.root = bvh.leaf_count < 2 ? 0 : summary.root;
}

// The build launched and finished: one wait for the device.
template <typename LeafBox, typename OnNode = IgnoreNodes>
Bvh build_bvh_from_sorted_codes(Backend& backend, const uint32_t* sorted_codes, uint32_t n,
                                BvhSummary* summary, LeafBox leaf_box,
                                OnNode on_node = IgnoreNodes{}) {
  Bvh bvh = launch_bvh_from_sorted_codes(backend, sorted_codes, n, summary, leaf_box, on_node);
  BvhSummary copied;
  backend.copy_to_host(&copied, summary, sizeof(BvhSummary));
  finish_bvh(bvh, copied);
  return bvh;
}

}  // namespace caustica
