// Pinhole camera rays. Pixel (0, 0) is the top-left corner of the image.
#pragma once

#include <cmath>

#include "renderer/base/ray.h"
#include "renderer/scene/scene.h"

namespace caustica {

struct PinholeCamera {
  Vec3f origin, forward, right, up;  // right and up scaled to the image plane at distance 1
  int width, height;

  static PinholeCamera from(const Camera& c) {
    PinholeCamera p;
    p.origin = c.position;
    p.forward = normalize(c.look_at - c.position);
    Vec3f r = normalize(cross(p.forward, c.up));
    Vec3f u = cross(r, p.forward);
    float tan_half = std::tan(0.5f * c.vertical_fov_deg * kPi / 180.0f);
    float aspect = float(c.width) / float(c.height);
    p.right = r * (tan_half * aspect);
    p.up = u * tan_half;
    p.width = c.width;
    p.height = c.height;
    return p;
  }

  // Ray through image position (x, y) in pixels, continuous.
  CAUSTICA_HDI Ray ray_through(float x, float y) const {
    float sx = 2.0f * x / float(width) - 1.0f;
    float sy = 1.0f - 2.0f * y / float(height);
    Ray r;
    r.origin = origin;
    r.direction = normalize(forward + right * sx + up * sy);
    return r;
  }
};

}  // namespace caustica
