// The ray-tracing structure over a scene's triangles: an LBVH (Karras 2012) whose leaves are the
// triangles in Morton order, stored as vertex triples next to their original indices.
#pragma once

#include <span>

#include "renderer/accel/bvh.h"
#include "renderer/accel/triangle.h"

namespace caustica {

// Plain pointers into a TriangleBvh, copied by value into kernels.
struct TriangleBvhView {
  const BvhNode* nodes = nullptr;
  const TriangleVertices* triangles = nullptr;  // in leaf (sorted) order
  const uint32_t* triangle_ids = nullptr;       // leaf -> original triangle index
  uint32_t count = 0;
  uint32_t root = 0;
  Aabb bounds;
};

struct TriangleBvh {
  Bvh bvh;
  Buffer<TriangleVertices> triangles;
  Buffer<uint32_t> triangle_ids;

  TriangleBvhView view() const {
    return {bvh.nodes.data(), triangles.data(), triangle_ids.data(), bvh.leaf_count, bvh.root,
            bvh.bounds};
  }
  size_t bytes() const { return bvh.nodes.bytes() + triangles.bytes() + triangle_ids.bytes(); }
};

// Builds the structure from triangles already in the backend's memory (`count` of them).
TriangleBvh build_triangle_bvh(Backend& backend, const TriangleVertices* triangles, uint32_t count);

}  // namespace caustica
