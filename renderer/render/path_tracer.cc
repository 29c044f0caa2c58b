#include "renderer/render/path_tracer.h"

#include <stdexcept>
#include <string>
#include <type_traits>

#include "renderer/accel/ray_queries.h"
#include "renderer/base/rng.h"
#include "renderer/base/sampling.h"
#include "renderer/material/fresnel.h"
#include "renderer/medium/medium.h"
#include "renderer/parallel/parallel_for.h"
#include "renderer/render/visible_points.h"
#include "renderer/render/whitted.h"
#include "renderer/resident/cutouts.h"

namespace caustica {
namespace {

// One shadow ray from `p`, inside `medium`, to a point drawn on an area light chosen by power,
// weighed against the path's own sampling that could have found the same point: `value(wi)` is
// what the path scatters light from wi by (f |cos| off a surface, the phase function in a medium)
// and `pdf(wi)` the solid-angle density with which it samples wi; `shadow_origin(wi)` where the
// shadow ray starts. The shadow ray stops just short of the light, whose own triangle must not
// block it, and its light is attenuated by the transmittance of the way.
template <typename Structure, typename Value, typename Pdf, typename ShadowOrigin>
CAUSTICA_HDI Vec3f sample_area_light(const ResidentSceneView& scene, const Structure& structure,
                                     Vec3f p, uint32_t medium, Sampler& s, Value value, Pdf pdf,
                                     ShadowOrigin shadow_origin) {
  const AreaLightPoint y = draw_area_light_point(scene, p, s);
  if (!(y.dist2 > 0.0f) || y.cos_light <= 0.0f) return Vec3f(0.0f);
  const Vec3f f = value(y.wi);
  if (is_black(f)) return Vec3f(0.0f);
  const float light_pdf = area_light_pdf(scene, y.index, y.dist2, y.cos_light);
  if (!(light_pdf > 0.0f)) return Vec3f(0.0f);
  if (surface_blocks(structure, scene, shadow_ray(shadow_origin(y.wi), y.position, 1e-3f)))
    return Vec3f(0.0f);
  return y.radiance * transmittance_along(scene.media, medium, p, y.wi, sqrtf(y.dist2)) * f *
         (power_heuristic(light_pdf, pdf(y.wi)) / light_pdf);
}

// One shadow ray from `p`, inside `medium`, towards a direction drawn from the environment by its
// luminance, weighed as sample_area_light's against the path's own sampling.
template <typename Structure, typename Value, typename Pdf, typename ShadowOrigin>
CAUSTICA_HDI Vec3f sample_environment(const ResidentSceneView& scene, const Structure& structure,
                                      Vec3f p, uint32_t medium, float scene_radius, Sampler& s,
                                      Value value, Pdf pdf, ShadowOrigin shadow_origin) {
  const float u0 = s.next_float();
  const EnvironmentSample e = scene.environment.sample(u0, s.next_float());
  if (!(e.pdf > 0.0f)) return Vec3f(0.0f);
  const Vec3f f = value(e.direction);
  if (is_black(f)) return Vec3f(0.0f);
  const float dist = distance_to_outside(scene_radius);
  if (surface_blocks(structure, scene,
                     shadow_ray(shadow_origin(e.direction), p + e.direction * dist, 0.0f)))
    return Vec3f(0.0f);
  return e.radiance * transmittance_along(scene.media, medium, p, e.direction, dist) * f *
         (power_heuristic(e.pdf, pdf(e.direction)) / e.pdf);
}

// One shadow ray to an area light and one to the environment, where the scene has them, from
// `p` as sample_area_light's and sample_environment's.
template <typename Structure, typename Value, typename Pdf, typename ShadowOrigin>
CAUSTICA_HDI Vec3f sample_lights(const ResidentSceneView& scene, const Structure& structure,
                                 Vec3f p, uint32_t medium, float scene_radius, Sampler& s,
                                 Value value, Pdf pdf, ShadowOrigin shadow_origin) {
  Vec3f sum(0.0f);
  if (scene.area_light_count > 0)
    sum += sample_area_light(scene, structure, p, medium, s, value, pdf, shadow_origin);
  if (scene.has_environment)
    sum +=
        sample_environment(scene, structure, p, medium, scene_radius, s, value, pdf, shadow_origin);
  return sum;
}

// The light scattered at `x`, inside `medium`, towards where `travel` came from: one shadow ray
// to every point, spot and directional light, one to a point on an area light and one to the
// environment, the latter two weighed against the phase function's sampling that could have found
// the same light. Each is attenuated by the transmittance of its way through the medium.
template <typename Structure>
CAUSTICA_HDI Vec3f scattered_light(const ResidentSceneView& scene, const Structure& structure,
                                   Vec3f x, Vec3f travel, uint32_t medium, float scene_radius,
                                   Sampler& s) {
  const float g = scene.media.media[medium].g;
  Vec3f sum(0.0f);
  for (uint32_t i = 0; i < delta_light_count(scene); ++i) {
    const DeviceLight& l = scene.lights[i];
    const WayToLight way = way_to_light(l, x, scene_radius);
    if (!(way.scale > 0.0f)) continue;
    if (surface_blocks(structure, scene, shadow_ray(x, way.light_point, 1e-3f))) continue;
    sum += l.color * transmittance_along(scene.media, medium, x, way.wi, way.dist) *
           (henyey_greenstein(dot(way.wi, travel), g) * way.scale);
  }
  const auto phase = [&](Vec3f wi) { return henyey_greenstein(dot(wi, travel), g); };
  return sum + sample_lights(
                   scene, structure, x, medium, scene_radius, s,
                   [&](Vec3f wi) { return Vec3f(phase(wi)); }, phase, [&](Vec3f) { return x; });
}

// Russian roulette after bounce `bounce`: whether the path goes on, its throughput rescaled.
CAUSTICA_HDI bool survives_roulette(uint32_t bounce, Vec3f& throughput, Sampler& s) {
  if (bounce + 1 < kPathRouletteFrom) return true;
  const float survive = min_f(kPathSurvivalCap, max_component(throughput));
  if (!(s.next_float() < survive)) return false;
  throughput = throughput / survive;
  return true;
}

// The radiance a path from the camera along `ray` carries back.
template <typename Structure>
CAUSTICA_HDI Vec3f trace_path(const ResidentSceneView& scene, const Structure& structure, Ray ray,
                              float scene_radius, Sampler& s) {
  Vec3f radiance(0.0f), throughput(1.0f);
  // The solid-angle pdf of the last bounce's direction when it was a diffuse one, else 0: a light
  // met after it is weighed against the shadow ray that could have found it.
  float bounce_pdf = 0.0f;
  // The camera stands outside every shape: in the scene-wide medium, where there is one.
  uint32_t medium = scene.media.scene_medium;
  for (uint32_t bounce = 0; bounce < kPathSafetyBounces; ++bounce) {
    const Hit hit = closest_surface_hit(structure, scene, ray);
    if (medium != kVacuum) {
      // A collision before the surface scatters the path there instead.
      const DeviceMedium& md = scene.media.media[medium];
      const MediumSpan span = medium_span(scene.media, medium, ray.origin, ray.direction, hit.t);
      const FreeFlight flight =
          sample_free_flight(md, ray.origin, ray.direction, span, [&] { return s.next_float(); });
      throughput *= flight.weight;
      if (flight.collided) {
        const Vec3f x = ray.origin + ray.direction * flight.t;
        throughput *= md.albedo;
        radiance += throughput *
                    scattered_light(scene, structure, x, ray.direction, medium, scene_radius, s);
        const Vec3f wi =
            sample_henyey_greenstein(ray.direction, md.g, s.next_float(), s.next_float());
        bounce_pdf = henyey_greenstein(dot(wi, ray.direction), md.g);  // f / pdf = 1
        ray = Ray{};
        ray.origin = x;
        ray.direction = wi;
        if (!survives_roulette(bounce, throughput, s)) break;
        continue;
      }
    }
    if (!hit.valid()) {
      // The environment, weighed against the shadow ray that could have found the same direction.
      radiance += throughput * environment_seen(scene, ray.direction, bounce_pdf, 1.0f);
      break;
    }
    const SurfaceHit sh = surface_at(scene, hit);
    const DeviceMaterial& m = scene.materials[sh.material];
    const Vec3f d = ray.direction;
    // Any surface may emit from its front face.
    if (!is_black(m.radiance)) {
      const float cos_light = -dot(d, sh.geometric_normal);
      if (cos_light > 0.0f) {
        float weight = 1.0f;
        const uint32_t a = scene.triangle_area_light[hit.triangle];
        if (bounce_pdf > 0.0f && a != kNoAreaLight)
          weight = power_heuristic(bounce_pdf, area_light_pdf(scene, a, hit.t * hit.t, cos_light));
        radiance += throughput * surface_emission(scene, m, hit, d, 0.0f) * weight;
      }
    }
    if (m.type == MaterialType::kEmissive) break;  // lights do not reflect
    if (is_sampled_model(m)) {
      const SurfaceBsdf bsdf =
          SurfaceBsdf::at_hit(scene, m, hit, sh, d, 0.0f, Transport::kRadiance);
      const Vec3f wo = -d;
      // Point, spot and directional lights through every lobe, then an area light weighed
      // against the BSDF's own sampling.
      radiance += throughput * direct_light_traced(
                                   scene, structure, sh.position, sh.geometric_normal,
                                   SurfaceReflection{bsdf, wo, 0.0f}, 0, scene_radius, s, medium);
      radiance +=
          throughput *
          sample_lights(
              scene, structure, sh.position, medium, scene_radius, s,
              [&](Vec3f wi) { return bsdf.f(wo, wi) * fabsf(dot(bsdf.normal(), wi)); },
              [&](Vec3f wi) { return bsdf.pdf(wo, wi); },
              [&](Vec3f wi) { return offset_origin(sh.position, sh.geometric_normal, wi); });
      const float uc = s.next_float(), u0 = s.next_float();
      const SurfaceSample b = bsdf.sample(wo, uc, u0, s.next_float());
      if (!b.valid()) break;
      const bool transmits = (b.flags & kBsdfTransmission) != 0;
      // A direction on the wrong side of the triangle itself would leak through it.
      if ((dot(b.wi, sh.geometric_normal) * dot(d, sh.geometric_normal) < 0.0f) == transmits) break;
      throughput *= b.weight;
      bounce_pdf = b.pdf;
      if (transmits)
        medium = medium_after_crossing(scene.media, hit.triangle, d, sh.geometric_normal);
      ray = Ray{};
      ray.origin = offset_origin(sh.position, sh.geometric_normal, b.wi);
      ray.direction = b.wi;
      if (!survives_roulette(bounce, throughput, s)) break;
      continue;
    }
    // The reference reads the finest level of a map at every hit: its samples average the pixel.
    switch (m.type) {
      case MaterialType::kDiffuse: {
        const Vec3f color = surface_color(scene, m, hit, d, 0.0f);
        const Vec3f n = dot(d, sh.shading_normal) < 0.0f ? sh.shading_normal : -sh.shading_normal;
        const Vec3f ng =
            dot(d, sh.geometric_normal) < 0.0f ? sh.geometric_normal : -sh.geometric_normal;
        // Point, spot and directional lights: a shadow ray each (no area samples here).
        radiance += throughput * direct_light(scene, structure, sh.position, n, ng, color, 0,
                                              scene_radius, s, medium);
        // The cosine density, none below the shading normal's horizon: a light there gives none.
        const auto density = [&](Vec3f wi) { return max_f(0.0f, dot(n, wi)) * kInvPi; };
        radiance += throughput * color *
                    sample_lights(
                        scene, structure, sh.position, medium, scene_radius, s,
                        [&](Vec3f wi) { return Vec3f(density(wi)); }, density,
                        [&](Vec3f wi) { return offset_origin(sh.position, ng, wi); });
        const Vec3f local = sample_cosine_hemisphere(s.next_float(), s.next_float());
        const Vec3f wi = Frame::from_normal(n).to_world(local);
        // A direction under the surface itself (a shading normal tilted from the geometric one)
        // would leak through it.
        if (local.z <= 0.0f || dot(wi, ng) <= 0.0f) return radiance;
        bounce_pdf = local.z * kInvPi;
        throughput *= color;  // f cos / pdf = (albedo / pi) cos / (cos / pi)
        ray = Ray{};
        ray.origin = offset_origin(sh.position, sh.geometric_normal, wi);
        ray.direction = wi;
        break;
      }
      case MaterialType::kMirror: {
        const Vec3f r = reflect(d, sh.shading_normal);
        throughput *= surface_color(scene, m, hit, d, 0.0f);
        bounce_pdf = 0.0f;
        ray = Ray{};
        ray.origin = offset_origin(sh.position, sh.geometric_normal, r);
        ray.direction = r;
        break;
      }
      case MaterialType::kDielectric: {
        // One branch, drawn by the Fresnel reflectance, so the weight is 1 either way.
        const DielectricSide side = dielectric_side(d, sh.shading_normal, m.ior);
        const float fr = fresnel_dielectric(side.cos_i, side.eta);
        Vec3f next = reflect(d, side.normal);
        Vec3f refracted;
        if (s.next_float() >= fr && refract(d, side.normal, side.eta, refracted)) {
          next = refracted;
          medium = medium_after_crossing(scene.media, hit.triangle, d, sh.geometric_normal);
        }
        bounce_pdf = 0.0f;
        ray = Ray{};
        ray.origin = offset_origin(sh.position, sh.geometric_normal, next);
        ray.direction = next;
        break;
      }
      default:  // emissive, or a sampled model (above)
        break;
    }
    if (!survives_roulette(bounce, throughput, s)) break;
  }
  return radiance;
}

// One pass's paths through `structure`, a view that answers single rays, added to `accum`. (A
// named function: nvcc admits no extended lambda inside the generic one that visits the views.)
template <typename Structure>
void trace_paths_through(const Structure& structure, Backend& backend,
                         const ResidentSceneView& scene, float scene_radius,
                         const PinholeCamera& camera, const PathSettings& settings, Vec3f* accum) {
  const size_t pixels = size_t(camera.width) * camera.height;
  const uint32_t seed = settings.seed, pass = settings.pass;
  parallel_for(backend, "path_trace", pixels, [=] CAUSTICA_HD(size_t pixel) {
    Sampler s(seed, camera.stream(pixel), pass);
    const float jx = s.next_float();
    const Ray ray = camera.pixel_ray(pixel, jx, s.next_float());
    accum[pixel] += trace_path(scene, structure, ray, scene_radius, s);
  });
}

}  // namespace

void render_path_pass(Backend& backend, const ResidentScene& resident, const PinholeCamera& camera,
                      const PathSettings& settings, Film& film) {
  const ResidentSceneView scene = resident.view();
  const float scene_radius = resident.radius();
  Vec3f* accum = film.accumulator();
  resident.structure().visit([&](const auto& structure) {
    if constexpr (StructureView<std::decay_t<decltype(structure)>>) {
      trace_paths_through(structure, backend, scene, scene_radius, camera, settings, accum);
    } else {
      throw batch_only_refusal("the path integrator", resident.structure().kind());
    }
  });
  film.add_pass();
}

}  // namespace caustica
