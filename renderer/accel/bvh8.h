// The compressed 8-wide BVH of Ylitie, Karras and Laine, "Efficient Incoherent Ray Traversal on
// GPUs Through Compressed Wide BVHs" (HPG 2017), built from the H-PLOC tree (hploc.h).
//
// A node is 80 bytes: its box's lower corner p and one power-of-two scale per axis, and for each
// of eight child slots its box quantised to 8 bits per plane on that grid, rounded outwards so
// the quantised box holds the child's. A slot's meta byte says what it holds:
// - an internal child: 0b001'11'sss with sss its slot; internal children lie at consecutive node
//   indices from child_base, in slot order (their rank among the slots set in imask);
// - a leaf of 1 to kBvh8LeafTriangles triangles: a unary count in the top three bits and the
//   offset of its first triangle from triangle_base in the low five;
// - nothing: 0, with a box that no ray enters.
// Children take the slots by the direction they lie in from the node's centre, so that a ray
// visiting slots in the order its direction's octant gives meets near children first.
#pragma once

#include <cstdint>
#include <cstring>

#include "renderer/accel/hploc.h"
#include "renderer/accel/triangle.h"
#include "renderer/base/bits.h"
#include "renderer/parallel/buffer.h"

namespace caustica {

constexpr int kBvh8Width = 8;
// Triangles in one leaf, at most: the meta byte's unary count has three bits.
constexpr uint32_t kBvh8LeafTriangles = 3;
// Triangles one node of nothing but leaves can hold.
constexpr uint32_t kBvh8NodeTriangles = 8 * kBvh8LeafTriangles;
// Groups a traversal may hold on its stack; the builder refuses trees deeper than half of it
// (each level pushes one node group at most, and a postponed triangle group).
constexpr int kBvh8StackSize = 64;

struct alignas(16) Bvh8Node {
  float p[3];              // the grid's origin: the node box's lower corner
  uint8_t exponent[3];     // per axis, the grid's step 2^(exponent - 127), a float's exponent bits
  uint8_t imask;           // bit s: slot s holds an internal child
  uint32_t child_base;     // node index of the first internal child
  uint32_t triangle_base;  // index of the first leaf triangle
  uint8_t meta[8];
  uint8_t lower_x[8], lower_y[8], lower_z[8];
  uint8_t upper_x[8], upper_y[8], upper_z[8];
};
static_assert(sizeof(Bvh8Node) == 80, "five 16-byte loads");

CAUSTICA_HDI bool bvh8_slot_is_internal(uint8_t meta) { return (meta & 0xf8u) == 0x38u; }
// Triangles in the leaf a slot holds (0 for an internal child or nothing).
CAUSTICA_HDI uint32_t bvh8_leaf_triangles(uint8_t meta) {
  return bvh8_slot_is_internal(meta) ? 0u : popcount32(meta >> 5u);
}

// Plain pointers into a Bvh8, copied by value into kernels.
struct Bvh8View {
  const Bvh8Node* nodes = nullptr;              // node 0 is the root
  const TriangleVertices* triangles = nullptr;  // in leaf order
  const uint32_t* triangle_ids = nullptr;       // leaf order -> original triangle index
  uint32_t count = 0;
  Aabb bounds;
  // The largest |coordinate| of any plane the nodes' grids can place, for the box tests' bound on
  // rounding (bvh8_traversal.h).
  float reach = 0.0f;
};

struct Bvh8 {
  Buffer<Bvh8Node> nodes;
  Buffer<TriangleVertices> triangles;
  Buffer<uint32_t> triangle_ids;
  Aabb bounds;
  uint32_t count = 0;
  uint32_t depth = 0;  // node levels

  Bvh8View view() const;
  size_t node_count() const { return nodes.size(); }
  size_t bytes() const { return nodes.bytes() + triangles.bytes() + triangle_ids.bytes(); }
};

// The 8-wide tree over `count` triangles in the backend's memory: H-PLOC along `curve`, then
// collapsed and compressed level by level from the root.
Bvh8 build_bvh8(Backend& backend, const TriangleVertices* triangles, uint32_t count, Curve curve);

// `binary` collapsed to 8-wide compressed nodes, taking over its triangles' order.
Bvh8 collapse_to_bvh8(Backend& backend, const ClusteredTriangleBvh& binary);

// The SAH cost (StructureStats::sah_cost) of the tree, over the quantised boxes that traversal
// tests.
double sah_cost(Backend& backend, const Bvh8& bvh);

// A grid's step from its exponent bits: 2^(exponent - 127).
CAUSTICA_HDI float bvh8_grid_step(uint8_t exponent) {
  const uint32_t bits = uint32_t(exponent) << 23;
  float step;
  memcpy(&step, &bits, sizeof step);
  return step;
}

// Slot s's quantised box (what traversal tests), in world space.
CAUSTICA_HDI Aabb bvh8_child_box(const Bvh8Node& n, int s) {
  Aabb b;
  const uint8_t* lower[3] = {n.lower_x, n.lower_y, n.lower_z};
  const uint8_t* upper[3] = {n.upper_x, n.upper_y, n.upper_z};
  for (int a = 0; a < 3; ++a) {
    const float step = bvh8_grid_step(n.exponent[a]);
    b.lower[a] = n.p[a] + float(lower[a][s]) * step;
    b.upper[a] = n.p[a] + float(upper[a][s]) * step;
  }
  return b;
}

}  // namespace caustica
