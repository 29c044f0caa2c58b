// A binned SAH BVH built breadth-first from the root (Zeidan 2011, ch. 4; Wald 2007), in stages
// that differ in the size of the nodes they split and so in how many bins those nodes use
// (BinnedSahSchedule, build_options.h):
// - Nodes of more than the schedule's per-node limit are split level by level over all of them
//   at once, data-parallel over their triangles: each triangle takes a bin along its node's
//   longest centroid axis (or the node's last bin when it is huge for its node, binned_sah.cc),
//   with as many bins as its node's stage gives; the triangles are put in (node, bin) order,
//   either by one stable radix sort of the key node << b | bin (Zeidan's fast variant) or by a
//   stable split of every node's triangles per bit of the bin (his segmented splits), so a split
//   is a position and the children need no partition pass; the bins' counts and bounds are
//   reduced over chunks of the sorted run, and one thread per node sweeps the bins for the
//   cheapest split. Zeidan runs his stages one after another; here the nodes of every stage split
//   in the same level, each with its own stage's bins, which builds the same tree in fewer
//   launches.
// - Nodes within the per-node limit are finished a node per thread by the SAH subtree builder the
//   LBVH uses (sah_subtrees.h), with bins on all three axes.
// The tree keeps the radix tree's layout (internal node k splits between leaf positions k and
// k + 1), so it collapses to 4-wide nodes like the LBVH (bvh4.h). Every decision is an integer
// or an exact float operation (minima, maxima, counts), so each backend builds the same tree,
// and both orderings build the same tree.
//
// The stages start from any number of disjoint subtrees at once (rebuild_subtrees_by_binned_sah):
// the hybrid structure (hybrid_bvh.h) hands them the LBVH's subtrees below its cut, and a build
// from the root is the case of one subtree, the whole range.
#pragma once

#include <string>
#include <string_view>

#include "renderer/accel/build_options.h"
#include "renderer/accel/sah_subtrees.h"
#include "renderer/accel/triangle_bvh.h"

namespace caustica {

// The schedule of `text` ("ABOVE:BINS,...", parse_binned_sah_stages in build_options.h) ordered
// by `reorder`; throws std::invalid_argument naming the stage and the problem. For tools and tests
// that name schedules themselves.
BinnedSahSchedule parse_binned_sah_schedule(
    std::string_view text, BinnedSahReorder reorder = BinnedSahReorder::kRadixSort);

// Rebuilds each of the `segment_count` subtrees of `tree` listed in `segments` (in the backend's
// memory, in any order; disjoint ranges of its sorted triangles of at least two each, as
// ListSmallSubtrees lists them) by the stages: the data-parallel ones over all of them at once,
// level by level, then the per-node one within the schedule's per-node limit. Their triangles move
// only within their ranges, and the nodes above them are untouched. `root_listed`: whether the root
// is the one segment, whose box then becomes tree.bvh.bounds.
void rebuild_subtrees_by_binned_sah(Backend& backend, BinaryTriangleBvh& tree,
                                    const SmallSubtree* segments, uint32_t segment_count,
                                    bool root_listed, const BinnedSahSchedule& schedule = {});

// The binary SAH BVH over `count` triangles in the backend's memory.
BinaryTriangleBvh build_binned_sah_bvh(Backend& backend, const TriangleVertices* triangles,
                                       uint32_t count, const BinnedSahSchedule& schedule = {});

}  // namespace caustica
