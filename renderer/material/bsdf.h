// What every scattering model of the material seam shares: directions in the shading frame (the
// normal along +z, both directions pointing away from the surface), the lobe flags the integrators
// branch on, and a sampled direction with its value and density. Each model offers
// f(wo, wi), sample(wo, uc, u) and pdf(wo, wi) over these (docs/materials.md).
#pragma once

#include <cstdint>

#include "renderer/base/sampling.h"
#include "renderer/base/vec.h"

namespace caustica {

// The kinds of scattering a lobe does: the integrators store photons and gather density at
// diffuse and glossy lobes, follow specular (delta) ones, and treat transmission as crossing a
// boundary.
enum BsdfFlags : uint32_t {
  kBsdfNone = 0,
  kBsdfReflection = 1u << 0,
  kBsdfTransmission = 1u << 1,
  kBsdfDiffuse = 1u << 2,
  kBsdfGlossy = 1u << 3,
  kBsdfSpecular = 1u << 4,
};

CAUSTICA_HDI float cos_theta(Vec3f w) { return w.z; }
CAUSTICA_HDI float abs_cos_theta(Vec3f w) { return fabsf(w.z); }
CAUSTICA_HDI bool same_hemisphere(Vec3f a, Vec3f b) { return a.z * b.z > 0.0f; }

// A direction a model sampled: its value f(wo, wi), its density over solid angle and the lobe it
// came from. `pdf` is zero when no direction came out (one below the surface, say); the estimate
// it stands for is then zero.
struct BsdfSample {
  Vec3f f{0.0f};
  Vec3f wi{0.0f, 0.0f, 1.0f};
  float pdf = 0.0f;
  uint32_t flags = kBsdfNone;

  // A density that overflowed says nothing of the direction: such a sample is dropped.
  CAUSTICA_HDI bool valid() const { return pdf > 0.0f && isfinite(pdf); }
  // The estimator's weight f |cos| / pdf of the sampled direction.
  CAUSTICA_HDI Vec3f weight() const { return f * (abs_cos_theta(wi) / pdf); }
};

// A sample of a reflecting model made of a glossy lobe over a Lambertian base: `uc` below
// `glossy_probability` takes the direction `glossy_wi(u0, u1)`, else a cosine-weighted one, and
// the sample carries the model's value and whole density there, or is none when the direction is
// below the surface.
template <typename Model, typename GlossyDirection>
CAUSTICA_HDI BsdfSample sample_glossy_or_base(const Model& model, Vec3f wo,
                                              float glossy_probability, float uc, float u0,
                                              float u1, GlossyDirection glossy_wi) {
  BsdfSample s;
  if (wo.z <= 0.0f) return s;
  if (uc < glossy_probability) {
    s.wi = glossy_wi(u0, u1);
    s.flags = kBsdfReflection | kBsdfGlossy;
  } else {
    s.wi = sample_cosine_hemisphere(u0, u1);
    s.flags = kBsdfReflection | kBsdfDiffuse;
  }
  if (s.wi.z <= 0.0f) return BsdfSample{};
  s.pdf = model.pdf(wo, s.wi);
  if (!(s.pdf > 0.0f)) return BsdfSample{};
  s.f = model.f(wo, s.wi);
  return s;
}

// Schlick's approximation of the Fresnel reflectance from the reflectance at normal incidence,
// as glTF's metallic-roughness model defines it.
CAUSTICA_HDI float schlick_weight(float cos_h) {
  const float m = 1.0f - min_f(1.0f, max_f(0.0f, cos_h));
  const float m2 = m * m;
  return m2 * m2 * m;
}
CAUSTICA_HDI Vec3f fresnel_schlick(Vec3f f0, float cos_h) {
  return f0 + (Vec3f(1.0f) - f0) * schlick_weight(cos_h);
}
CAUSTICA_HDI float fresnel_schlick(float f0, float cos_h) {
  return f0 + (1.0f - f0) * schlick_weight(cos_h);
}

// Luminance of linear Rec. 709 values: how the models weigh their lobes when choosing one.
CAUSTICA_HDI float luminance(Vec3f c) { return 0.2126f * c.x + 0.7152f * c.y + 0.0722f * c.z; }

}  // namespace caustica
