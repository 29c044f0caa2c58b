// Unit vectors in 32 bits by the octahedral map (Cigolle et al., "A Survey of Efficient
// Representations for Independent Unit Vectors", JCGT 2014): the sphere is projected onto the
// octahedron |x| + |y| + |z| = 1 and unfolded onto a square quantised to 16 bits per axis, which
// keeps the angular error below 1e-4 radians. Photons store their incoming direction this way,
// since the only use of it is the side test at the gather.
#pragma once

#include <cstdint>

#include "renderer/base/vec.h"

namespace caustica {

namespace detail {

CAUSTICA_HDI float sign_not_zero(float v) { return v >= 0.0f ? 1.0f : -1.0f; }

CAUSTICA_HDI uint32_t quantise_snorm16(float v) {
  float clamped = min_f(1.0f, max_f(-1.0f, v));
  return uint32_t(int32_t(rintf((clamped * 0.5f + 0.5f) * 65535.0f)));
}

// Never exactly 0 (q * 2 / 65535 is 1 for no integer q), so its sign is sign_not_zero's.
CAUSTICA_HDI float dequantise_snorm16(uint32_t q) { return fmaf(float(q), 2.0f / 65535.0f, -1.0f); }

}  // namespace detail

CAUSTICA_HDI uint32_t encode_octahedral(Vec3f v) {
  float inv_l1 = 1.0f / (fabsf(v.x) + fabsf(v.y) + fabsf(v.z));
  float x = v.x * inv_l1, y = v.y * inv_l1;
  if (v.z < 0.0f) {  // fold the lower half over the diagonals
    float fx = (1.0f - fabsf(y)) * detail::sign_not_zero(x);
    float fy = (1.0f - fabsf(x)) * detail::sign_not_zero(y);
    x = fx;
    y = fy;
  }
  return detail::quantise_snorm16(x) | (detail::quantise_snorm16(y) << 16);
}

// The point of the octahedron |x| + |y| + |z| = 1 that `bits` encodes: the direction, not yet
// of unit length.
// The lower half is unfolded by selects, and each sign is copied rather than multiplied in, where
// a branch and two products by sign_not_zero cost a fifth more instructions: every photon the
// gather sums takes this side test.
CAUSTICA_HDI Vec3f decode_octahedral_unnormalised(uint32_t bits) {
  const float x = detail::dequantise_snorm16(bits & 0xffffu);
  const float y = detail::dequantise_snorm16(bits >> 16);
  const float z = 1.0f - fabsf(x) - fabsf(y);
  const bool folded = z < 0.0f;
  return Vec3f(folded ? copysignf(1.0f - fabsf(y), x) : x,
               folded ? copysignf(1.0f - fabsf(x), y) : y, z);
}

CAUSTICA_HDI Vec3f decode_octahedral(uint32_t bits) {
  return normalize(decode_octahedral_unnormalised(bits));
}

// Whether the direction `bits` encodes points along `n` (a positive dot product): the side test
// without normalising, a square root and a division that cannot change the sign. On a GPU the
// normalisation took about 30 instructions per photon of every estimate.
CAUSTICA_HDI bool octahedral_along(uint32_t bits, Vec3f n) {
  return dot(decode_octahedral_unnormalised(bits), n) > 0.0f;
}

}  // namespace caustica
