// Axis-aligned bounding boxes and the slab test used by every traversal.
#pragma once

#include <cfloat>
#include <cmath>

#include "renderer/base/vec.h"

namespace caustica {

struct Aabb {
  Vec3f lower{FLT_MAX, FLT_MAX, FLT_MAX};
  Vec3f upper{-FLT_MAX, -FLT_MAX, -FLT_MAX};

  CAUSTICA_HDI bool empty() const {
    return lower.x > upper.x || lower.y > upper.y || lower.z > upper.z;
  }
  CAUSTICA_HDI void extend(Vec3f p) {
    lower = min(lower, p);
    upper = max(upper, p);
  }
  CAUSTICA_HDI void extend(const Aabb& b) {
    lower = min(lower, b.lower);
    upper = max(upper, b.upper);
  }
  CAUSTICA_HDI Vec3f extent() const { return upper - lower; }
  CAUSTICA_HDI Vec3f center() const { return (lower + upper) * 0.5f; }
  CAUSTICA_HDI bool contains(const Aabb& b) const {
    return lower.x <= b.lower.x && lower.y <= b.lower.y && lower.z <= b.lower.z &&
           upper.x >= b.upper.x && upper.y >= b.upper.y && upper.z >= b.upper.z;
  }
  CAUSTICA_HDI float half_area() const {
    Vec3f e = extent();
    return e.x * e.y + e.y * e.z + e.z * e.x;
  }
};

CAUSTICA_HDI Aabb merge(Aabb a, const Aabb& b) {
  a.extend(b);
  return a;
}

// Squared distance from `p` to the box (0 inside); kNN search prunes with it.
CAUSTICA_HDI float distance_squared(const Aabb& b, Vec3f p) {
  Vec3f d = max(max(b.lower - p, p - b.upper), Vec3f(0.0f));
  return dot(d, d);
}

// Reciprocal direction for slab tests, with zero components replaced by a tiny value of the same
// sign: the products in intersect_slabs then stay finite (no 0 * inf NaN for a ray lying in a
// slab plane), so the plain compares below are exact.
CAUSTICA_HDI Vec3f safe_reciprocal(Vec3f d) {
  auto r = [](float x) { return 1.0f / (fabsf(x) > 1e-30f ? x : copysignf(1e-30f, x)); };
  return {r(d.x), r(d.y), r(d.z)};
}

// Slab test with a reciprocal direction from safe_reciprocal. Returns the entry distance, or
// +infinity when the ray misses [t_min, t_max] (never <= any t_max, even FLT_MAX).
CAUSTICA_HDI float intersect_slabs(const Aabb& b, Vec3f origin, Vec3f inv_dir, float t_min,
                                   float t_max) {
  float tx0 = (b.lower.x - origin.x) * inv_dir.x, tx1 = (b.upper.x - origin.x) * inv_dir.x;
  float ty0 = (b.lower.y - origin.y) * inv_dir.y, ty1 = (b.upper.y - origin.y) * inv_dir.y;
  float tz0 = (b.lower.z - origin.z) * inv_dir.z, tz1 = (b.upper.z - origin.z) * inv_dir.z;
  float t_near = max_f(max_f(min_f(tx0, tx1), min_f(ty0, ty1)), max_f(min_f(tz0, tz1), t_min));
  float t_far = min_f(min_f(max_f(tx0, tx1), max_f(ty0, ty1)), min_f(max_f(tz0, tz1), t_max));
  // Robust slab test (Ize 2013): widen the far distance by 2 ulp-ish so grazing rays are not lost.
  t_far *= 1.00000024f;
  return t_near <= t_far ? t_near : INFINITY;
}

}  // namespace caustica
