// Rays and hit records shared by traversal, photon tracing and rendering.
#pragma once

#include <cfloat>
#include <cstdint>

#include "renderer/base/vec.h"

namespace caustica {

struct Ray {
  Vec3f origin;
  Vec3f direction;
  // Never negative: a GPU's box tests order distances as integers (ray_slabs.h).
  float t_min = 0.0f;
  float t_max = FLT_MAX;
};

constexpr uint32_t kNoHit = 0xffffffffu;

struct Hit {
  float t = FLT_MAX;
  float u = 0, v = 0;          // barycentrics of vertices 1 and 2
  uint32_t triangle = kNoHit;  // index into the scene's original triangle order
  CAUSTICA_HD bool valid() const { return triangle != kNoHit; }
};

// Offsets a ray origin off a surface along the geometric normal, scaled to the coordinate's
// magnitude, so secondary rays do not re-hit their own triangle (float error grows with |p|).
CAUSTICA_HDI Vec3f offset_origin(Vec3f p, Vec3f geometric_normal, Vec3f direction) {
  float scale = 1e-4f * max_f(1.0f, max_component(abs(p)));
  Vec3f n = dot(geometric_normal, direction) >= 0 ? geometric_normal : -geometric_normal;
  return p + n * scale;
}

}  // namespace caustica
