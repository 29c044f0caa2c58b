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
// sign: slab distances (accel/ray_slabs.h) then stay finite (no 0 * inf NaN for a ray lying in a
// slab plane).
CAUSTICA_HDI Vec3f safe_reciprocal(Vec3f d) {
  auto r = [](float x) { return 1.0f / (fabsf(x) > 1e-30f ? x : copysignf(1e-30f, x)); };
  return {r(d.x), r(d.y), r(d.z)};
}

}  // namespace caustica
