// H-PLOC (Benthin, Meister, Barczak, Mehalwal, Tsakok and Kensler, "H-PLOC: Hierarchical Parallel
// Locally-Ordered Clustering for Bounding Volume Hierarchy Construction", HPG 2024): a binary BVH
// of PLOC quality built in one bottom-up pass over the triangles' curve order.
//
// Each leaf's thread climbs the implicit radix tree of the sorted codes as the LBVH build does
// (bvh_build.h, after Apetrei 2014): the first of two siblings to reach their parent stops, the
// second goes on with the union of their ranges. A range's clusters (subtrees not yet merged)
// are kept at the front of its slice of one index array. Where a range grows past
// kHplocMaxClusters triangles, its two halves' clusters (at most 2 x kHplocMaxClusters) are
// merged PLOC-style: every cluster finds its nearest neighbour (the smallest merged box area)
// among the kHplocSearchRadius clusters on either side, mutual pairs merge into a new node, and
// this repeats until at most kHplocMaxClusters remain (one, at the root). On a GPU a warp merges
// the clusters of one range together, a cluster per lane; on the CPU one thread runs the same
// rounds over an array. Every decision (the pairs' areas and their ties, which are broken by the
// pair's positions) is computed alike on both, so both build the same tree; only the numbering
// of the internal nodes, which come from an atomic counter, differs.
#pragma once

#include "renderer/accel/triangle_bvh.h"

namespace caustica {

// Clusters a range hands up to its parent, and so the number of triangles a range may hold
// before its clusters are merged: H-PLOC's merging threshold.
constexpr uint32_t kHplocMaxClusters = 16;
// How many clusters on either side a cluster compares itself with.
constexpr uint32_t kHplocSearchRadius = 8;
// The leaf size leaf_pieces counts in: the 8-wide layout's (bvh8.h).
constexpr uint32_t kHplocLeafTriangles = 3;

// A binary BVH whose children are any nodes (not the radix tree's layout): internal node k's
// children are BvhNode::child[0..1], each kLeafFlag | sorted position or another node, with
// `unused` holding the child's subtree size in triangles.
struct ClusteredTriangleBvh {
  Buffer<BvhNode> nodes;  // count - 1 internal nodes for count >= 2
  // Per internal node: the leaves of at most kHplocLeafTriangles its subtree falls into when
  // every larger part is split (the 8-wide collapse asks it of small subtrees).
  Buffer<uint32_t> leaf_pieces;
  Buffer<TriangleVertices> triangles;  // in the curve order the leaves name
  Buffer<uint32_t> triangle_ids;       // sorted -> original triangle index
  Aabb bounds;
  uint32_t count = 0;
  uint32_t root = 0;  // kLeafFlag | 0 for a single triangle
};

// Builds the H-PLOC tree over `count` triangles in the backend's memory, along `curve`.
ClusteredTriangleBvh build_hploc_bvh(Backend& backend, const TriangleVertices* triangles,
                                     uint32_t count, Curve curve);

}  // namespace caustica
