// Compact 32-byte nodes of a binary BVH after Fabianowski (2011, ch. 6): a node holds its two
// children's boxes as only the planes that a child does not inherit from the node's own box.
// The node's box is the union of its children's, so for each of its six planes at least one child
// touches it (holds that very value); the node records per plane which child inherits it and the
// other child's value there. Six floats, six bits and two child references fit in 32 bytes, where
// the two boxes in full (BvhNode, bvh.h) take 64; a traversal that knows the node's box rebuilds
// both children's, bit for bit, with one select per plane.
//
// The layout serves two trees: the triangle structure `sibling-pair` (sibling_pair_bvh.h), whose
// leaves are runs of sorted triangles, and the photon map's hierarchy (photon/photon_map.h,
// PhotonMapNodes::kSiblingPairs), whose leaves are runs of photons.
#pragma once

#include <cstdint>
#include <cstring>

#include "renderer/accel/bvh.h"
#include "renderer/base/aabb.h"

namespace caustica {

// A child word: kLeafFlag (bit 31), three inheritance bits (bits 28..30: the lower planes x, y, z
// in child[0]'s word, the upper planes in child[1]'s), and a 28-bit reference below them: an
// internal node's index, or what a leaf is to its tree (a photon leaf's index; a run of triangles,
// sibling_pair_bvh.h).
constexpr int kSiblingInheritShift = 28;
constexpr uint32_t kSiblingReferenceMask = (1u << kSiblingInheritShift) - 1;
// The most nodes or leaves one tree of these nodes can address.
constexpr uint32_t kMaxSiblingReferences = 1u << kSiblingInheritShift;

struct alignas(32) SiblingPairNode {
  // Lower x, y, z, then upper x, y, z: at plane p, the value of the child that does not inherit
  // the node's plane p (the node's own value when both children touch it).
  float plane[6];
  uint32_t child[2];
};
static_assert(sizeof(SiblingPairNode) == 32, "a sibling-pair node is 32 bytes");

// The child's reference in bvh.h's convention: kLeafFlag | leaf, or an internal node's index.
CAUSTICA_HDI uint32_t sibling_reference(uint32_t word) {
  return word & (kLeafFlag | kSiblingReferenceMask);
}

// Bit p set: child 1 inherits plane p of the node, so child 0 takes plane[p].
CAUSTICA_HDI uint32_t sibling_inherit_bits(const SiblingPairNode& n) {
  return (n.child[0] >> kSiblingInheritShift & 7u) | (n.child[1] >> kSiblingInheritShift & 7u) << 3;
}

// The two children's boxes of node `n`, whose own box is `box`: bit for bit the boxes it was
// encoded from.
CAUSTICA_HDI void sibling_child_boxes(const SiblingPairNode& n, const Aabb& box, Aabb& box0,
                                      Aabb& box1) {
  const uint32_t bits = sibling_inherit_bits(n);
  // Selects with indices known at compile time: a run-time index would put the box in local
  // memory on a GPU.
  auto plane = [&](int p, float inherited, float& c0, float& c1) {
    const bool second_inherits = (bits >> p) & 1u;
    c0 = second_inherits ? n.plane[p] : inherited;
    c1 = second_inherits ? inherited : n.plane[p];
  };
  plane(0, box.lower.x, box0.lower.x, box1.lower.x);
  plane(1, box.lower.y, box0.lower.y, box1.lower.y);
  plane(2, box.lower.z, box0.lower.z, box1.lower.z);
  plane(3, box.upper.x, box0.upper.x, box1.upper.x);
  plane(4, box.upper.y, box0.upper.y, box1.upper.y);
  plane(5, box.upper.z, box0.upper.z, box1.upper.z);
}

// The box a node of children `box0` and `box1` decodes them from: their union. Minima and maxima
// return one of their operands, so every plane of it is some child's, bit for bit.
CAUSTICA_HDI Aabb sibling_pair_box(const Aabb& box0, const Aabb& box1) { return merge(box0, box1); }

// The node whose children have boxes `box0` and `box1` and references `ref0` and `ref1` (below
// kMaxSiblingReferences, with kLeafFlag for a leaf). False when a plane of their union is neither
// child's, bit for bit, which sibling_pair_box rules out for finite boxes.
CAUSTICA_HDI bool encode_sibling_pair(const Aabb& box0, uint32_t ref0, const Aabb& box1,
                                      uint32_t ref1, SiblingPairNode& out) {
  const Aabb box = sibling_pair_box(box0, box1);
  const float own[6] = {box.lower.x, box.lower.y, box.lower.z,
                        box.upper.x, box.upper.y, box.upper.z};
  const float first[6] = {box0.lower.x, box0.lower.y, box0.lower.z,
                          box0.upper.x, box0.upper.y, box0.upper.z};
  const float second[6] = {box1.lower.x, box1.lower.y, box1.lower.z,
                           box1.upper.x, box1.upper.y, box1.upper.z};
  auto same_bits = [](float a, float b) {
    uint32_t x, y;
    memcpy(&x, &a, 4);
    memcpy(&y, &b, 4);
    return x == y;
  };
  uint32_t bits = 0;
  bool ok = true;
  for (int p = 0; p < 6; ++p) {
    if (same_bits(first[p], own[p])) {
      out.plane[p] = second[p];  // child 0 inherits
    } else {
      ok = ok && same_bits(second[p], own[p]);
      out.plane[p] = first[p];
      bits |= 1u << p;
    }
  }
  out.child[0] = ref0 | (bits & 7u) << kSiblingInheritShift;
  out.child[1] = ref1 | (bits >> 3) << kSiblingInheritShift;
  return ok;
}

// A radix tree of BvhNodes (bvh.h) in sibling-pair nodes, node k for node k, its children's
// references unchanged: what the photon map stores. `root_box` receives the box the root decodes
// from (sibling_pair_box of the root's children; the tree's bounds when it has no node). Throws
// std::invalid_argument past kMaxSiblingReferences leaves.
Buffer<SiblingPairNode> encode_sibling_pairs(Backend& backend, const Bvh& tree, Aabb& root_box);

}  // namespace caustica
