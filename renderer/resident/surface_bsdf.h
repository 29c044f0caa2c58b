// A material's scattering at one hit, in world directions, as the integrators use it: the seam's
// models (renderer/material/) built from a DeviceMaterial and the colour at the hit, dispatched on
// the material's type once per hit. The first four kinds keep the integrators' own code, so that
// their images stay what they were; metallic-roughness, Phong and rough glass come through here
// (docs/materials.md, "In the integrators").
#pragma once

#include "renderer/material/metallic_roughness.h"
#include "renderer/material/modified_phong.h"
#include "renderer/material/rough_dielectric.h"
#include "renderer/resident/resident_scene.h"

namespace caustica {

// The GGX alpha below which a camera path treats a glossy lobe as near-specular, as it treats a
// mirror: the lobe's light from area lights and the environment comes from the path's own
// continuation alone, without shadow rays (docs/materials.md, "Near-specular lobes").
constexpr float kNearSpecularAlpha = 0.0625f;

// Whether a material scatters through SurfaceBsdf rather than the first kinds' own code.
CAUSTICA_HDI bool is_sampled_model(const DeviceMaterial& m) {
  return m.type == MaterialType::kMetallicRoughness || m.type == MaterialType::kPhong ||
         (m.type == MaterialType::kDielectric && m.roughness > 0.0f);
}

// A material's metalness and roughness at `hit`: its factors, a metallic-roughness material's times
// its map there (blue and green, linear), read as surface_color reads colour maps.
CAUSTICA_HDI Vec2f metal_rough_at(const ResidentSceneView& scene, const DeviceMaterial& m,
                                  const Hit& hit, Vec3f direction, float cone_width) {
  if (m.metallic_roughness_map == kNoTexture || scene.corner_uvs == nullptr)
    return Vec2f{m.metallic, m.roughness};
  const Vec3f texel = map_at_hit(scene, m.metallic_roughness_map, hit, direction, cone_width);
  return Vec2f{m.metallic * texel.z, m.roughness * texel.y};
}

// A direction a SurfaceBsdf drew, in world space, with its weight f |cos| / pdf (the cosine taken
// in the shading frame), the density and the lobe's flags.
struct SurfaceSample {
  Vec3f wi{0.0f};
  Vec3f weight{0.0f};
  float pdf = 0.0f;
  uint32_t flags = kBsdfNone;
  CAUSTICA_HDI bool valid() const { return pdf > 0.0f; }
};

struct SurfaceBsdf {
  MaterialType type;
  // +z of the shading frame: a reflecting model's shading normal on the side the ray came from, a
  // dielectric's outward shading normal (the side of the triangle's front face).
  Frame frame;
  Vec3f color;  // base colour, or Phong's diffuse colour, at the hit
  Vec3f specular;
  float metallic, roughness, ior, exponent;
  Transport transport;

  // The scattering of material `m` of colour `color` at a hit with `shading_normal` (on the side of
  // the geometric normal) of a ray travelling along `d`; photons carry importance.
  // `metal_rough`: its metalness and roughness there (metal_rough_at).
  CAUSTICA_HDI static SurfaceBsdf at(const DeviceMaterial& m, Vec3f color, Vec2f metal_rough,
                                     Vec3f shading_normal, Vec3f d, Transport transport) {
    SurfaceBsdf b;
    b.type = m.type;
    const bool flip = m.type != MaterialType::kDielectric && dot(d, shading_normal) > 0.0f;
    b.frame = Frame::from_normal(flip ? -shading_normal : shading_normal);
    b.color = color;
    b.specular = m.specular;
    b.metallic = metal_rough.x;
    b.roughness = metal_rough.y;
    b.ior = m.ior;
    b.exponent = m.exponent;
    b.transport = transport;
    return b;
  }

