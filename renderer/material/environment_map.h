// Light from an environment: an equirectangular image of radiance around the scene, row 0 the
// zenith (+y), turned about +y by `rotation` and scaled by `scale` (colour times intensity).
// Directions are drawn in proportion to the image's luminance over solid angle, so that next-event
// estimation and photon emission spend their samples where the light is (docs/materials.md,
// "Environment").
#pragma once

#include <cmath>
#include <vector>

#include "renderer/base/piecewise_constant.h"
#include "renderer/material/bsdf.h"
#include "renderer/material/texture.h"

namespace caustica {

struct EnvironmentSample {
  Vec3f direction{0.0f, 1.0f, 0.0f};  // towards the environment
  Vec3f radiance{0.0f};
  float pdf = 0.0f;  // over solid angle
};

struct EnvironmentMap {
  TextureView image;  // level 0 read; u wraps, v clamps
  PiecewiseConstant2D distribution;
  Vec3f scale{1.0f};
  float rotation = 0.0f;  // radians about +y

  // u = (phi - rotation) / 2 pi with phi measured from -z towards +x, v = theta / pi from +y.
  CAUSTICA_HDI Vec2f uv_of(Vec3f d) const {
    const float theta = acosf(min_f(1.0f, max_f(-1.0f, d.y)));
    float u = (atan2f(d.x, -d.z) - rotation) * (0.5f * kInvPi);
    u -= floorf(u);
    return {u, theta * kInvPi};
  }
  CAUSTICA_HDI Vec3f direction_of(Vec2f uv) const {
    const float phi = uv.x * 2.0f * kPi + rotation, theta = uv.y * kPi;
    const float s = sinf(theta);
    return {s * sinf(phi), cosf(theta), -s * cosf(phi)};
  }

  CAUSTICA_HDI Vec3f radiance(Vec3f d) const {
    const Texel t = image.bilinear(0, uv_of(d));
    return Vec3f(t.r, t.g, t.b) * scale;
  }

  // The density over solid angle of drawing `d`: the image's density over (u, v) over the
  // Jacobian 2 pi^2 sin(theta).
  CAUSTICA_HDI float pdf(Vec3f d) const {
    const Vec2f uv = uv_of(d);
    const float s = sinf(uv.y * kPi);
    return s > 0.0f ? distribution.pdf(uv) / (2.0f * kPi * kPi * s) : 0.0f;
  }

  CAUSTICA_HDI EnvironmentSample sample(float u0, float u1) const {
    EnvironmentSample out;
    float pdf_uv;
    const Vec2f uv = distribution.sample(u0, u1, &pdf_uv);
    const float s = sinf(uv.y * kPi);
    if (!(s > 0.0f) || !(pdf_uv > 0.0f)) return out;
    out.direction = direction_of(uv);
    out.radiance = radiance(out.direction);
    out.pdf = pdf_uv / (2.0f * kPi * kPi * s);
    return out;
  }
};

// The distribution an environment of `width` x `height` texels is drawn from: each texel's
// weight is the largest luminance among it and its eight neighbours (bilinear lookups inside a
// texel read them all, so no direction with light is left without a density), times the sine of
// its row's polar angle (rows near the poles cover less solid angle).
inline PiecewiseConstant2DData environment_distribution(uint32_t width, uint32_t height,
                                                        const std::vector<Texel>& texels) {
  std::vector<float> f(size_t(width) * height);
  for (uint32_t y = 0; y < height; ++y) {
    const float sin_theta = sinf(kPi * (float(y) + 0.5f) / float(height));
    for (uint32_t x = 0; x < width; ++x) {
      float brightest = 0.0f;
      for (int dy = -1; dy <= 1; ++dy) {
        const int yy = int(y) + dy;
        if (yy < 0 || yy >= int(height)) continue;
        for (int dx = -1; dx <= 1; ++dx) {
          const uint32_t xx = uint32_t((int(x) + dx + int(width)) % int(width));
          const Texel& t = texels[size_t(yy) * width + xx];
          brightest = max_f(brightest, luminance(Vec3f(t.r, t.g, t.b)));
        }
      }
      f[size_t(y) * width + x] = brightest * sin_theta;
    }
  }
  return build_piecewise_constant_2d(std::move(f), width, height);
}

// The mean over the sphere of an environment image's radiance (before its scale): what its power
// through a disc facing any direction is pi r^2 4 pi times. Each texel weighs by the solid angle
// of its row.
inline Vec3f environment_mean(uint32_t width, uint32_t height, const std::vector<Texel>& texels) {
  double sum[3] = {0.0, 0.0, 0.0}, weight = 0.0;
  for (uint32_t y = 0; y < height; ++y) {
    const double w = std::sin(3.14159265358979323846 * (double(y) + 0.5) / double(height));
    for (uint32_t x = 0; x < width; ++x) {
      const Texel& t = texels[size_t(y) * width + x];
      sum[0] += w * t.r;
      sum[1] += w * t.g;
      sum[2] += w * t.b;
    }
    weight += w * width;
  }
  return weight > 0.0
             ? Vec3f(float(sum[0] / weight), float(sum[1] / weight), float(sum[2] / weight))
             : Vec3f(0.0f);
}

}  // namespace caustica
