// Rebuilds the small subtrees of a triangle LBVH by the surface area heuristic (binned SAH, Wald
// 2007, "On fast Construction of SAH-based Bounding Volume Hierarchies"), level by level over all
// of them at once, a range of triangles per thread.
//
// A radix tree splits where the curve's codes split: at the bottom, where a few hundred triangles
// of a scanned surface share a handful of octree cells, those splits cut the surface into boxes
// that overlap and leave much empty space, and the leaves of up to four triangles that the
// collapse makes (bvh4.h) group triangles by cell rather than by how well they fit together.
// Rebuilding those subtrees by SAH below kSahSubtreeTriangles speeds every kind of ray
// (docs/performance.md, "Tree quality and photon order"); a full SAH build from the root was no
// better for shadow rays and needs its work spread over every level.
//
// Each maximal subtree of at most kSahSubtreeTriangles triangles is a contiguous range of the
// sorted triangles, and whatever binary tree is built over a range fits the radix tree's layout:
// internal node k splits between positions k and k + 1, so the range's internal nodes take exactly
// the indices its old ones had. The triangles move only within their range, and the tree above is
// untouched. Every decision is an integer or an uncontracted float operation, so each backend
// builds the same tree.
#pragma once

#include "renderer/accel/bvh.h"
#include "renderer/accel/triangle.h"
#include "renderer/base/atomic.h"

namespace caustica {

// The largest subtree rebuilt. Larger limits gained shadow rays little and cost the build several
// times over, since a range's splits are each one thread's (docs/performance.md, "Tree quality
// and photon order").
constexpr uint32_t kSahSubtreeTriangles = 256;

constexpr uint32_t kNoParent = 0xffffffffu;

// A maximal subtree of at most kSahSubtreeTriangles (and at least two) leaves: the sorted range
// [first, last] it covers, and the slot that points to it (child `side` of internal node
// `parent`, or the root itself when parent is kNoParent).
struct SmallSubtree {
  uint32_t parent;
  uint32_t side;
  uint32_t first, last;
};

// The LBVH build's node hook (build_bvh_from_sorted_codes) that lists the maximal subtrees of at
// most `limit` triangles: a complete node larger than the limit lists its children within it, and
// a whole tree within it lists its root. `list` has room for leaves / 2 entries (the subtrees are
// disjoint, with at least two leaves each); `count` starts at 0.
struct ListSmallSubtrees {
  SmallSubtree* list;
  uint32_t* count;
  uint32_t leaves;
  uint32_t limit = kSahSubtreeTriangles;

  CAUSTICA_HDI void operator()(uint32_t node, uint32_t first, uint32_t last) const {
    auto add = [&](uint32_t parent, uint32_t side, uint32_t from, uint32_t to) {
      list[atomic_fetch_add(count, 1u)] = {parent, side, from, to};
    };
    if (last - first + 1 <= limit) {
      if (first == 0 && last == leaves - 1) add(kNoParent, 0, first, last);
      return;
    }
    // The children cover [first, node] and [node + 1, last].
    if (node - first + 1 >= 2 && node - first + 1 <= limit) add(node, 0, first, node);
    if (last - node >= 2 && last - node <= limit) add(node, 1, node + 1, last);
  }
};

// Rebuilds each listed subtree of `bvh` (`count` of them, in the backend's memory) by SAH, and
// moves `triangles` and `triangle_ids` (both in leaf order) within each range to the new order.
// `root_listed`: whether the root is among them (parent kNoParent), so that bvh.root changes.
void rebuild_small_subtrees(Backend& backend, Bvh& bvh, const SmallSubtree* list, uint32_t count,
                            Buffer<TriangleVertices>& triangles, Buffer<uint32_t>& triangle_ids,
                            bool root_listed);

}  // namespace caustica
