// A ray made ready for slab tests (Kay and Kajiya 1986) against many boxes, at one fused
// multiply-add per plane: the distance (b - o) / d to plane b is b * (1 / d) + (-o / d), with
// -o / d computed once per ray. Each axis keeps two copies of -o / d, one lowered and one raised
// by a bound on the rounding of the distances: that of -o / d itself, an absolute error which a
// relative slack on the far distance could not cover (a box near an origin far from the world's
// origin would be missed), and that of each plane's multiply-add, at most 2^-24 of a distance,
// which is bounded for every plane of a box inside the structure's bounds. So distances to the
// planes a ray enters by come out no larger than exact, those to the planes it leaves by no
// smaller, and no box the ray touches is missed, with no slack at each test: one multiply per
// child a node visit less than a relative slack on the far distance. A box that the ray passes
// within about 2^-21 |o / d| + 2^-22 |bounds / d| of may count as touched, which costs a needless
// visit at most. The signs of the direction say which plane of each axis a ray enters by, so a
// node's rows are taken in that order, and no min and max per axis and child sort them out.
//
// This beat a subtraction and a product per plane with that min and max, and selecting the rows
// from a whole node's registers or loading them at offsets kept per ray, which took more
// registers (docs/performance.md, "Fewer instructions per box and triangle test"). The
// reciprocal is safe_reciprocal's (base/aabb.h). Both backends compute the same distances bit
// for bit.
#pragma once

#include <cfloat>
#include <cmath>

#include "renderer/accel/bvh4.h"
#include "renderer/base/aabb.h"

