// A binned SAH BVH built breadth-first from the root (Zeidan 2011, ch. 4; Wald 2007), in two
// stages:
// - Nodes of more than kSahSubtreeTriangles triangles are split level by level over all of them
//   at once, data-parallel over their triangles: each triangle takes a bin along its node's
//   longest centroid axis (or the node's last bin when it is huge for its node, binned_sah.cc),
//   one stable radix sort by (node, bin) puts every node's triangles in bin order (so a split is
//   a position and the children need no partition pass), the bins' counts and bounds are
//   reduced over chunks of the sorted run, and one thread per node sweeps the bins for the
//   cheapest split.
// - Smaller nodes are finished a node per thread by the SAH subtree builder the LBVH uses
//   (sah_subtrees.h), with bins on all three axes.
// The tree keeps the radix tree's layout (internal node k splits between leaf positions k and
// k + 1), so it collapses to 4-wide nodes like the LBVH (bvh4.h). Every decision is an integer
// or an exact float operation (minima, maxima, counts), so each backend builds the same tree.
//
// The stages start from any number of disjoint subtrees at once (rebuild_subtrees_by_binned_sah):
// the hybrid structure (hybrid_bvh.h) hands them the LBVH's subtrees below its cut, and a build
// from the root is the case of one subtree, the whole range.
#pragma once

#include "renderer/accel/sah_subtrees.h"
#include "renderer/accel/triangle_bvh.h"

namespace caustica {

// Bins along a node's longest centroid axis in the data-parallel stage, as a power of two
// (docs/structures.md, "binned-sah").
constexpr int kBinnedSahLogBins = 5;
constexpr uint32_t kBinnedSahBins = 1u << kBinnedSahLogBins;

// Rebuilds each of the `segment_count` subtrees of `tree` listed in `segments` (in the backend's
// memory, in any order; disjoint ranges of its sorted triangles of at least two each, as
// ListSmallSubtrees lists them) by the two stages: the data-parallel one over all of them at once,
// level by level, then the per-node one below kSahSubtreeTriangles. Their triangles move only
// within their ranges, and the nodes above them are untouched. `root_listed`: whether the root is
// the one segment, whose box then becomes tree.bvh.bounds.
void rebuild_subtrees_by_binned_sah(Backend& backend, BinaryTriangleBvh& tree,
                                    const SmallSubtree* segments, uint32_t segment_count,
                                    bool root_listed);

// The binary SAH BVH over `count` triangles in the backend's memory.
BinaryTriangleBvh build_binned_sah_bvh(Backend& backend, const TriangleVertices* triangles,
                                       uint32_t count);

}  // namespace caustica
