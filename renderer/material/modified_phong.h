// The energy-conserving modified Phong model (Lafortune and Willems 1994), the glossy model of
// the photon-mapping seed: a Lambertian lobe plus a lobe around the mirror direction,
//
//   f = kd / pi + ks (n + 2) / (2 pi) max(0, cos a)^n,   a the angle between wi and wo's mirror,
//
// which reflects at most kd + ks of the light, so any kd + ks <= 1 conserves energy. Sampling
// picks a lobe by its colour's luminance share; the specular lobe draws cos a with density
// (n + 1) / (2 pi) cos^n a around the mirror direction, and a direction below the surface is
// no sample.
#pragma once

#include <cmath>

#include "renderer/base/sampling.h"
#include "renderer/material/bsdf.h"

namespace caustica {

struct ModifiedPhongBsdf {
  Vec3f kd{0.5f};
  Vec3f ks{0.5f};
  float exponent = 20.0f;

  CAUSTICA_HDI uint32_t flags() const {
    return kBsdfReflection | (is_black(kd) ? kBsdfNone : kBsdfDiffuse) |
           (is_black(ks) ? kBsdfNone : kBsdfGlossy);
  }

  // wo's mirror direction about the macro normal.
  CAUSTICA_HDI static Vec3f mirror(Vec3f wo) { return Vec3f(-wo.x, -wo.y, wo.z); }

  CAUSTICA_HDI float lobe(Vec3f wo, Vec3f wi) const {
    const float c = dot(mirror(wo), wi);
    return c > 0.0f ? powf(c, exponent) : 0.0f;
  }

  CAUSTICA_HDI Vec3f f(Vec3f wo, Vec3f wi) const {
    if (!same_hemisphere(wo, wi) || wo.z <= 0.0f) return Vec3f(0.0f);
    return kd * kInvPi + ks * ((exponent + 2.0f) * (0.5f * kInvPi) * lobe(wo, wi));
  }

  CAUSTICA_HDI float specular_probability() const {
    const float d = luminance(kd), s = luminance(ks);
    return d + s > 0.0f ? s / (d + s) : 0.0f;
  }

  CAUSTICA_HDI float pdf(Vec3f wo, Vec3f wi) const {
    if (!same_hemisphere(wo, wi) || wo.z <= 0.0f) return 0.0f;
    const float p = specular_probability();
    return p * (exponent + 1.0f) * (0.5f * kInvPi) * lobe(wo, wi) +
           (1.0f - p) * abs_cos_theta(wi) * kInvPi;
  }

  // cos a = u0^(1 / (n + 1)) inverts the lobe's distribution of cos a around the mirror
  // direction.
  CAUSTICA_HDI Vec3f lobe_direction(Vec3f wo, float u0, float u1) const {
    const float c = powf(u0, 1.0f / (exponent + 1.0f));
    const float r = sqrtf(max_f(0.0f, 1.0f - c * c));
    const float phi = 2.0f * kPi * u1;
    return Frame::from_normal(mirror(wo)).to_world(Vec3f(r * cosf(phi), r * sinf(phi), c));
  }

  CAUSTICA_HDI BsdfSample sample(Vec3f wo, float uc, float u0, float u1) const {
    return sample_glossy_or_base(*this, wo, specular_probability(), uc, u0, u1,
                                 [&](float v0, float v1) { return lobe_direction(wo, v0, v1); });
  }

  // The glossy lobe alone, and the density with which sample_specular draws it.
  CAUSTICA_HDI Vec3f specular_f(Vec3f wo, Vec3f wi) const {
    if (!same_hemisphere(wo, wi) || wo.z <= 0.0f) return Vec3f(0.0f);
    return ks * ((exponent + 2.0f) * (0.5f * kInvPi) * lobe(wo, wi));
  }
  CAUSTICA_HDI float specular_pdf(Vec3f wo, Vec3f wi) const {
    if (!same_hemisphere(wo, wi) || wo.z <= 0.0f || is_black(ks)) return 0.0f;
    return (exponent + 1.0f) * (0.5f * kInvPi) * lobe(wo, wi);
  }

  // A direction from the glossy lobe alone, with that lobe's value and density: the camera paths'
  // way past a glossy surface. Its weight is ks (n + 2) / (n + 1) cos(wi).
  CAUSTICA_HDI BsdfSample sample_specular(Vec3f wo, float u0, float u1) const {
    BsdfSample s;
    if (wo.z <= 0.0f || is_black(ks)) return s;
    s.wi = lobe_direction(wo, u0, u1);
    if (s.wi.z <= 0.0f) return BsdfSample{};
    s.pdf = specular_pdf(wo, s.wi);
    if (!(s.pdf > 0.0f)) return BsdfSample{};
    s.f = specular_f(wo, s.wi);
    s.flags = kBsdfReflection | kBsdfGlossy;
    return s;
  }
};

}  // namespace caustica
