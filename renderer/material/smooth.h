// The scene's first material kinds as models of the seam: a Lambertian surface, a perfect mirror
// and a smooth dielectric. The last two scatter into single directions (delta lobes): f and pdf
// are zero for any pair of directions given, and a sample carries the lobe's weight as f / pdf
// with pdf the probability of the lobe chosen (pbrt-v4's convention), so weight() is the
// reflectance or transmittance itself.
#pragma once

#include "renderer/base/sampling.h"
#include "renderer/material/bsdf.h"
#include "renderer/material/fresnel.h"
#include "renderer/material/rough_dielectric.h"

namespace caustica {

struct LambertianBsdf {
  Vec3f color{0.5f};

  CAUSTICA_HDI uint32_t flags() const { return kBsdfReflection | kBsdfDiffuse; }
  CAUSTICA_HDI Vec3f f(Vec3f wo, Vec3f wi) const {
    return same_hemisphere(wo, wi) && wo.z > 0.0f ? color * kInvPi : Vec3f(0.0f);
  }
  CAUSTICA_HDI float pdf(Vec3f wo, Vec3f wi) const {
    return same_hemisphere(wo, wi) && wo.z > 0.0f ? abs_cos_theta(wi) * kInvPi : 0.0f;
  }
  CAUSTICA_HDI BsdfSample sample(Vec3f wo, float, float u0, float u1) const {
    BsdfSample s;
    if (wo.z <= 0.0f) return s;
    s.wi = sample_cosine_hemisphere(u0, u1);
    s.pdf = pdf(wo, s.wi);
    if (!(s.pdf > 0.0f)) return BsdfSample{};
    s.f = f(wo, s.wi);
    s.flags = kBsdfReflection | kBsdfDiffuse;
    return s;
  }
};

struct MirrorBsdf {
  Vec3f color{1.0f};

  CAUSTICA_HDI uint32_t flags() const { return kBsdfReflection | kBsdfSpecular; }
  CAUSTICA_HDI Vec3f f(Vec3f, Vec3f) const { return Vec3f(0.0f); }
  CAUSTICA_HDI float pdf(Vec3f, Vec3f) const { return 0.0f; }
  CAUSTICA_HDI BsdfSample sample(Vec3f wo, float, float, float) const {
    BsdfSample s;
    if (wo.z <= 0.0f) return s;
    s.wi = Vec3f(-wo.x, -wo.y, wo.z);
    s.pdf = 1.0f;
    s.f = color / abs_cos_theta(s.wi);
    s.flags = kBsdfReflection | kBsdfSpecular;
    return s;
  }
};

// A smooth boundary between the outside (index 1, the side +z faces) and a dielectric of index
// `ior`: reflection with the Fresnel reflectance's probability, else refraction by Snell's law,
// its radiance divided by the square of the index ratio (Transport as rough_dielectric.h).
struct SmoothDielectricBsdf {
  float ior = 1.5f;
  Transport transport = Transport::kRadiance;

  CAUSTICA_HDI uint32_t flags() const {
    return kBsdfReflection | kBsdfTransmission | kBsdfSpecular;
  }
  CAUSTICA_HDI Vec3f f(Vec3f, Vec3f) const { return Vec3f(0.0f); }
  CAUSTICA_HDI float pdf(Vec3f, Vec3f) const { return 0.0f; }

  CAUSTICA_HDI BsdfSample sample(Vec3f wo, float uc, float, float) const {
    BsdfSample s;
    if (cos_theta(wo) == 0.0f) return s;
    const Vec3f n(0.0f, 0.0f, wo.z > 0.0f ? 1.0f : -1.0f);  // faces wo's side
    const float eta = wo.z > 0.0f ? ior : 1.0f / ior;
    const float reflectance = fresnel_dielectric(abs_cos_theta(wo), eta);
    if (uc < reflectance) {
      s.wi = Vec3f(-wo.x, -wo.y, wo.z);
      s.pdf = reflectance;
      s.f = Vec3f(reflectance / abs_cos_theta(s.wi));
      s.flags = kBsdfReflection | kBsdfSpecular;
      return s;
    }
    if (!refract(-wo, n, eta, s.wi)) return BsdfSample{};
    const float transmittance = 1.0f - reflectance;
    float t = transmittance / abs_cos_theta(s.wi);
    if (transport == Transport::kRadiance) t /= eta * eta;
    s.pdf = transmittance;
    s.f = Vec3f(t);
    s.flags = kBsdfTransmission | kBsdfSpecular;
    return s;
  }
};

}  // namespace caustica