  // The scattering of material `m` where a ray along `d` meets `hit` (`sh` its surface), its maps
  // read through a ray cone `cone_width` wide there (0: the finest level).
  CAUSTICA_HDI static SurfaceBsdf at_hit(const ResidentSceneView& scene, const DeviceMaterial& m,
                                         const Hit& hit, const SurfaceHit& sh, Vec3f d,
                                         float cone_width, Transport transport) {
    return at(m, surface_color(scene, m, hit, d, cone_width),
              metal_rough_at(scene, m, hit, d, cone_width), sh.shading_normal, d, transport);
  }

  CAUSTICA_HDI Vec3f normal() const { return frame.n; }
  CAUSTICA_HDI Vec3f local(Vec3f w) const {
    return Vec3f(dot(w, frame.s), dot(w, frame.t), dot(w, frame.n));
  }

  CAUSTICA_HDI SurfaceSample world(const BsdfSample& s) const {
    if (!s.valid()) return SurfaceSample{};
    return {frame.to_world(s.wi), s.weight(), s.pdf, s.flags};
  }

  CAUSTICA_HDI MetallicRoughnessBsdf metallic_roughness() const {
    return {color, metallic, roughness};
  }
  CAUSTICA_HDI ModifiedPhongBsdf phong() const { return {color, specular, exponent}; }
  CAUSTICA_HDI RoughDielectricBsdf glass() const { return {ior, roughness, transport}; }

  CAUSTICA_HDI Vec3f f(Vec3f wo, Vec3f wi) const {
    const Vec3f o = local(wo), i = local(wi);
    switch (type) {
      case MaterialType::kMetallicRoughness:
        return metallic_roughness().f(o, i);
      case MaterialType::kPhong:
        return phong().f(o, i);
      default:
        return glass().f(o, i);
    }
  }

  CAUSTICA_HDI float pdf(Vec3f wo, Vec3f wi) const {
    const Vec3f o = local(wo), i = local(wi);
    switch (type) {
      case MaterialType::kMetallicRoughness:
        return metallic_roughness().pdf(o, i);
      case MaterialType::kPhong:
        return phong().pdf(o, i);
      default:
        return glass().pdf(o, i);
    }
  }

  // A direction from every lobe (`uc` choosing the lobe), its value and the mixture's density;
  // `wi` in world space.
  CAUSTICA_HDI SurfaceSample sample(Vec3f wo, float uc, float u0, float u1) const {
    const Vec3f o = local(wo);
    BsdfSample s;
    switch (type) {
      case MaterialType::kMetallicRoughness:
        s = metallic_roughness().sample(o, uc, u0, u1);
        break;
      case MaterialType::kPhong:
        s = phong().sample(o, uc, u0, u1);
        break;
      default:
        s = glass().sample(o, uc, u0, u1);
        break;
    }
    return world(s);
  }

  // A direction from the glossy lobes alone, with their value and density: how a camera path goes
  // on past the surface while the base's light comes from photons and shadow rays.
  CAUSTICA_HDI SurfaceSample sample_glossy(Vec3f wo, float uc, float u0, float u1) const {
    const Vec3f o = local(wo);
    BsdfSample s;
    switch (type) {
      case MaterialType::kMetallicRoughness:
        s = metallic_roughness().sample_specular(o, u0, u1);
        break;
      case MaterialType::kPhong:
        s = phong().sample_specular(o, u0, u1);
        break;
      default:
        s = glass().sample(o, uc, u0, u1);
        break;
    }
    return world(s);
  }

  // The glossy lobes alone, the ones sample_glossy draws from: their value and that density.
  CAUSTICA_HDI Vec3f glossy_f(Vec3f wo, Vec3f wi) const {
    const Vec3f o = local(wo), i = local(wi);
    switch (type) {
      case MaterialType::kMetallicRoughness:
        return metallic_roughness().specular_f(o, i);
      case MaterialType::kPhong:
        return phong().specular_f(o, i);
      default:
        return glass().f(o, i);
    }
  }
  CAUSTICA_HDI float glossy_pdf(Vec3f wo, Vec3f wi) const {
    const Vec3f o = local(wo), i = local(wi);
    switch (type) {
      case MaterialType::kMetallicRoughness:
        return metallic_roughness().distribution().reflection_pdf(o, i);
      case MaterialType::kPhong:
        return phong().specular_pdf(o, i);
      default:
        return glass().pdf(o, i);
    }
  }

