// The ray-tracing structure over a scene's triangles: the binary LBVH (Karras 2012) over the
// triangles in Hilbert or Morton order (curve_order.h), its small subtrees rebuilt by SAH
// (sah_subtrees.h), collapsed into a 4-wide tree for traversal whose leaves are runs of up to
// kMaxLeafTriangles (bvh4.h); the triangles are stored as vertex triples in leaf order, so a leaf
// names them by range, next to their original indices.
#pragma once

#include "renderer/accel/bvh.h"
#include "renderer/accel/bvh4.h"
#include "renderer/accel/curve_order.h"
#include "renderer/accel/triangle.h"

namespace caustica {

struct SmallSubtree;  // sah_subtrees.h

// Plain pointers into a TriangleBvh, copied by value into kernels.
struct TriangleBvhView {
  const Bvh4Node* nodes = nullptr;
  const TriangleVertices* triangles = nullptr;  // in sorted order: leaves are ranges of it
  const uint32_t* triangle_ids = nullptr;       // sorted -> original triangle index
  uint32_t count = 0;
  Aabb bounds;
};

// A binary BVH over triangles (an LBVH, or one built by SAH from the root) and the triangles in
// its leaf order.
struct BinaryTriangleBvh {
  Bvh bvh;
  Buffer<TriangleVertices> triangles;
  Buffer<uint32_t> triangle_ids;
};

struct TriangleBvh {
  Bvh4 bvh;
  Buffer<TriangleVertices> triangles;
  Buffer<uint32_t> triangle_ids;

  TriangleBvhView view() const {
    return {bvh.nodes.data(), triangles.data(), triangle_ids.data(), bvh.triangle_count,
            bvh.bounds};
  }
  size_t node_count() const { return bvh.nodes.size(); }
  size_t bytes() const { return bvh.nodes.bytes() + triangles.bytes() + triangle_ids.bytes(); }
};

// Builds the binary LBVH from triangles already in the backend's memory (`count` of them), along
// `curve`, by default the backend's (backend_curve).
BinaryTriangleBvh build_triangle_lbvh(Backend& backend, const TriangleVertices* triangles,
                                      uint32_t count, Curve curve);
BinaryTriangleBvh build_triangle_lbvh(Backend& backend, const TriangleVertices* triangles,
                                      uint32_t count);

// The LBVH, listing its maximal subtrees of at most `limit` (>= 2) triangles as ListSmallSubtrees
// (sah_subtrees.h) does: `list`, in the backend's memory, has room for count / 2 + 1 of them, and
// `listed` (one word there, zeroed by the caller) receives how many it holds. A tree of at most
// `limit` triangles lists its root.
BinaryTriangleBvh build_triangle_lbvh_listing_subtrees(Backend& backend,
                                                       const TriangleVertices* triangles,
                                                       uint32_t count, Curve curve, uint32_t limit,
                                                       SmallSubtree* list, uint32_t* listed);

// The LBVH with its small subtrees rebuilt by SAH (sah_subtrees.h): the same layout, leaves in a
// new order.
BinaryTriangleBvh build_sah_refined_lbvh(Backend& backend, const TriangleVertices* triangles,
                                         uint32_t count, Curve curve);

// `binary` collapsed to 4-wide nodes (bvh4.h), taking over its triangles and their ids.
TriangleBvh collapse_triangle_bvh(Backend& backend, BinaryTriangleBvh binary);

// `bvh` refitted over `triangles`, as many as it was built over and in the same (original)
// order, moved but with their topology kept: the same nodes and leaf order with every box
// recomputed from the leaves up, a level at a time from the deepest (Bvh4::level_starts), in new
// buffers beside `bvh`. Over triangles that did not move, the result is byte for byte `bvh`.
TriangleBvh refit_triangle_bvh(Backend& backend, const TriangleBvh& bvh,
                               const TriangleVertices* triangles, uint32_t count);

// The refined LBVH collapsed to 4-wide nodes: what traversal uses.
TriangleBvh build_triangle_bvh(Backend& backend, const TriangleVertices* triangles, uint32_t count,
                               Curve curve);
TriangleBvh build_triangle_bvh(Backend& backend, const TriangleVertices* triangles, uint32_t count);

}  // namespace caustica
