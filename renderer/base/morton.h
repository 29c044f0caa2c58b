// Morton (Z-order) codes: 10 bits per axis in 30 bits, the key the LBVH builders sort by
// (Karras 2012; Zeidan 2011 sec. 4.2); and Hilbert codes on the same grid, for orders whose runs
// should stay compact.
#pragma once

#include <cstdint>

#include "renderer/base/aabb.h"

namespace caustica {

// Spreads the low 10 bits of v so that bit i lands at bit 3i.
CAUSTICA_HDI uint32_t expand_bits_10(uint32_t v) {
  v &= 0x3ffu;
  v = (v * 0x00010001u) & 0xFF0000FFu;
  v = (v * 0x00000101u) & 0x0F00F00Fu;
  v = (v * 0x00000011u) & 0xC30C30C3u;
  v = (v * 0x00000005u) & 0x49249249u;
  return v;
}

// Inverse of expand_bits_10, for tests and debugging.
CAUSTICA_HDI uint32_t compact_bits_10(uint32_t v) {
  v &= 0x49249249u;
  v = (v ^ (v >> 2)) & 0xC30C30C3u;
  v = (v ^ (v >> 4)) & 0x0F00F00Fu;
  v = (v ^ (v >> 8)) & 0xFF0000FFu;
  v = (v ^ (v >> 16)) & 0x000003FFu;
  return v;
}

// Interleaves x, y, z (each < 1024) as ...z1y1x1 z0y0x0 with x in the lowest bit of each triple.
CAUSTICA_HDI uint32_t morton3_30(uint32_t x, uint32_t y, uint32_t z) {
  return expand_bits_10(x) | (expand_bits_10(y) << 1) | (expand_bits_10(z) << 2);
}

// Index of cell (x, y, z) (each < 1024) along a 3D Hilbert curve, after Skilling, "Programming
// the Hilbert curve" (AIP Conf. Proc. 707, 2004): the coordinates are turned into the curve's
// "transposed" index, whose bits then interleave like a Morton code's. Unlike Z-order, cells
// consecutive on the curve always share a face, so a run of consecutive codes never jumps across
// the grid.
CAUSTICA_HDI uint32_t hilbert3_30(uint32_t x, uint32_t y, uint32_t z) {
  // Masks instead of branches: the branches on coordinate bits mispredicted on the CPU, where
  // they made the dragon's LBVH build 1.6x slower.
  auto all_if = [](uint32_t v, uint32_t q) { return 0u - uint32_t((v & q) != 0); };
  for (uint32_t q = 512; q > 1; q >>= 1) {
    const uint32_t low = q - 1;
    x ^= low & all_if(x, q);
    // For y and z: invert x's low bits where the coordinate's bit q is set, else swap them.
    const uint32_t y_set = all_if(y, q);
    x ^= low & y_set;
    const uint32_t ty = (x ^ y) & low & ~y_set;
    x ^= ty;
    y ^= ty;
    const uint32_t z_set = all_if(z, q);
    x ^= low & z_set;
    const uint32_t tz = (x ^ z) & low & ~z_set;
    x ^= tz;
    z ^= tz;
  }
  y ^= x;  // Gray encoding
  z ^= y;
  uint32_t flip = 0;
  for (uint32_t q = 512; q > 1; q >>= 1) flip ^= (q - 1) & all_if(z, q);
  return morton3_30(z ^ flip, y ^ flip, x ^ flip);  // x's bit leads each triple
}

// The cell of point `p` on a 1024^3 grid over `bounds`; points outside are clamped.
struct GridCell {
  uint32_t x, y, z;
};
CAUSTICA_HDI GridCell grid_cell(Vec3f p, const Aabb& bounds) {
  Vec3f e = bounds.extent();
  Vec3f scale(e.x > 0 ? 1024.0f / e.x : 0.0f, e.y > 0 ? 1024.0f / e.y : 0.0f,
              e.z > 0 ? 1024.0f / e.z : 0.0f);
  Vec3f q = (p - bounds.lower) * scale;
  auto cell = [](float f) -> uint32_t {
    return f <= 0.0f ? 0u : (f >= 1023.0f ? 1023u : uint32_t(f));
  };
  return {cell(q.x), cell(q.y), cell(q.z)};
}

// Morton code of point `p` on that grid.
CAUSTICA_HDI uint32_t morton_code(Vec3f p, const Aabb& bounds) {
  const GridCell c = grid_cell(p, bounds);
  return morton3_30(c.x, c.y, c.z);
}

// Hilbert code of point `p` on that grid.
CAUSTICA_HDI uint32_t hilbert_code(Vec3f p, const Aabb& bounds) {
  const GridCell c = grid_cell(p, bounds);
  return hilbert3_30(c.x, c.y, c.z);
}

// A bit that sorts a box before the Morton code of its centre: 0 for boxes whose diagonal is over
// a quarter of the scene's, 1 for the rest (after Vinkler, Bittner and Havran, "Extended Morton
// Codes", HPG 2017, who add several size bits). A radix tree over such codes puts the few huge
// primitives (a room's walls) in a subtree of their own at the root, where with plain codes a
// wall sorted among small triangles swells the box of every node above it and every ray that
// crosses the room enters them. Finer size classes were measured and rejected: they split a
// scanned mesh's neighbouring small and medium triangles into overlapping subtrees, which slowed
// the dragon's rays (docs/performance.md).
CAUSTICA_HDI uint32_t size_class(const Aabb& box, const Aabb& bounds) {
  float ratio_squared = length_squared(box.extent()) / length_squared(bounds.extent());
  return ratio_squared <= 1.0f / 16.0f ? 1u : 0u;  // NaN (a zero-size scene) counts as huge
}

// The sort key of an LBVH leaf: size class in bit 30, the curve's code of the centre below.
CAUSTICA_HDI uint32_t extended_morton_code(const Aabb& box, const Aabb& bounds) {
  return (size_class(box, bounds) << 30) | morton_code(box.center(), bounds);
}
CAUSTICA_HDI uint32_t extended_hilbert_code(const Aabb& box, const Aabb& bounds) {
  return (size_class(box, bounds) << 30) | hilbert_code(box.center(), bounds);
}

}  // namespace caustica
