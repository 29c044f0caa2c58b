// The hybrid build (Zeidan 2011, ch. 4: "LBVH for the top levels, binned SAH below"): the LBVH's
// radix tree over the triangles' curve order (triangle_bvh.h) gives the top levels, fast to build
// and where a scanned mesh's curve order already splits well; below the cut, where each maximal
// subtree holds at most kHybridLbvhSubtreeTriangles triangles (a contiguous range of the sorted
// triangles), every subtree is rebuilt by the binned SAH stages of binned_sah.h, level by level
// over all of them at once, then node by node below kSahSubtreeTriangles. The tree keeps the radix
// tree's layout, so it collapses to the same 4-wide nodes as lbvh4 and binned-sah.
#pragma once

#include "renderer/accel/binned_sah.h"
#include "renderer/accel/triangle_bvh.h"

namespace caustica {

// The largest subtree of the LBVH that binned SAH rebuilds, chosen by measuring build time and
// SAH cost on the bunny and the dragon (docs/structures.md, "hybrid").
constexpr uint32_t kHybridLbvhSubtreeTriangles = 1u << 14;

// The hybrid binary tree over `count` triangles in the backend's memory, along `curve`, cut where
// subtrees fall to at most `lbvh_limit` (>= 2) triangles, and those rebuilt by `schedule`'s
// stages.
BinaryTriangleBvh build_hybrid_bvh(Backend& backend, const TriangleVertices* triangles,
                                   uint32_t count, Curve curve,
                                   uint32_t lbvh_limit = kHybridLbvhSubtreeTriangles,
                                   const BinnedSahSchedule& schedule = {});

}  // namespace caustica