namespace caustica {

struct RaySlabs {
  Vec3f inv;                // 1 / d (safe_reciprocal); 0 on an axis it cannot cull on
  Vec3f enter_offset;       // -o / d, lowered by the bound on the distances' rounding
  Vec3f leave_offset;       // -o / d, raised by it
  uint32_t enter_upper[3];  // 16 (a row's bytes) where it enters axis a by the upper plane, else 0
};

// The slabs for boxes inside `within` (a structure's bounds): boxes outside it may be missed by
// the last bits of their distances.
CAUSTICA_HDI RaySlabs ray_slabs(Vec3f origin, Vec3f direction, const Aabb& within) {
  RaySlabs s;
  const Vec3f inv = safe_reciprocal(direction);
  for (int a = 0; a < 3; ++a) {
    const float scaled = origin[a] * inv[a];
    // The largest distance term of a plane inside `within` on this axis.
    const float reach = max_f(fabsf(within.lower[a]), fabsf(within.upper[a])) * fabsf(inv[a]);
    // |o * (1/d) - scaled| <= 2^-24 |scaled|; rounding the sum -scaled +- error adds about as
    // much, and a plane's multiply-add at most 2^-24 (|scaled| + reach) more: 2^-22 |scaled| +
    // 2^-23 reach covers the three with room to spare.
    const float error = fabsf(scaled) * 0x1p-22f + reach * 0x1p-23f;
    if (fabsf(scaled) <= FLT_MAX * 0.5f && error <= FLT_MAX * 0.25f) {
      s.inv[a] = inv[a];
      s.enter_offset[a] = -scaled - error;
      s.leave_offset[a] = -scaled + error;
    } else {
      // A coordinate so far out along a nearly parallel axis that -o / d or its error bound
      // overflows: that axis bounds no distance (every plane at -inf to enter, +inf to leave),
      // which is conservative.
      s.inv[a] = 0.0f;
      s.enter_offset[a] = -INFINITY;
      s.leave_offset[a] = INFINITY;
    }
    s.enter_upper[a] = inv[a] < 0.0f ? 16u : 0u;
  }
  return s;
}

// The entry distance of the ray into the box whose planes it enters by are at `enter_*` and
// leaves by at `leave_*` (enter_upper says which is which) within [t_min, t_max], or +infinity
// when it misses.
CAUSTICA_HDI float slab_entry(const RaySlabs& s, float enter_x, float enter_y, float enter_z,
                              float leave_x, float leave_y, float leave_z, float t_min,
                              float t_max) {
  const float tx0 = fmaf(enter_x, s.inv.x, s.enter_offset.x);
  const float ty0 = fmaf(enter_y, s.inv.y, s.enter_offset.y);
  const float tz0 = fmaf(enter_z, s.inv.z, s.enter_offset.z);
  const float tx1 = fmaf(leave_x, s.inv.x, s.leave_offset.x);
  const float ty1 = fmaf(leave_y, s.inv.y, s.leave_offset.y);
  const float tz1 = fmaf(leave_z, s.inv.z, s.leave_offset.z);
#if defined(__CUDA_ARCH__) && __CUDA_ARCH__ >= 900
  // Hopper's three-way integer min and max, one instruction each, on the distances' bits: with
  // t_min >= 0, as every ray here has, the integers order the distances that decide as floats
  // do. Where some distance is negative (a plane behind the origin) the integer max is still the
  // largest non-negative one, t_min at least, and the integer min is some negative distance,
  // which puts the box behind the ray, as the float min does. Only an exit distance of exactly
  // -0 orders differently (below every negative), which visits a box more at most; otherwise the
  // decisions are the CPU's (GpuParity.BoxEntriesAreTheCpus).
  const float t_near = __int_as_float(
      __vimax3_s32(__float_as_int(tx0), __float_as_int(ty0), __float_as_int(max_f(tz0, t_min))));
  const float t_far = __int_as_float(
      __vimin3_s32(__float_as_int(tx1), __float_as_int(ty1), __float_as_int(min_f(tz1, t_max))));
#else
  const float t_near = max_f(max_f(tx0, ty0), max_f(tz0, t_min));
  const float t_far = min_f(min_f(tx1, ty1), min_f(tz1, t_max));
#endif
  return t_near <= t_far ? t_near : INFINITY;
}

// The same for one box.
CAUSTICA_HDI float slab_entry(const RaySlabs& s, const Aabb& b, float t_min, float t_max) {
  // Selects, not a small array: indexed at run time, one would live in local memory on a GPU.
  auto plane = [&](int a, bool upper) { return upper ? b.upper[a] : b.lower[a]; };
  return slab_entry(s, plane(0, s.enter_upper[0]), plane(1, s.enter_upper[1]),
                    plane(2, s.enter_upper[2]), plane(0, !s.enter_upper[0]),
                    plane(1, !s.enter_upper[1]), plane(2, !s.enter_upper[2]), t_min, t_max);
}

// A Bvh4Node's boxes with each axis's two rows in the order a ray meets them, indexed
// enter[axis][child] and leave[axis][child]: on a GPU, copies in registers, loaded as seven
// 16-byte loads at offsets chosen per ray (picking rows out of registers would cost a select per
// value; read field by field, the compiler emitted 28 four-byte loads, a child's index behind a
// branch on whether its box was hit); on the CPU, pointers to the node's own rows, which the box
// tests read as vectors.
struct OrderedNode {
#if defined(__CUDA_ARCH__)
  float enter[3][4], leave[3][4];
  uint32_t child[4];
#else
  const float* enter[3];
  const float* leave[3];
  const uint32_t* child;
#endif
};

CAUSTICA_HDI OrderedNode load_ordered_node(const Bvh4Node* node, const RaySlabs& s) {
  static_assert(sizeof(Bvh4Node) == 7 * 4 * sizeof(float), "six rows of bounds, then children");
  OrderedNode n;
#if defined(__CUDA_ARCH__)
  const char* rows = reinterpret_cast<const char*>(node);
  auto row = [&](uint32_t byte) { return __ldg(reinterpret_cast<const float4*>(rows + byte)); };
  auto put = [](float to[4], float4 v) {
    to[0] = v.x;
    to[1] = v.y;
    to[2] = v.z;
    to[3] = v.w;
  };
  for (int a = 0; a < 3; ++a) {
    put(n.enter[a], row(32 * a + s.enter_upper[a]));
    put(n.leave[a], row(32 * a + 16 - s.enter_upper[a]));
  }
  const uint4 c = __ldg(reinterpret_cast<const uint4*>(rows + 96));
  n.child[0] = c.x;
  n.child[1] = c.y;
  n.child[2] = c.z;
  n.child[3] = c.w;
#else
  // The six rows lie back to back (static_assert above), 16 bytes each.
  const float* rows = reinterpret_cast<const float*>(node);
  for (int a = 0; a < 3; ++a) {
    n.enter[a] = rows + 8 * a + s.enter_upper[a] / 4;
    n.leave[a] = rows + 8 * a + 4 - s.enter_upper[a] / 4;
  }
  n.child = node->child;
#endif
  return n;
}

}  // namespace caustica
