// The `sibling-pair` triangle structure: the binary tree that lbvh4 collapses (the LBVH with its
// small subtrees rebuilt by SAH, triangle_bvh.h) kept binary and stored in 32-byte sibling-pair
// nodes (sibling_pair.h), its leaves runs of up to kMaxLeafTriangles sorted triangles chosen as
// the 4-wide collapse chooses them (binary_subtree_becomes_leaf, bvh4.h). Nodes lie level by
// level from the root (node 0), so that the build and the SAH cost run a level per launch.
#pragma once

#include <vector>

#include "renderer/accel/bvh4.h"
#include "renderer/accel/sibling_pair.h"
#include "renderer/accel/triangle_bvh.h"

namespace caustica {

// A leaf's 28-bit reference (sibling_pair.h): (count - 1) << kSiblingLeafCountShift | first, the
// sorted triangles [first, first + count). The count's two bits leave the first index 26, which
// caps the triangles of this structure below the scene limit (kMaxBvh4Triangles).
constexpr int kSiblingLeafCountShift = 26;
constexpr uint32_t kMaxSiblingPairTriangles = 1u << kSiblingLeafCountShift;
static_assert(kMaxLeafTriangles - 1 <= (kSiblingReferenceMask >> kSiblingLeafCountShift),
              "a leaf's triangle count must fit above its first index");

CAUSTICA_HDI uint32_t make_sibling_leaf(uint32_t first, uint32_t count) {
  return kLeafFlag | (count - 1) << kSiblingLeafCountShift | first;
}
// For a reference (sibling_reference) with is_leaf.
CAUSTICA_HDI uint32_t sibling_leaf_first(uint32_t reference) {
  return reference & ((1u << kSiblingLeafCountShift) - 1u);
}
CAUSTICA_HDI uint32_t sibling_leaf_count(uint32_t reference) {
  return ((reference & kSiblingReferenceMask) >> kSiblingLeafCountShift) + 1;
}

// Entries of a traversal's stack, which holds at most one per level of the tree: the build refuses
// deeper trees. The LBVH's depth stays far below it (30-bit codes, their ties split by index), and
// so does that of the SAH subtrees below it.
constexpr int kSiblingPairStackSize = 96;

// Plain pointers into a SiblingPairBvh, copied by value into kernels; `bounds` is the box the root
// decodes its children from.
struct SiblingPairView {
  const SiblingPairNode* nodes = nullptr;
  const TriangleVertices* triangles = nullptr;  // in sorted order: leaves are ranges of it
  const uint32_t* triangle_ids = nullptr;       // sorted -> original triangle index
  uint32_t count = 0;
  Aabb bounds;
};

struct SiblingPairBvh {
  Buffer<SiblingPairNode> nodes;  // node 0 is the root when there are >= 2 triangles
  Buffer<TriangleVertices> triangles;
  Buffer<uint32_t> triangle_ids;
  Aabb bounds;
  uint32_t triangle_count = 0;
  // Level l of the tree is nodes [level_starts[l], level_starts[l + 1]); the last entry is the
  // node count.
  std::vector<uint32_t> level_starts;

  SiblingPairView view() const {
    return {nodes.data(), triangles.data(), triangle_ids.data(), triangle_count, bounds};
  }
  size_t node_count() const { return nodes.size(); }
  size_t bytes() const { return nodes.bytes() + triangles.bytes() + triangle_ids.bytes(); }
};

// `binary` (a radix tree over sorted triangles, internal node k splitting between leaves k and
// k + 1) in sibling-pair nodes, taking over its triangles and their ids. Throws
// std::invalid_argument past kMaxSiblingPairTriangles triangles or for a tree with more levels
// than kSiblingPairStackSize.
SiblingPairBvh build_sibling_pair_bvh(Backend& backend, BinaryTriangleBvh binary);

// The SAH cost (StructureStats::sah_cost) of the tree, its boxes decoded level by level on the
// backend.
double sah_cost(Backend& backend, const SiblingPairBvh& bvh);

}  // namespace caustica
