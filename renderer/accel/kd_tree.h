// A kd-tree over triangles (structures kd-sah and kd-siroh): 8-byte nodes, each an axis-aligned
// split plane or a leaf holding a range of an array of triangle references. Built breadth-first
// on any backend in the manner of Zhou et al. 2008 (kd_tree_build.cc), traversed with a stack or
// stacklessly (kd_traversal.h). docs/structures.md, "kd-sah and kd-siroh", says why the
// parameters below are what they are.
#pragma once

#include <cstdint>
#include <cstring>

#include "renderer/accel/build_options.h"
#include "renderer/accel/triangle.h"
#include "renderer/parallel/buffer.h"

namespace caustica {

// An inner node: `split` and, in `bits`, the axis (0..2) in the low two bits and the index of
// the first of its two adjacent children (below the plane, then above) above them. A leaf: axis
// bits 3, its reference count above them, and the index of its first reference in the place of
// the split.
struct KdNode {
  float split;
  uint32_t bits;

  CAUSTICA_HDI bool leaf() const { return (bits & 3u) == 3u; }
  CAUSTICA_HDI int axis() const { return int(bits & 3u); }
  CAUSTICA_HDI uint32_t first_child() const { return bits >> 2; }
  CAUSTICA_HDI uint32_t ref_count() const { return bits >> 2; }
  CAUSTICA_HDI uint32_t first_ref() const {
    uint32_t first;
    memcpy(&first, &split, sizeof(first));
    return first;
  }

  CAUSTICA_HDI static KdNode inner(int axis, float split, uint32_t first_child) {
    return {split, uint32_t(axis) | first_child << 2};
  }
  CAUSTICA_HDI static KdNode leaf_of(uint32_t first_ref, uint32_t count) {
    KdNode n;
    memcpy(&n.split, &first_ref, sizeof(first_ref));
    n.bits = 3u | count << 2;
    return n;
  }
};
static_assert(sizeof(KdNode) == 8, "8-byte kd nodes");

// The deepest a leaf may lie (the root at depth 0). The stackless traversal keeps one bit per
// level of inner nodes in a 32-bit register, and its leaf-visit step adds the bit of the leaf's
// parent, one level above the leaf's own, which must exist: so leaves stop at depth 31, for both
// cost functions and both traversals, which then walk the same tree.
constexpr int kKdMaxLeafDepth = 31;

// Nodes of more references than this are split by Zhou's large-node rules (spatial median or
// an empty-space cut); smaller ones by the exact SAH sweep.
constexpr uint32_t kKdLargeNode = 64;

// Which cost the small-node sweep minimises.
enum class KdCost : uint32_t {
  kSah,    // surface area heuristic: ray origins outside the scene box
  kSiroh,  // Fabianowski's scene-interior ray origin heuristic: origins inside it
};

// The device view of a kd-tree, one type per traversal so that kernels are instantiated for each
// and a launch never branches per ray on the choice. `refs` hold the indices of the triangles in
// the builder's input order, which `triangles` keep.
template <KdTraversal kTraversal>
struct KdTreeView {
  const KdNode* nodes = nullptr;
  const uint32_t* refs = nullptr;
  const TriangleVertices* triangles = nullptr;
  uint32_t node_count = 0;
  Aabb bounds;
};
using KdTreeStackView = KdTreeView<KdTraversal::kStack>;
using KdTreeStacklessView = KdTreeView<KdTraversal::kStackless>;

struct KdTree {
  Buffer<KdNode> nodes;
  Buffer<uint32_t> refs;
  Buffer<TriangleVertices> triangles;
  // Per node, the half area of its cell: what the SAH cost weighs nodes by; not read by traversal.
  Buffer<float> cell_half_areas;
  Aabb bounds;
  uint32_t triangle_count = 0;
  int depth = 0;  // of the deepest leaf
  KdTraversal traversal = KdTraversal::kStack;

  template <KdTraversal kTraversal>
  KdTreeView<kTraversal> view_for() const {
    return {nodes.data(), refs.data(), triangles.data(), uint32_t(nodes.size()), bounds};
  }
  size_t node_count() const { return nodes.size(); }
  size_t bytes() const { return nodes.bytes() + refs.bytes() + triangles.bytes(); }
};

// The kd-tree over `count` triangles in the backend's memory, its small nodes split by `cost`.
KdTree build_kd_tree(Backend& backend, const TriangleVertices* triangles, uint32_t count,
                     KdCost cost);

// The SAH cost with C_T = C_I = 1 (StructureStats::sah_cost): the sum over inner nodes of their
// cells' areas plus the sum over leaves of references x area, over the root's area; on the
// backend.
double sah_cost(Backend& backend, const KdTree& tree);

}  // namespace caustica
