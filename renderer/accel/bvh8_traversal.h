// Closest and any hit through the compressed 8-wide BVH (bvh8.h), after Ylitie et al. 2017: the
// stack holds groups, a node's base index with a bit mask of the children still to visit, so one
// entry stands for up to eight subtrees or 24 triangles, and the children a node visit hit leave
// it as two groups, one of nodes and one of triangles. Internal children's bits are placed by
// the ray's octant, so taking the highest bit first visits them in the order the builder's slot
// assignment meant for that direction.
#pragma once

#include <cfloat>
#include <cmath>

#include "renderer/accel/bvh8.h"
#include "renderer/accel/triangle.h"
#include "renderer/base/bits.h"

namespace caustica {
namespace detail {

// A ray made ready for the quantised slab tests: as ray_slabs.h, the distance to a plane
// p + q 2^e is q (2^e / d) + (p - o) / d, with the offset lowered for the planes a ray enters by
// and raised for those it leaves by, by a bound on the rounding, so that no box the ray touches
// is missed.
struct Bvh8Ray {
  Vec3f inv;             // 1 / d (safe_reciprocal); 0 on an axis it cannot cull on
  Vec3f enter_offset;    // -o / d, lowered by the bound
  Vec3f leave_offset;    // -o / d, raised by it
  bool negative[3];      // enters axis a by its upper plane
  uint32_t octant_flip;  // 7 - the direction's octant: slot s's bit is 24 + (s ^ octant_flip)
};

CAUSTICA_HDI Bvh8Ray bvh8_ray(const Ray& ray, float reach) {
  Bvh8Ray r;
  const Vec3f inv = safe_reciprocal(ray.direction);
  uint32_t octant = 0;
  for (int a = 0; a < 3; ++a) {
    const float scaled = ray.origin[a] * inv[a];
    // Rounding of -o / d, of the node's offset p / d - o / d, and of each plane's multiply-add:
    // each at most 2^-24 of |o / d| plus the plane's distance term, at most reach |1 / d|.
    const float error = fabsf(scaled) * 0x1p-21f + reach * fabsf(inv[a]) * 0x1p-22f;
    if (fabsf(scaled) <= FLT_MAX * 0.5f && error <= FLT_MAX * 0.25f) {
      r.inv[a] = inv[a];
      r.enter_offset[a] = -scaled - error;
      r.leave_offset[a] = -scaled + error;
    } else {
      r.inv[a] = 0.0f;
      r.enter_offset[a] = -INFINITY;
      r.leave_offset[a] = INFINITY;
    }
    r.negative[a] = inv[a] < 0.0f;
    octant |= r.negative[a] ? 1u << a : 0u;
  }
  r.octant_flip = 7u - octant;
  return r;
}

// A group: `base` and the bits of what is left in it. Node groups keep children bits in 24..31
// and the node's imask in 0..7; triangle groups keep triangle bits in 0..23.
struct Bvh8Group {
  uint32_t base;
  uint32_t bits;
};

// Four bytes of a node's row as one word: the compiler keeps the node in registers and takes the
// bytes out with shifts (selecting between byte arrays would put the node in local memory).
CAUSTICA_HDI uint32_t bvh8_row_word(const uint8_t* row, int half) {
  uint32_t w;
  memcpy(&w, row + 4 * half, sizeof w);
  return w;
}

// Byte j of `word` as a float. On a GPU not by a conversion instruction, which issues at an
// eighth of the rate of arithmetic and took six per child: the byte goes into the low mantissa
// bits of 2^23 (one byte permute), and 2^23 comes off again (one exact subtraction).
CAUSTICA_HDI float bvh8_byte(uint32_t word, int j) {
#if defined(__CUDA_ARCH__)
  return __uint_as_float(__byte_perm(word, 0x4b000000u, 0x7540u + uint32_t(j))) - 8388608.0f;
#else
  return float((word >> (8 * j)) & 0xffu);
#endif
}

// The entry and exit distances of a box from its per-axis ones, clipped to [t_min, t_max]; as
// slab_entry (ray_slabs.h), Hopper's three-way integer min and max on the bits, which order the
// distances that decide as floats do when t_min >= 0.
CAUSTICA_HDI bool bvh8_box_entered(float tx0, float ty0, float tz0, float tx1, float ty1, float tz1,
                                   float t_min, float t_max) {
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  const int t_near =
      __vimax3_s32(__float_as_int(tx0), __float_as_int(ty0), __float_as_int(fmaxf(tz0, t_min)));
  const int t_far =
      __vimin3_s32(__float_as_int(tx1), __float_as_int(ty1), __float_as_int(fminf(tz1, t_max)));
  return t_near <= t_far;
#else
  return fmaxf(fmaxf(tx0, ty0), fmaxf(tz0, t_min)) <= fminf(fminf(tx1, ty1), fminf(tz1, t_max));
#endif
}

// Tests the eight slots of `node` (in [t_min, t_max]) and returns the hit mask: internal
// children's bits at 24 + (slot ^ octant_flip), leaves' triangles at their offsets.
CAUSTICA_HDI uint32_t bvh8_intersect_node(const Bvh8Node& node, const Bvh8Ray& r, float t_min,
                                          float t_max) {
  float scale[3], enter[3], leave[3];
  for (int a = 0; a < 3; ++a) {
    scale[a] = bvh8_grid_step(node.exponent[a]) * r.inv[a];
    enter[a] = fmaf(node.p[a], r.inv[a], r.enter_offset[a]);
    leave[a] = fmaf(node.p[a], r.inv[a], r.leave_offset[a]);
  }
  uint32_t hits = 0;
  for (int half = 0; half < 2; ++half) {
    const uint32_t lx = bvh8_row_word(node.lower_x, half), ux = bvh8_row_word(node.upper_x, half);
    const uint32_t ly = bvh8_row_word(node.lower_y, half), uy = bvh8_row_word(node.upper_y, half);
    const uint32_t lz = bvh8_row_word(node.lower_z, half), uz = bvh8_row_word(node.upper_z, half);
    const uint32_t near_x = r.negative[0] ? ux : lx, far_x = r.negative[0] ? lx : ux;
    const uint32_t near_y = r.negative[1] ? uy : ly, far_y = r.negative[1] ? ly : uy;
    const uint32_t near_z = r.negative[2] ? uz : lz, far_z = r.negative[2] ? lz : uz;
    const uint32_t metas = bvh8_row_word(node.meta, half);
    for (int j = 0; j < 4; ++j) {
      const float tx0 = fmaf(bvh8_byte(near_x, j), scale[0], enter[0]);
      const float ty0 = fmaf(bvh8_byte(near_y, j), scale[1], enter[1]);
      const float tz0 = fmaf(bvh8_byte(near_z, j), scale[2], enter[2]);
      const float tx1 = fmaf(bvh8_byte(far_x, j), scale[0], leave[0]);
      const float ty1 = fmaf(bvh8_byte(far_y, j), scale[1], leave[1]);
      const float tz1 = fmaf(bvh8_byte(far_z, j), scale[2], leave[2]);
      const uint32_t meta = (metas >> (8 * j)) & 0xffu;
      if (bvh8_box_entered(tx0, ty0, tz0, tx1, ty1, tz1, t_min, t_max)) {
        // An internal child's meta is 0b00111sss: its bit 24 + (s ^ flip); a leaf's top three
        // bits are its triangles, at the offset in the low five; an empty slot's are 0.
        const uint32_t internal = bvh8_slot_is_internal(uint8_t(meta)) ? r.octant_flip : 0u;
        hits |= (meta >> 5) << ((meta ^ internal) & 31u);
      }
    }
  }
  return hits;
}

// Below this many lanes testing triangles together, a lane postpones its triangles.
constexpr int kBvh8PostponeLanes = 6;

// A node in five 16-byte loads through the read-only cache.
CAUSTICA_HDI Bvh8Node bvh8_load_node(const Bvh8Node* p) {
#if defined(__CUDA_ARCH__)
  Bvh8Node n;
  const uint4* from = reinterpret_cast<const uint4*>(p);
  uint4* to = reinterpret_cast<uint4*>(&n);
  for (int k = 0; k < 5; ++k) to[k] = __ldg(from + k);
  return n;
#else
  return *p;
#endif
}

// Walks `bvh` along `ray`: `test(index)` tests the triangle at leaf-order index `index`, may
// shrink t_max (a closest hit) and returns true to end the walk (an any hit).
template <typename Test>
CAUSTICA_HDI void bvh8_walk(const Bvh8View& bvh, const Ray& ray, const float& t_max, Test test) {
  if (bvh.count == 0) return;
  const Bvh8Ray r = bvh8_ray(ray, bvh.reach);
  const float t_min = ray.t_min;
  Bvh8Group stack[kBvh8StackSize];
  int top = 0;
  // The root as the one internal child, in slot 0, of a group based at node 0.
  Bvh8Group nodes{0, (1u << (24 + r.octant_flip)) | 1u};
  Bvh8Group triangles{0, 0};
  while (true) {
    if (nodes.bits & 0xff000000u) {
      const uint32_t bit = highest_bit32(nodes.bits & 0xff000000u);
      nodes.bits &= ~(1u << bit);
      const uint32_t slot = (bit - 24u) ^ r.octant_flip;
      const uint32_t index = nodes.base + popcount32(nodes.bits & ((1u << slot) - 1u) & 0xffu);
      if (nodes.bits & 0xff000000u) stack[top++] = nodes;
      const Bvh8Node node = bvh8_load_node(bvh.nodes + index);
      const uint32_t hits = bvh8_intersect_node(node, r, t_min, t_max);
      nodes = {node.child_base, (hits & 0xff000000u) | node.imask};
      triangles = {node.triangle_base, hits & 0x00ffffffu};
    } else {
      triangles = nodes;
      nodes = {0, 0};
    }
    while (triangles.bits != 0) {
#if defined(__CUDA_ARCH__)
      // Few lanes of the warp testing triangles while the rest wait: a lane with nodes still to
      // visit puts its triangles on the stack and goes on with the nodes alongside the others
      // (Ylitie et al. sec. 4). Postponed groups keep to half the stack; node groups, one per
      // level, to the rest.
      if ((nodes.bits & 0xff000000u) != 0 && top < kBvh8StackSize / 2 &&
          __popc(__activemask()) < kBvh8PostponeLanes) {
        stack[top++] = triangles;
        break;
      }
#endif
      const uint32_t bit = lowest_bit32(triangles.bits);
      triangles.bits &= triangles.bits - 1u;
      if (test(triangles.base + bit)) return;
    }
    if ((nodes.bits & 0xff000000u) == 0) {
      if (top == 0) return;
      nodes = stack[--top];
    }
  }
}

}  // namespace detail

CAUSTICA_HDI Hit closest_hit(const Bvh8View& bvh, const Ray& ray) {
  return nearest_walked_hit(
      bvh.triangles, bvh.triangle_ids, ray,
      [&](const float& t_max, auto test) { detail::bvh8_walk(bvh, ray, t_max, test); });
}

CAUSTICA_HDI bool any_hit(const Bvh8View& bvh, const Ray& ray) {
  return walked_segment_blocked(bvh.triangles, ray, [&](const float& t_max, auto test) {
    detail::bvh8_walk(bvh, ray, t_max, test);
  });
}

}  // namespace caustica
