// glTF 2.0's metallic-roughness material (the specification's appendix B): a GGX specular lobe
// over a Lambertian base, the lobe weighted by Schlick's Fresnel at the microfacet normal with
// ior 1.5 (reflectance 0.04) for a dielectric and by the base colour's for a metal; `metallic`
// mixes the two. Reflection only; transmission is the dielectric models'.
//
//   f = (1 - m) c (1 - F(wo.n)) (1 - F(wi.n)) / (pi (1 - F_avg))
//     + D G / (4 |cos o| |cos i|) ((1 - m) F_0.04(wo.wm) + m F_c(wo.wm))
//
// with F(x) = f0 + (1 - f0) (1 - x)^5. The specification weights the base by 1 - F(wo.wm), which
// reflects more light than arrives at grazing angles (8% more at 88 degrees, roughness 0.6); the
// base here is weighted by both directions' Fresnel at the macro normal instead, divided by its
// cosine-weighted mean (1 - F_avg = 1 - f0 - (1 - f0) / 21), so that it stays reciprocal, reflects
// 1 - F(wo.n) of white light and never more than arrives (docs/materials.md).
//
// Sampling picks the specular lobe (visible normals) or the base (cosine-weighted) by their
// albedos' estimate at wo and returns the mixture's density, so f cos / pdf stays bounded.
#pragma once

#include "renderer/material/microfacet.h"

namespace caustica {

struct MetallicRoughnessBsdf {
  Vec3f base_color{1.0f};
  float metallic = 0.0f;
  float roughness = 1.0f;  // perceptual: alpha = roughness^2

  static constexpr float kDielectricF0 = 0.04f;  // ior 1.5
  // 1 - the cosine-weighted mean of Schlick's F over the hemisphere, F0 + (1 - F0) / 21: dividing
  // the base by it makes the base's albedo at wo exactly 1 - F(wo.n).
  static constexpr float kBaseAlbedoNorm = 1.0f - (kDielectricF0 + (1.0f - kDielectricF0) / 21.0f);

  CAUSTICA_HDI TrowbridgeReitz distribution() const {
    return {max_f(roughness * roughness, kMinMicrofacetAlpha)};
  }
  CAUSTICA_HDI uint32_t flags() const {
    return kBsdfReflection | kBsdfGlossy | (metallic < 1.0f ? kBsdfDiffuse : kBsdfNone);
  }

  // The base, which is separable: base_albedo(wo) base_in(wi) / pi. An integrator that stores
  // photons with base_in of the way they came and weighs their density by base_albedo estimates
  // the base's share exactly (docs/materials.md, "In the integrators").
  CAUSTICA_HDI Vec3f base_albedo(Vec3f wo) const {
    return base_color *
           ((1.0f - metallic) * (1.0f - fresnel_schlick(kDielectricF0, abs_cos_theta(wo))));
  }
  CAUSTICA_HDI float base_in(Vec3f wi) const {
    return (1.0f - fresnel_schlick(kDielectricF0, abs_cos_theta(wi))) / kBaseAlbedoNorm;
  }

  // The specular lobe alone.
  CAUSTICA_HDI Vec3f specular_f(Vec3f wo, Vec3f wi) const {
    if (!same_hemisphere(wo, wi) || wo.z <= 0.0f) return Vec3f(0.0f);
    const Vec3f h = wo + wi;
    if (!(length_squared(h) > 0.0f)) return Vec3f(0.0f);
    const Vec3f wm = normalize(h);
    const float cos_h = fabsf(dot(wo, wm));
    const float dielectric = fresnel_schlick(kDielectricF0, cos_h);
    const Vec3f metal = fresnel_schlick(base_color, cos_h);
    const TrowbridgeReitz d = distribution();
    const float specular = d.D(wm) * d.G(wo, wi) / (4.0f * abs_cos_theta(wo) * abs_cos_theta(wi));
    return (Vec3f((1.0f - metallic) * dielectric) + metal * metallic) * specular;
  }

  CAUSTICA_HDI Vec3f f(Vec3f wo, Vec3f wi) const {
    if (!same_hemisphere(wo, wi) || wo.z <= 0.0f) return Vec3f(0.0f);
    return base_albedo(wo) * (base_in(wi) * kInvPi) + specular_f(wo, wi);
  }

  // A direction from the specular lobe alone (visible normals), with that lobe's value and
  // density: the camera paths' way past a glossy surface.
  CAUSTICA_HDI BsdfSample sample_specular(Vec3f wo, float u0, float u1) const {
    BsdfSample s;
    if (wo.z <= 0.0f) return s;
    const TrowbridgeReitz d = distribution();
    s.wi = reflect(-wo, d.sample_visible_normal(wo, u0, u1));
    if (s.wi.z <= 0.0f) return BsdfSample{};
    s.pdf = d.reflection_pdf(wo, s.wi);
    if (!(s.pdf > 0.0f)) return BsdfSample{};
    s.f = specular_f(wo, s.wi);
    s.flags = kBsdfReflection | kBsdfGlossy;
    return s;
  }

  // The probability of sampling the specular lobe from `wo`: its share of an estimate of both
  // lobes' albedos (Fresnel at the macro normal for the lobe, the rest of the base's colour).
  CAUSTICA_HDI float specular_probability(Vec3f wo) const {
    const float c = abs_cos_theta(wo);
    const float dielectric = fresnel_schlick(kDielectricF0, c);
    const float specular =
        (1.0f - metallic) * dielectric + metallic * luminance(fresnel_schlick(base_color, c));
    const float diffuse = (1.0f - metallic) * (1.0f - dielectric) * luminance(base_color);
    const float total = specular + diffuse;
    if (!(total > 0.0f)) return 1.0f;
    // Never quite zero for either lobe, so that every direction either lobe reaches has a density.
    return min_f(0.98f, max_f(0.02f, specular / total));
  }

  CAUSTICA_HDI float pdf(Vec3f wo, Vec3f wi) const {
    if (!same_hemisphere(wo, wi) || wo.z <= 0.0f) return 0.0f;
    const float p = metallic < 1.0f ? specular_probability(wo) : 1.0f;
    return p * distribution().reflection_pdf(wo, wi) + (1.0f - p) * abs_cos_theta(wi) * kInvPi;
  }

  // `uc` chooses the lobe, `u0` and `u1` the direction.
  CAUSTICA_HDI BsdfSample sample(Vec3f wo, float uc, float u0, float u1) const {
    const float p = metallic < 1.0f ? specular_probability(wo) : 1.0f;
    return sample_glossy_or_base(*this, wo, p, uc, u0, u1, [&](float v0, float v1) {
      return reflect(-wo, distribution().sample_visible_normal(wo, v0, v1));
    });
  }
};

}  // namespace caustica