  // The GGX alpha of the glossy lobes, or for Phong's cos^n lobe the alpha of the same width
  // (Walter et al. 2007: n = 2 / alpha^2 - 2).
  CAUSTICA_HDI float glossy_alpha() const {
    if (type == MaterialType::kPhong) return sqrtf(2.0f / (exponent + 2.0f));
    return roughness * roughness;
  }
  // Whether the glossy lobes are narrower than `threshold` (kNearSpecularAlpha by default).
  CAUSTICA_HDI bool near_specular(float threshold) const { return glossy_alpha() < threshold; }

  // The diffuse base, f_base(wo, wi) = base_albedo(wo) base_in(wi) / pi: black for glass and for a
  // pure metal. Photons are stored with base_in of the way they came (photon_tracer.cc), so that
  // the density weighed by base_albedo(wo) is the base's reflected light.
  CAUSTICA_HDI Vec3f base_albedo(Vec3f wo) const {
    switch (type) {
      case MaterialType::kMetallicRoughness:
        return metallic_roughness().base_albedo(local(wo));
      case MaterialType::kPhong:
        return color;
      default:
        return Vec3f(0.0f);
    }
  }
  CAUSTICA_HDI float base_in(Vec3f wi) const {
    return type == MaterialType::kMetallicRoughness ? metallic_roughness().base_in(local(wi))
                                                    : 1.0f;
  }
  // Whether the base reflects anything, so that photons are stored on the surface.
  CAUSTICA_HDI bool has_base() const {
    switch (type) {
      case MaterialType::kMetallicRoughness:
        return metallic < 1.0f;
      case MaterialType::kPhong:
        return !is_black(color);
      default:
        return false;
    }
  }
};

// Veach's power heuristic (beta = 2): the weight of a sample drawn with density `a` when another
// strategy draws the same with density `b`.
CAUSTICA_HDI float power_heuristic(float a, float b) {
  const float a2 = a * a, b2 = b * b;
  return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

// What a diffuse surface reflects of direct light towards the viewer: f |cos| for a light in
// direction `wi`, the same for every kind of light; an area light's density does not matter.
struct LambertReflection {
  Vec3f f;       // albedo / pi
  Vec3f normal;  // towards the viewer
  CAUSTICA_HDI Vec3f delta(Vec3f wi) const {
    const float c = dot(normal, wi);
    return c > 0.0f ? f * c : Vec3f(0.0f);
  }
  CAUSTICA_HDI Vec3f area(Vec3f wi, float) const { return delta(wi); }
};

// What a camera path's hit on a sampled model reflects of direct light towards `wo`, f |cos|:
// every lobe for a point, spot or directional light, which nothing else finds. For an area light
// met in direction wi by a shadow ray drawn with solid-angle density `light_pdf`, the base whole
// and the glossy lobes weighed by the power heuristic against the path's own glossy continuation,
// which may meet the same light (glossy_emission_weight); `light_samples` is how many shadow rays
// the hit sends to area lights, or 0 where no path goes on (the glossy lobes' share then comes
// from the shadow rays alone). With `glossy_by_path`, a near-specular lobe's path goes on and
// alone carries that share: the shadow rays see the base only, and a pure metal's none at all.
struct SurfaceReflection {
  SurfaceBsdf bsdf;
  Vec3f wo;
  float light_samples;
  bool glossy_by_path = false;
  CAUSTICA_HDI Vec3f delta(Vec3f wi) const {
    return bsdf.f(wo, wi) * fabsf(dot(bsdf.normal(), wi));
  }
  CAUSTICA_HDI Vec3f area(Vec3f wi, float light_pdf) const {
    const float c = fabsf(dot(bsdf.normal(), wi));
    Vec3f f(0.0f);
    if (!glossy_by_path) {
      float glossy_share = 1.0f;
      if (light_samples > 0.0f)
        glossy_share = power_heuristic(light_samples * light_pdf, bsdf.glossy_pdf(wo, wi));
      f = bsdf.glossy_f(wo, wi) * glossy_share;
    }
    if (dot(bsdf.normal(), wi) > 0.0f && bsdf.type != MaterialType::kDielectric)
      f += bsdf.base_albedo(wo) * (bsdf.base_in(wi) * kInvPi);
    return f * c;
  }
};

// What a camera path's hit on a sampled model reflects of direct light while its path goes on
// along the glossy lobes, with `light_samples` shadow rays to area lights: near-specular lobes
// (below `near_specular_alpha`) left to the path alone.
CAUSTICA_HDI SurfaceReflection reflection_on_path(const SurfaceBsdf& bsdf, Vec3f wo,
                                                  float light_samples, float near_specular_alpha) {
  return {bsdf, wo, light_samples, bsdf.near_specular(near_specular_alpha)};
}

// The density a camera path's glossy continuation drawn with density `pdf` carries to the MIS
// weights of the lights it meets (glossy_emission_weight, environment_seen): 0 after a
// near-specular lobe, whose hit sent no shadow rays that could have found them.
CAUSTICA_HDI float continuation_pdf(const SurfaceBsdf& bsdf, float pdf, float near_specular_alpha) {
  return bsdf.near_specular(near_specular_alpha) ? 0.0f : pdf;
}

// The solid-angle density with which a shadow ray chooses a direction that meets area light `a`
// (an index into scene.area_lights) at squared distance `dist2` with cosine `cos_light` there.
CAUSTICA_HDI float area_light_pdf(const ResidentSceneView& scene, uint32_t a, float dist2,
                                  float cos_light) {
  const float choice = scene.area_light_cdf[a + 1] - scene.area_light_cdf[a];
  return choice * dist2 / (cos_light * scene.lights[scene.area_lights[a]].area);
}

// The weight of an area light's emission that a camera path's glossy continuation met, drawn with
// density `glossy_pdf` (0 for any other way there), against the `light_samples` shadow rays of
// the hit it left: the other half of SurfaceReflection's power heuristic.
CAUSTICA_HDI float glossy_emission_weight(const ResidentSceneView& scene, float glossy_pdf,
                                          float light_samples, const Hit& hit, float cos_light) {
  if (!(glossy_pdf > 0.0f) || !(light_samples > 0.0f)) return 1.0f;
  const uint32_t a = scene.triangle_area_light[hit.triangle];
  if (a == kNoAreaLight) return 1.0f;
  return power_heuristic(glossy_pdf,
                         light_samples * area_light_pdf(scene, a, hit.t * hit.t, cos_light));
}

// The environment's radiance along `d`, a camera path's ray that left the scene, weighed like
// glossy_emission_weight's area lights when a glossy lobe drew it with density `glossy_pdf` (0 for
// any other way there) against the `light_samples` shadow rays to the environment of the hit it
// left. Black without an environment.
CAUSTICA_HDI Vec3f environment_seen(const ResidentSceneView& scene, Vec3f d, float glossy_pdf,
                                    float light_samples) {
  if (!scene.has_environment) return Vec3f(0.0f);
  const Vec3f radiance = scene.environment.radiance(d);
  if (!(glossy_pdf > 0.0f) || !(light_samples > 0.0f)) return radiance;
  return radiance * power_heuristic(glossy_pdf, light_samples * scene.environment.pdf(d));
}

}  // namespace caustica
