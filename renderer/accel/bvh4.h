// A 4-wide BVH collapsed from the binary LBVH: each node holds its four children's boxes in
// structure-of-arrays form, so one node fetch feeds four box tests that the compiler turns into
// SIMD on the CPU. Collapsing halves the depth and the dependent loads along a ray, which is what
// bounds traversal (the binary tree spent ~30 ns per node visit on the dragon, nearly all in
// waiting for the node). The greedy choice of which children to open follows Wald et al.,
// "Getting Rid of Packets" (2008): open the child of largest surface area until four remain.
//
// Leaves hold up to kMaxLeafTriangles consecutive triangles of the sorted order instead of one.
// With one triangle per leaf, the bottom levels are nodes whose boxes cost as much to fetch and
// test as the triangles they guard, and the nodes took 52 of the 92 bytes per triangle on the
// dragon. Stopping the collapse at small subtrees removes most of those nodes (and one node
// level from a ray's path); in a radix tree every subtree is a contiguous range of sorted
// triangles, so a leaf is just (first, count) packed into the child field and needs no index
// list.
#pragma once

#include <cstdint>
#include <vector>

#include "renderer/accel/bvh.h"
#include "renderer/base/morton.h"

namespace caustica {

constexpr uint32_t kEmptyChild = 0xffffffffu;

// A binary subtree over at most this many triangles becomes one leaf. Four is the smallest limit
// that takes the dragon's structure under 64 bytes per triangle (three gives 64.3); on the CPU,
// rays measured the same with two, three and four (docs/performance.md): the node level saved
// pays for the extra triangle tests.
constexpr uint32_t kMaxLeafTriangles = 4;

// Whether a binary subtree of `size` triangles in `box` (within the scene's `bounds`) becomes one
// leaf child whatever its inner splits: at most kMaxLeafTriangles, none of them huge by the measure
// that sorts huge triangles apart (size_class, base/morton.h). A subtree of huge triangles also
// becomes one leaf when its box is no larger than one of its halves' (bvh4.cc), which depends on
// how it splits.
CAUSTICA_HDI bool always_one_leaf(uint32_t size, const Aabb& box, const Aabb& bounds) {
  return size <= kMaxLeafTriangles && size_class(box, bounds) == 1u;
}

// A single triangle is a leaf; so is a subtree of up to kMaxLeafTriangles whose box is not huge
// by the measure that sorts huge triangles apart (size_class, base/morton.h), or whose box is no
// larger than one of its two halves' (the two triangles of a wall). Grouped by the curve alone,
// a leaf of huge triangles spanned two or three walls, the whole room, and every ray in the room
// entered it and tested its triangles (cornell-caustics: 7 of a shadow ray's 7.1 triangle tests
// were walls). `child` is the subtree's binary child field, `nodes` the binary tree's.
CAUSTICA_HDI bool binary_subtree_becomes_leaf(const BvhNode* nodes, uint32_t child, uint32_t size,
                                              const Aabb& box, const Aabb& bounds) {
  if (size == 1) return true;
  if (size > kMaxLeafTriangles) return false;
  if (always_one_leaf(size, box, bounds)) return true;
  const BvhNode& n = nodes[child];
  const float half = box.half_area();
  return half <= n.child[0].bounds().half_area() || half <= n.child[1].bounds().half_area();
}

// A leaf child is kLeafFlag | (count - 1) << kLeafCountShift | first: the range of sorted
// triangles [first, first + count). The first index takes the low 28 bits, which caps the
// triangles one structure can hold (scene_limits.h keeps scenes under it).
constexpr int kLeafCountShift = 28;
constexpr uint32_t kLeafFirstMask = (1u << kLeafCountShift) - 1;
constexpr uint32_t kMaxBvh4Triangles = 1u << kLeafCountShift;
static_assert(kMaxLeafTriangles - 1 <= (~kLeafFlag >> kLeafCountShift),
              "the leaf triangle count must fit between the flag and the first index");

CAUSTICA_HDI uint32_t make_leaf_child(uint32_t first, uint32_t count) {
  return kLeafFlag | (count - 1) << kLeafCountShift | first;
}
// For a child with is_leaf(child) (bvh.h) that is not kEmptyChild.
CAUSTICA_HDI uint32_t leaf_first(uint32_t child) { return child & kLeafFirstMask; }
CAUSTICA_HDI uint32_t leaf_count(uint32_t child) {
  return ((child & ~kLeafFlag) >> kLeafCountShift) + 1;
}

// 16-byte aligned (112 bytes either way) so that each row of four is one vector load on a GPU.
struct alignas(16) Bvh4Node {
  float lower_x[4], upper_x[4], lower_y[4], upper_y[4], lower_z[4], upper_z[4];
  uint32_t child[4];  // Bvh4 node index, a leaf (make_leaf_child), or kEmptyChild

  CAUSTICA_HDI Aabb child_bounds(int i) const {
    return {Vec3f(lower_x[i], lower_y[i], lower_z[i]), Vec3f(upper_x[i], upper_y[i], upper_z[i])};
  }
  CAUSTICA_HDI void set_child_bounds(int i, const Aabb& box) {
    lower_x[i] = box.lower.x;
    lower_y[i] = box.lower.y;
    lower_z[i] = box.lower.z;
    upper_x[i] = box.upper.x;
    upper_y[i] = box.upper.y;
    upper_z[i] = box.upper.z;
  }
};

struct Bvh4 {
  Buffer<Bvh4Node> nodes;  // node 0 is the root (when there are >= 2 triangles)
  Aabb bounds;
  uint32_t triangle_count = 0;
  // Nodes are laid out level by level from the root, a node's children after it: level i is
  // nodes [level_starts[i], level_starts[i + 1]), the last entry being the node count. A refit
  // (triangle_bvh.h) recomputes the boxes a level at a time from the deepest.
  std::vector<uint32_t> level_starts;
};

// Collapses `binary` (a radix tree: internal node k splits its range between sorted leaves k and
// k + 1) into a 4-wide tree over the same sorted leaves, level by level from the root (two passes
// and a scan per level, so it runs on any backend). The root is always a node; below it, every
// binary subtree of at most kMaxLeafTriangles leaves becomes one leaf child, unless its box is
// huge and larger than either half's (a room's walls: each keeps a leaf of its own, bvh4.cc). At
// most kMaxBvh4Triangles leaves.
Bvh4 collapse_to_bvh4(Backend& backend, const Bvh& binary);

}  // namespace caustica
