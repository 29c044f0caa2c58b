// Sampling routines shared by photon emission and light sampling (pbrt-v4 ch. A.5 conventions):
// each maps uniform numbers in [0,1)^2 to a distribution and the caller divides by its pdf.
#pragma once

#include "renderer/base/vec.h"

namespace caustica {

// Orthonormal basis around a unit vector (Duff et al. 2017, branchless).
struct Frame {
  Vec3f s, t, n;
  CAUSTICA_HD static Frame from_normal(Vec3f n) {
    float sign = copysignf(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float b = n.x * n.y * a;
    return {Vec3f(1.0f + sign * n.x * n.x * a, sign * b, -sign * n.x),
            Vec3f(b, sign + n.y * n.y * a, -n.y), n};
  }
  CAUSTICA_HDI Vec3f to_world(Vec3f v) const { return s * v.x + t * v.y + n * v.z; }
};

CAUSTICA_HDI Vec3f sample_uniform_sphere(float u0, float u1) {
  float z = 1.0f - 2.0f * u0;
  float r = sqrtf(max_f(0.0f, 1.0f - z * z));
  float phi = 2.0f * kPi * u1;
  return {r * cosf(phi), r * sinf(phi), z};
}

// Uniform over the cap of directions within acos(cos_max) of +z; pdf 1 / (2 pi (1 - cos_max)).
CAUSTICA_HDI Vec3f sample_uniform_cone(float u0, float u1, float cos_max) {
  float z = 1.0f - u0 * (1.0f - cos_max);
  float r = sqrtf(max_f(0.0f, 1.0f - z * z));
  float phi = 2.0f * kPi * u1;
  return {r * cosf(phi), r * sinf(phi), z};
}

// Cosine-weighted hemisphere around +z (Malley's method); pdf cos(theta) / pi.
CAUSTICA_HDI Vec3f sample_cosine_hemisphere(float u0, float u1) {
  float r = sqrtf(u0);
  float phi = 2.0f * kPi * u1;
  float x = r * cosf(phi), y = r * sinf(phi);
  return {x, y, sqrtf(max_f(0.0f, 1.0f - x * x - y * y))};
}

// Uniform point on the unit disk (polar mapping; area pdf 1 / pi).
CAUSTICA_HDI Vec2f sample_uniform_disk(float u0, float u1) {
  float r = sqrtf(u0);
  float phi = 2.0f * kPi * u1;
  return {r * cosf(phi), r * sinf(phi)};
}

// Uniform barycentrics (b1, b2) on a triangle (Heitz 2019 area-preserving square-to-triangle map).
CAUSTICA_HDI Vec2f sample_uniform_triangle(float u0, float u1) {
  float b0, b1;
  if (u0 < u1) {
    b0 = u0 / 2;
    b1 = u1 - b0;
  } else {
    b1 = u1 / 2;
    b0 = u0 - b1;
  }
  return {b1, 1.0f - b0 - b1};
}

}  // namespace caustica
