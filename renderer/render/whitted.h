// The Whitted integrator with photon-mapped indirect light (Zeidan 2011 ch. 5-6): camera rays
// follow mirror and dielectric chains (both Fresnel branches, depth-first) and end at the first
// diffuse hit, where direct light comes from shadow rays and caustic and indirect diffuse light
// from the two photon maps.
#pragma once

#include "renderer/base/rng.h"
#include "renderer/parallel/backend.h"
#include "renderer/photon/density_kernel.h"
#include "renderer/photon/volume_map.h"
#include "renderer/render/camera.h"
#include "renderer/render/film.h"
#include "renderer/resident/cutouts.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/resident/surface_bsdf.h"

namespace caustica {

constexpr uint32_t kMaxSpecularDepth = 64;

// Russian roulette on camera paths through mirrors and glass: a branch spawned from depth
// kBranchRouletteFrom on goes on with probability min(its throughput's largest channel,
// kBranchSurvival) and its throughput divided by that, so deep paths are pruned without bias and
// the depth cap is only a safety net. The cap below 1 ends the lossless chains too (total internal
// reflection inside a faceted glass sphere), but each survival multiplies such a chain's weight by
// 1 / kBranchSurvival, so a low cap makes fireflies; the shallower branches are all followed:
// pruned there, the gathers' remaining requests cost more than the dropped ones saved
// (docs/convergence.md, "Path length").
constexpr uint32_t kBranchRouletteFrom = 6;
constexpr float kBranchSurvival = 0.8f;

struct ShadingSettings {
  uint32_t k_nearest = 64;
  float max_radius = 1.0f;
  DensityKernel kernel = DensityKernel::kEpanechnikov;
  uint32_t max_depth = kMaxSpecularDepth;
  uint32_t area_light_samples = 4;
  uint32_t seed = 1;
  uint32_t pass = 0;
  // Room for gather requests made ready before a pass, per pixel; a pass that needs more walks
  // its specular trees again with exactly enough, so this changes speed, never the image.
  uint32_t gather_requests_per_pixel = 4;
  // Walk the specular paths as ray queues (batches of closest and any hits) even where the
  // structure answers single rays; structures that answer batches only always do. The image is
  // the same either way.
  bool ray_queues = false;
  // The most a deep camera branch survives Russian roulette with (kBranchSurvival); 1 leaves
  // lossless branches to the depth cap, 0 ends every branch at kBranchRouletteFrom. A tuning knob
  // of the benchmark's.
  float branch_survival = kBranchSurvival;
  // The GGX alpha below which a glossy lobe is near-specular (kNearSpecularAlpha): its light from
  // area lights and the environment comes from the pixel's branch alone. 0 sends shadow rays
  // through every lobe, as the image converges to the same either way; a knob of the tests'.
  float near_specular_alpha = kNearSpecularAlpha;
  // The pass's volume photon map, which camera rays through media gather from (the beam radiance
  // estimate); empty when the scene has no media.
  VolumeMapView volume{};
};

// A diffuse hit of a camera path, waiting for the photon maps' estimate of its indirect light.
struct GatherRequest {
  Vec3f position;
  Vec3f normal;  // towards the viewer
  Vec3f weight;  // path throughput times albedo
  uint32_t pixel;
  uint32_t order;  // among its pixel's requests, in the order the specular tree met them
};

// A pass's gather requests as its gather stage reads them.
struct GatherRequests {
  const GatherRequest* requests;  // in the order the walks appended them
  const uint32_t* by_code;        // indices into `requests`, in Hilbert order of their positions
  const uint32_t* pixel_offsets;  // where each pixel's estimates start in the output
  uint32_t count;
};

// Stage 4 of the render pass, where estimators differ (estimator/): the light the photon maps
// give every request, caustic and diffuse, times its weight, written for request q to
// gathered[pixel_offsets[q.pixel] + q.order]. Called once per pass on the host.
class RadianceGather {
 public:
  virtual ~RadianceGather() = default;
  virtual void gather(Backend& backend, const GatherRequests& requests,
                      const ShadingSettings& settings, Vec3f* gathered) const = 0;
};

// Renders one pass (one jittered sample per pixel) and adds it to the film, as a wavefront:
// camera rays (accel/camera_tiles.h); per pixel the specular tree with emitted and direct light,
// which leaves one gather request per diffuse hit; the requests in Hilbert order and `gather`'s
// estimates of them; and per pixel the sum of its requests' estimates.
// `requests`, when given, gets the pass's gather requests (diffuse hits of the specular trees).
void render_pass(Backend& backend, const ResidentScene& scene, const PinholeCamera& camera,
                 const ShadingSettings& settings, const RadianceGather& gather, Film& film,
                 uint32_t* requests = nullptr);

// The point, spot and directional lights: the first of scene.lights, whose environment (when
// there is one) and area lights (one per emitting triangle, thousands for a model that glows)
// follow them (ResidentScene::new_lighting).
CAUSTICA_HDI uint32_t delta_light_count(const ResidentSceneView& scene) {
  return scene.light_count - scene.area_light_count - (scene.has_environment ? 1u : 0u);
}

// Shadow rays direct_light_with may ask for at one point: one per point, spot or directional
// light (slot = the light's index), one per area sample (slot = delta_light_count + sample) and,
// with an environment, one per environment sample, as many as area samples (slot =
// delta_light_count + area_samples + sample).
CAUSTICA_HDI uint32_t direct_light_slots(const ResidentSceneView& scene, uint32_t area_samples) {
  return delta_light_count(scene) + (scene.has_environment ? 2u : 1u) * area_samples;
}

// Sample dimensions direct_light_with draws at one point, whatever its shadow rays find: three
// per area sample when there are area lights, two per environment sample. A wavefront that shades
// a path's diffuse hits out of order starts each one's sampler this far past the previous one's.
CAUSTICA_HDI uint32_t direct_light_dimensions(const ResidentSceneView& scene,
                                              uint32_t area_samples) {
  return (scene.area_light_count > 0 ? 3 * area_samples : 0) +
         (scene.has_environment ? 2 * area_samples : 0);
}

// How far a shadow ray to the environment or a directional light goes: out of the scene's
// bounding sphere from any point inside it.
CAUSTICA_HDI float distance_to_outside(float scene_radius) { return 4.0f * scene_radius; }

// A point drawn uniformly on an area light chosen by power (three sample dimensions), as a
// shadow ray from `p` aims at it.
struct AreaLightPoint {
  uint32_t index;  // into scene.area_lights and scene.area_light_cdf
  const DeviceLight* light;
  Vec3f position;
  Vec3f wi;          // unit, from p to the point
  float dist2;       // squared distance from p
  float cos_light;   // at the light, towards p (its front faces p when positive)
  float choice_pdf;  // of choosing this light
  Vec3f radiance;    // what the light emits at the point
};

// The probability of choosing area light `a` (an index into scene.area_lights) by power.
CAUSTICA_HDI float area_light_choice_pdf(const ResidentSceneView& scene, uint32_t a) {
  return scene.area_light_cdf[a + 1] - scene.area_light_cdf[a];
}

CAUSTICA_HDI AreaLightPoint draw_area_light_point(const ResidentSceneView& scene, Vec3f p,
                                                  Sampler& s) {
  AreaLightPoint y;
  float u = s.next_float();
  y.index = ResidentSceneView::sample_cdf(scene.area_light_cdf, scene.area_light_count, u);
  y.light = &scene.lights[scene.area_lights[y.index]];
  y.choice_pdf = area_light_choice_pdf(scene, y.index);
  Vec2f b = sample_uniform_triangle(s.next_float(), s.next_float());
  y.position = y.light->position + y.light->edge1 * b.x + y.light->edge2 * b.y;
  y.radiance = area_light_radiance(scene, *y.light, b);
  Vec3f d = y.position - p;
  y.dist2 = length_squared(d);
  float dist = sqrtf(y.dist2);
  y.wi = d / dist;
  y.cos_light = -dot(y.light->direction, y.wi);
  return y;
}

// The way from `p` to a point, spot or directional light: the unit direction, a point to aim a
// shadow ray at (for a directional light, one outside the scene), its distance, and the factor
// that turns the light's colour into irradiance at p facing it (1 / r^2 and the spot's falloff).
struct WayToLight {
  Vec3f wi, light_point;
  float dist, scale;
};

CAUSTICA_HDI WayToLight way_to_light(const DeviceLight& l, Vec3f p, float scene_radius) {
  WayToLight way;
  if (l.type == DeviceLightType::kDirectional) {
    way.wi = -l.direction;
    way.dist = distance_to_outside(scene_radius);
    way.light_point = p + way.wi * way.dist;
    way.scale = 1.0f;
    return way;
  }
  const Vec3f d = l.position - p;
  way.dist = length(d);
  way.light_point = l.position;
  way.wi = d / way.dist;
  way.scale = 1.0f / (way.dist * way.dist);
  if (l.type == DeviceLightType::kSpot) way.scale *= spot_falloff(l, -way.wi);
  return way;
}

// Direct light at a point of a camera path: every point, spot and directional light with one
// shadow ray each, `area_samples` shadow rays to area lights chosen by power and as many to the
// environment's directions drawn by its luminance, each weighed by what `reflection`
// (LambertReflection, SurfaceReflection) gives for its direction, f |cos|.
// `visible(slot, ray)` says whether the shadow ray `ray` (slot: direct_light_slots) reaches its
// light. In `medium`, each light's share is attenuated by the transmittance of the way to it.
// kEnvironment false compiles the environment's samples out, for launches over scenes without
// one (docs/performance.md, "Launches by what the scene has"); the slots and sample dimensions
// stay those of the scene, which has none to draw.
template <bool kEnvironment = true, typename Reflection, typename Visible>
CAUSTICA_HDI Vec3f direct_light_by(const ResidentSceneView& scene, Vec3f p, Vec3f geometric_normal,
                                   const Reflection& reflection, uint32_t area_samples,
                                   float scene_radius, Sampler& s, Visible visible_slot,
                                   uint32_t medium = kVacuum) {
  Vec3f sum(0.0f);
  // Shadow rays stop just short of the light so that an area light's own triangle never blocks.
  auto visible = [&](uint32_t slot, Vec3f light_point, Vec3f wi) {
    return visible_slot(slot,
                        shadow_ray(offset_origin(p, geometric_normal, wi), light_point, 1e-3f));
  };
  for (uint32_t i = 0; i < delta_light_count(scene); ++i) {
    const DeviceLight& l = scene.lights[i];
    const WayToLight way = way_to_light(l, p, scene_radius);
    const Vec3f f_cos = reflection.delta(way.wi);
    if (is_black(f_cos) || way.scale <= 0.0f) continue;
    if (visible(i, way.light_point, way.wi))
      sum += f_cos * l.color * transmittance_along(scene.media, medium, p, way.wi, way.dist) *
             way.scale;
  }
  if (scene.area_light_count > 0 && area_samples > 0) {
    Vec3f area_sum(0.0f);
    for (uint32_t k = 0; k < area_samples; ++k) {
      const AreaLightPoint y = draw_area_light_point(scene, p, s);
      const DeviceLight& l = *y.light;
      if (y.cos_light <= 0.0f || y.choice_pdf <= 0.0f) continue;
      const Vec3f f_cos =
          reflection.area(y.wi, area_light_pdf(scene, y.index, y.dist2, y.cos_light));
      if (is_black(f_cos)) continue;
      if (!visible(delta_light_count(scene) + k, y.position, y.wi)) continue;
      area_sum += f_cos * y.radiance *
                  transmittance_along(scene.media, medium, p, y.wi, sqrtf(y.dist2)) *
                  (y.cos_light * l.area / (y.dist2 * y.choice_pdf));
    }
    sum += area_sum / float(area_samples);
  }
  if (kEnvironment && scene.has_environment && area_samples > 0) {
    Vec3f environment_sum(0.0f);
    const uint32_t first_slot = delta_light_count(scene) + area_samples;
    const float dist = distance_to_outside(scene_radius);
    for (uint32_t k = 0; k < area_samples; ++k) {
      const float u0 = s.next_float();
      const EnvironmentSample e = scene.environment.sample(u0, s.next_float());
      if (!(e.pdf > 0.0f)) continue;
      const Vec3f f_cos = reflection.area(e.direction, e.pdf);
      if (is_black(f_cos)) continue;
      if (!visible(first_slot + k, p + e.direction * dist, e.direction)) continue;
      environment_sum += f_cos * e.radiance *
                         transmittance_along(scene.media, medium, p, e.direction, dist) / e.pdf;
    }
    sum += environment_sum / float(area_samples);
  }
  return sum;
}

// Direct light at a diffuse point of albedo `albedo`; `normal` faces the viewer.
template <typename Visible>
CAUSTICA_HDI Vec3f direct_light_with(const ResidentSceneView& scene, Vec3f p, Vec3f normal,
                                     Vec3f geometric_normal, Vec3f albedo, uint32_t area_samples,
                                     float scene_radius, Sampler& s, Visible visible_slot,
                                     uint32_t medium = kVacuum) {
  return direct_light_by(scene, p, geometric_normal, LambertReflection{albedo * kInvPi, normal},
                         area_samples, scene_radius, s, visible_slot, medium);
}

// A hit's material for reflected_at: kLambertHit for a diffuse one, else a sampled model's index.
constexpr uint32_t kLambertHit = 0xffffffffu;

// What a hit that waits for its direct light reflects: `direct(reflection)` given a
// LambertReflection of `albedo` (a diffuse hit) or the SurfaceReflection of material `sampled` of
// colour `albedo` and metalness and roughness `metal_rough` towards `wo`, whose frame's normal is
// `normal` (reflection_on_path's with `light_samples` and `near_specular_alpha`; light_samples 0
// where no path goes on); `weight` gets what its gather request weighs the photons' density by
// (albedo, or the base's albedo towards wo).
template <typename Direct>
CAUSTICA_HDI Vec3f reflected_at(const ResidentSceneView& scene, uint32_t sampled, Vec3f albedo,
                                Vec2f metal_rough, Vec3f normal, Vec3f wo, float light_samples,
                                float near_specular_alpha, Vec3f& weight, Direct direct) {
  if (sampled == kLambertHit) {
    weight = albedo;
    return direct(LambertReflection{albedo * kInvPi, normal});
  }
  const SurfaceBsdf bsdf = SurfaceBsdf::at(scene.materials[sampled], albedo, metal_rough, normal,
                                           -wo, Transport::kRadiance);
  const SurfaceReflection r = light_samples > 0.0f
                                  ? reflection_on_path(bsdf, wo, light_samples, near_specular_alpha)
                                  : SurfaceReflection{bsdf, wo, 0.0f};
  weight = r.bsdf.base_albedo(wo);
  return direct(r);
}

// direct_light_by, each shadow ray traced on the spot through `structure` (a StructureView).
// kCutouts: surface_blocks'.
template <bool kEnvironment = true, bool kCutouts = true, typename Structure, typename Reflection>
CAUSTICA_HDI Vec3f direct_light_traced(const ResidentSceneView& scene, const Structure& structure,
                                       Vec3f p, Vec3f geometric_normal,
                                       const Reflection& reflection, uint32_t area_samples,
                                       float scene_radius, Sampler& s, uint32_t medium = kVacuum) {
  return direct_light_by<kEnvironment>(
      scene, p, geometric_normal, reflection, area_samples, scene_radius, s,
      [&](uint32_t, const Ray& shadow) {
        return !surface_blocks<kCutouts>(structure, scene, shadow);
      },
      medium);
}

// direct_light_with, each shadow ray traced on the spot through `structure` (a StructureView).
template <bool kEnvironment = true, bool kCutouts = true, typename Structure>
CAUSTICA_HDI Vec3f direct_light(const ResidentSceneView& scene, const Structure& structure, Vec3f p,
                                Vec3f normal, Vec3f geometric_normal, Vec3f albedo,
                                uint32_t area_samples, float scene_radius, Sampler& s,
                                uint32_t medium = kVacuum) {
  return direct_light_traced<kEnvironment, kCutouts>(scene, structure, p, geometric_normal,
                                           LambertReflection{albedo * kInvPi, normal}, area_samples,
                                           scene_radius, s, medium);
}

}  // namespace caustica
