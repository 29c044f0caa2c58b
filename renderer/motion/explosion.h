// An exploding mesh, after the Utah "Exploding Dragon" that dynamic ray-tracing papers animate:
// every triangle flies off along its own normal at a speed of its own, spinning about its
// centroid, and falls under gravity. A pure function of the rest triangle, its index and the
// time, so that the CPU and a GPU move every triangle the same and any frame can be drawn alone.
#pragma once

#include <cmath>
#include <cstdint>

#include "renderer/accel/triangle.h"
#include "renderer/base/rng.h"
#include "renderer/base/vec.h"

namespace caustica {

struct Explosion {
  float speed = 1.0f;                   // the mean speed along the normals, scene units a second
  Vec3f gravity = Vec3f(0, -9.81f, 0);  // scene units a second squared
  float spin = 6.0f;                    // the largest spin, radians a second
  uint32_t seed = 1;
};

// Triangle `index` of the rest mesh `rest`, `seconds` into `explosion`.
CAUSTICA_HDI TriangleVertices exploded_triangle(const TriangleVertices& rest, uint32_t index,
                                                float seconds, const Explosion& explosion) {
  const uint32_t key = pcg_hash(explosion.seed ^ pcg_hash(index));
  const float pace = 0.5f + unit_float(pcg_hash(key ^ 1u));  // in [0.5, 1.5)
  const float turn = explosion.spin * (2.0f * unit_float(pcg_hash(key ^ 2u)) - 1.0f) * seconds;
  const float z = 2.0f * unit_float(pcg_hash(key ^ 3u)) - 1.0f;
  const float phi = 6.2831853f * unit_float(pcg_hash(key ^ 4u));
  const float r = sqrtf(fmaxf(0.0f, 1.0f - z * z));
  const Vec3f axis(r * cosf(phi), r * sinf(phi), z);

  const Vec3f n = cross(rest.p1 - rest.p0, rest.p2 - rest.p0);
  const float n_length = length(n);
  const Vec3f normal = n_length > 0.0f ? n * (1.0f / n_length) : Vec3f(0.0f);
  const Vec3f centroid = (rest.p0 + rest.p1 + rest.p2) * (1.0f / 3.0f);
  const Vec3f moved_centroid = centroid + normal * (explosion.speed * pace * seconds) +
                               explosion.gravity * (0.5f * seconds * seconds);
  // Rodrigues' rotation of each corner about the axis through the centroid.
  const float c = cosf(turn), s = sinf(turn);
  auto place = [&](Vec3f p) {
    const Vec3f v = p - centroid;
    const Vec3f rotated = v * c + cross(axis, v) * s + axis * (dot(axis, v) * (1.0f - c));
    return moved_centroid + rotated;
  };
  return {place(rest.p0), place(rest.p1), place(rest.p2)};
}

}  // namespace caustica
