// A rough dielectric boundary (Walter et al. 2007, "Microfacet Models for Refraction through Rough
// Surfaces"): GGX microfacets that reflect or refract by the exact Fresnel reflectance at the
// microfacet normal. The shading frame's +z faces the outside, of index 1; `ior` is the inside's.
// Transmission's value depends on what the path carries: radiance (camera paths) is compressed by
// the square of the index ratio when it enters a denser medium, importance and flux (photon paths)
// are not, so that f for photons is the adjoint of f for radiance (docs/materials.md).
#pragma once

#include "renderer/material/fresnel.h"
#include "renderer/material/microfacet.h"

namespace caustica {

enum class Transport : uint32_t { kRadiance, kImportance };

struct RoughDielectricBsdf {
  float ior = 1.5f;
  float roughness = 0.5f;  // alpha = roughness^2
  Transport transport = Transport::kRadiance;

  CAUSTICA_HDI TrowbridgeReitz distribution() const {
    return {max_f(roughness * roughness, kMinMicrofacetAlpha)};
  }
  CAUSTICA_HDI uint32_t flags() const { return kBsdfReflection | kBsdfTransmission | kBsdfGlossy; }

  // The index ratio across the boundary seen from `w`'s side: transmitted over incident.
  CAUSTICA_HDI float eta_from(Vec3f w) const { return w.z > 0.0f ? ior : 1.0f / ior; }

  // What f and pdf share for a pair of directions: the generalised half vector (facing +z), the
  // Fresnel reflectance there, and the transmission's Jacobian denominator.
  struct Pair {
    bool valid = false;
    bool reflects = false;
    Vec3f wm{0.0f};
    float eta = 1.0f;  // from wo's side; 1 for a reflection's half vector
    float reflectance = 0.0f;
    float denominator = 0.0f;  // (wi.wm + wo.wm / eta)^2, transmission only
  };

  CAUSTICA_HDI Pair pair(Vec3f wo, Vec3f wi) const {
    Pair p;
    const float cos_o = cos_theta(wo), cos_i = cos_theta(wi);
    if (cos_o == 0.0f || cos_i == 0.0f) return p;
    p.reflects = cos_o * cos_i > 0.0f;
    p.eta = p.reflects ? 1.0f : eta_from(wo);
    Vec3f wm = wi * p.eta + wo;
    if (!(length_squared(wm) > 0.0f)) return p;
    wm = normalize(wm);
    if (wm.z < 0.0f) wm = -wm;
    // Microfacets that face away from either direction reflect and transmit nothing.
    const float o_dot_m = dot(wo, wm), i_dot_m = dot(wi, wm);
    if (o_dot_m * cos_o <= 0.0f || i_dot_m * cos_i <= 0.0f) return p;
    p.wm = wm;
    p.reflectance = fresnel_dielectric(fabsf(o_dot_m), eta_from(wo));
    if (!p.reflects) {
      const float s = i_dot_m + o_dot_m / p.eta;
      p.denominator = s * s;
      if (!(p.denominator > 0.0f)) return p;
    }
    p.valid = true;
    return p;
  }

  CAUSTICA_HDI Vec3f f(Vec3f wo, Vec3f wi) const {
    const Pair p = pair(wo, wi);
    if (!p.valid) return Vec3f(0.0f);
    const TrowbridgeReitz d = distribution();
    const float cos_cos = fabsf(cos_theta(wo) * cos_theta(wi));
    if (p.reflects) return Vec3f(d.D(p.wm) * d.G(wo, wi) * p.reflectance / (4.0f * cos_cos));
    float t = d.D(p.wm) * (1.0f - p.reflectance) * d.G(wo, wi) *
              fabsf(dot(wi, p.wm) * dot(wo, p.wm) / (cos_cos * p.denominator));
    if (transport == Transport::kRadiance) t /= p.eta * p.eta;
    return Vec3f(t);
  }

  CAUSTICA_HDI float pdf(Vec3f wo, Vec3f wi) const {
    const Pair p = pair(wo, wi);
    if (!p.valid) return 0.0f;
    // The density of the visible normal wm (facing +z) as seen from wo's side of the boundary.
    const float normal = distribution().visible_D(wo.z > 0.0f ? wo : -wo, p.wm);
    if (p.reflects) return normal / (4.0f * fabsf(dot(wo, p.wm))) * p.reflectance;
    return normal * fabsf(dot(wi, p.wm)) / p.denominator * (1.0f - p.reflectance);
  }

  // `uc` chooses reflection (with the Fresnel reflectance's probability) or transmission.
  CAUSTICA_HDI BsdfSample sample(Vec3f wo, float uc, float u0, float u1) const {
    BsdfSample s;
    if (cos_theta(wo) == 0.0f) return s;
    const bool outside = cos_theta(wo) > 0.0f;
    // A visible normal from wo's side of the boundary.
    Vec3f wm = distribution().sample_visible_normal(outside ? wo : -wo, u0, u1);
    if (!outside) wm = -wm;
    const float reflectance = fresnel_dielectric(dot(wo, wm), eta_from(wo));
    if (uc < reflectance) {
      s.wi = reflect(-wo, wm);
      if (!same_hemisphere(wo, s.wi)) return BsdfSample{};
      s.flags = kBsdfReflection | kBsdfGlossy;
    } else {
      if (!refract(-wo, wm, eta_from(wo), s.wi)) return BsdfSample{};
      if (same_hemisphere(wo, s.wi) || cos_theta(s.wi) == 0.0f) return BsdfSample{};
      s.flags = kBsdfTransmission | kBsdfGlossy;
    }
    s.pdf = pdf(wo, s.wi);
    if (!(s.pdf > 0.0f)) return BsdfSample{};
    s.f = f(wo, s.wi);
    return s;
  }
};

}  // namespace caustica
