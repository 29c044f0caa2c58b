// A 4-wide BVH collapsed from the binary LBVH: each node holds its four children's boxes in
// structure-of-arrays form, so one node fetch feeds four box tests that the compiler turns into
// SIMD on the CPU. Collapsing halves the depth and the dependent loads along a ray, which is what
// bounds traversal (the binary tree spent ~30 ns per node visit on the dragon, nearly all in
// waiting for the node). The greedy choice of which children to open follows Wald et al.,
// "Getting Rid of Packets" (2008): open the child of largest surface area until four remain.
#pragma once

#include <cstdint>

#include "renderer/accel/bvh.h"

namespace caustica {

constexpr uint32_t kEmptyChild = 0xffffffffu;

struct Bvh4Node {
  float lower_x[4], upper_x[4], lower_y[4], upper_y[4], lower_z[4], upper_z[4];
  uint32_t child[4];  // Bvh4 node index, kLeafFlag | sorted primitive, or kEmptyChild

  CAUSTICA_HDI Aabb child_bounds(int i) const {
    return {Vec3f(lower_x[i], lower_y[i], lower_z[i]), Vec3f(upper_x[i], upper_y[i], upper_z[i])};
  }
};

struct Bvh4 {
  Buffer<Bvh4Node> nodes;  // node 0 is the root (when there are >= 2 leaves)
  Aabb bounds;
  uint32_t leaf_count = 0;
};

// Collapses `binary` into a 4-wide tree over the same sorted leaves, level by level from the root
// (two passes and a scan per level, so it runs on any backend).
Bvh4 collapse_to_bvh4(Backend& backend, const Bvh& binary);

}  // namespace caustica
