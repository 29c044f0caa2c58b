// Morton (Z-order) codes: 10 bits per axis in 30 bits, the key the LBVH builders sort by
// (Karras 2012; Zeidan 2011 sec. 4.2).
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

// Code of point `p` quantised on a 1024^3 grid over `bounds`; points outside are clamped.
CAUSTICA_HDI uint32_t morton_code(Vec3f p, const Aabb& bounds) {
  Vec3f e = bounds.extent();
  Vec3f scale(e.x > 0 ? 1024.0f / e.x : 0.0f, e.y > 0 ? 1024.0f / e.y : 0.0f,
              e.z > 0 ? 1024.0f / e.z : 0.0f);
  Vec3f q = (p - bounds.lower) * scale;
  auto cell = [](float f) -> uint32_t { return f <= 0.0f ? 0u : (f >= 1023.0f ? 1023u : uint32_t(f)); };
  return morton3_30(cell(q.x), cell(q.y), cell(q.z));
}

}  // namespace caustica
