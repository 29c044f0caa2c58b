// Binary BVH shared by the triangle structure and the photon map. Leaves are primitives (or runs
// of them) in the order of their codes along a space-filling curve (curve_order.h); each internal
// node stores its two children's boxes, so a traversal step tests both children with one node
// fetch and leaves need no node of their own.
#pragma once

#include <cstdint>

#include "renderer/base/aabb.h"
#include "renderer/parallel/buffer.h"

namespace caustica {

constexpr uint32_t kLeafFlag = 0x80000000u;

CAUSTICA_HDI bool is_leaf(uint32_t child) { return (child & kLeafFlag) != 0; }
CAUSTICA_HDI uint32_t leaf_index(uint32_t child) { return child & ~kLeafFlag; }

// One child of a binary node: its box with the child's index between the corners, so that a slot
// is two aligned 16-byte words. The bottom-up build writes a slot with two vector stores and reads
// its sibling's with two vector loads (six or seven scalar accesses each, with a 56-byte node, were
// most of its L2 traffic), and the kNN search fetches a node in four loads.
struct alignas(16) BvhChild {
  Vec3f lower;
  uint32_t index;  // internal node index, or kLeafFlag | leaf
  Vec3f upper;
  uint32_t unused = 0;  // keeps nodes byte-comparable

  CAUSTICA_HDI Aabb bounds() const { return {lower, upper}; }
};

struct BvhNode {
  BvhChild child[2];
};

// A built hierarchy over `leaf_count` primitives: leaf_count - 1 internal nodes, `root` among them.
// A single primitive has no internal node; its box is `bounds`.
struct Bvh {
  Buffer<BvhNode> nodes;
  Aabb bounds;
  uint32_t leaf_count = 0;
  uint32_t root = 0;
  // Internal nodes plus leaves: 2n - 1 for n >= 1.
  size_t node_count() const { return leaf_count == 0 ? 0 : 2 * size_t(leaf_count) - 1; }
};

}  // namespace caustica
