// The k nearest photons found so far, as a max-heap whose root is the current k-th distance:
// what a k-nearest search (knn_estimate.h) offers each photon its range query finds.
#pragma once

#include <cstdint>

#include "renderer/base/hd.h"

namespace caustica {

constexpr uint32_t kMaxNearest = 1024;  // the largest k validation admits

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

}  // namespace caustica
