#include "renderer/render/visible_points.h"

#include <stdexcept>
#include <string>
#include <type_traits>

#include "renderer/accel/ray_queries.h"
#include "renderer/base/pixel_blocks.h"
#include "renderer/base/rng.h"
#include "renderer/material/fresnel.h"
#include "renderer/parallel/parallel_for.h"
#include "renderer/render/path_tracer.h"
#include "renderer/render/whitted.h"

namespace caustica {
namespace {

// Where one pixel's chain stands between its hits.
struct Chain {
  Ray ray;
  Vec3f throughput;
  Vec3f light;  // emitted and direct light seen so far
  Sampler s;
  uint32_t depth;
  float glossy_pdf;  // the density the ray was drawn with off a glossy surface, else 0
};

// The chain's first ray: the pixel's jittered camera ray (the sampler's first two dimensions).
CAUSTICA_HDI Chain start_chain(const PinholeCamera& camera, const VisiblePointSettings& cfg,
                               size_t pixel) {
  Sampler s(cfg.seed, camera.stream(pixel), cfg.pass);
  const float jx = s.next_float();
  const Ray ray = camera.pixel_ray(pixel, jx, s.next_float());
  return {ray, Vec3f(1.0f), Vec3f(0.0f), s, 0, 0.0f};
}

// The chain's hit `hit` of its current ray: true when the chain goes on (its next ray set), false
// when it ended, at a light, in the environment or at a diffuse surface, which becomes `point`.
// `direct(sh, reflection, s)` gives the direct light at a diffuse hit or one on a sampled model
// (whitted.h's direct_light_by). Maps are read at their finest level: each pass's jittered chains
// average the pixel, as the passes accumulate.
template <typename Direct>
CAUSTICA_HDI bool chain_step(const ResidentSceneView& scene, const Hit& hit,
                             const VisiblePointSettings& cfg, Chain& c, VisiblePoint& point,
                             Direct direct) {
  if (!hit.valid()) {
    c.light += c.throughput * environment_seen(scene, c.ray.direction, c.glossy_pdf,
                                               float(cfg.area_light_samples));
    return false;
  }
  const SurfaceHit sh = surface_at(scene, hit);
  const DeviceMaterial& m = scene.materials[sh.material];
  const Vec3f d = c.ray.direction;
  Vec3f next;
  // Any surface may emit from its front face; an emissive one does nothing else.
  const float cos_light = -dot(d, sh.geometric_normal);
  if (!is_black(m.radiance) && cos_light > 0.0f)
    c.light +=
        c.throughput * surface_emission(scene, m, hit, d, 0.0f) *
        glossy_emission_weight(scene, c.glossy_pdf, float(cfg.area_light_samples), hit, cos_light);
  c.glossy_pdf = 0.0f;
  if (is_sampled_model(m)) {
    const SurfaceBsdf bsdf = SurfaceBsdf::at_hit(scene, m, hit, sh, d, 0.0f, Transport::kRadiance);
    const Vec3f wo = -d;
    c.light += c.throughput * direct(sh,
                                     reflection_on_path(bsdf, wo, float(cfg.area_light_samples),
                                                        cfg.near_specular_alpha),
                                     c.s);
    // One point a pixel: the base's, with the probability of its share of what this hit reflects,
    // or else the chain goes on along the glossy lobes' direction. The share may depend on the
    // direction drawn, which is drawn first.
    const Vec3f base = bsdf.base_albedo(wo);
    const float uc = c.s.next_float(), u0 = c.s.next_float(), u1 = c.s.next_float();
    const SurfaceSample g = bsdf.sample_glossy(wo, uc, u0, u1);
    const float base_share = luminance(base);
    const float glossy_share = g.valid() ? luminance(g.weight) : 0.0f;
    const float stop =
        base_share + glossy_share > 0.0f ? base_share / (base_share + glossy_share) : 1.0f;
    if (c.s.next_float() < stop) {
      if (base_share > 0.0f) point = {sh.position, bsdf.normal(), c.throughput * base / stop};
      return false;
    }
    const bool transmits = (g.flags & kBsdfTransmission) != 0;
    if ((dot(g.wi, sh.geometric_normal) * dot(d, sh.geometric_normal) < 0.0f) == transmits)
      return false;
    c.throughput *= g.weight / (1.0f - stop);
    c.glossy_pdf = continuation_pdf(bsdf, g.pdf, cfg.near_specular_alpha);
    next = g.wi;
  } else {
    switch (m.type) {
      case MaterialType::kEmissive:
        return false;
      case MaterialType::kDiffuse: {
        const Vec3f n = dot(d, sh.shading_normal) < 0.0f ? sh.shading_normal : -sh.shading_normal;
        const Vec3f color = surface_color(scene, m, hit, d, 0.0f);
        c.light += c.throughput * direct(sh, LambertReflection{color * kInvPi, n}, c.s);
        point = {sh.position, n, c.throughput * color};
        return false;
      }
      case MaterialType::kMirror:
        next = reflect(d, sh.shading_normal);
        c.throughput *= surface_color(scene, m, hit, d, 0.0f);
        break;
      case MaterialType::kDielectric: {
        const DielectricSide side = dielectric_side(d, sh.shading_normal, m.ior);
        const float fr = fresnel_dielectric(side.cos_i, side.eta);
        next = reflect(d, side.normal);
        Vec3f refracted;
        if (c.s.next_float() >= fr && refract(d, side.normal, side.eta, refracted))
          next = refracted;
        break;
      }
      default:
        return false;
    }
  }
  if (c.depth >= cfg.max_depth) return false;
  // From the depth where the photon integrator's trees start their roulette (whitted.h), with
  // the path tracer's cap: one chain a pixel costs little, and a lower cap multiplies a lossless
  // chain's weight into fireflies that SPPM's statistics keep for many passes.
  if (c.depth >= kBranchRouletteFrom) {
    const float survive = min_f(max_component(c.throughput), kPathSurvivalCap);
    if (!(c.s.next_float() < survive)) return false;
    c.throughput = c.throughput / survive;
  }
  c.ray = Ray{};
  c.ray.origin = offset_origin(sh.position, sh.geometric_normal, next);
  c.ray.direction = next;
  ++c.depth;
  return true;
}

// The pass's chains through `structure`, a view that answers single rays, one per thread. (A
// named function: nvcc admits no extended lambda inside the generic one that visits the views.)
template <typename Structure>
void trace_chains_through(const Structure& structure, Backend& backend,
                          const ResidentSceneView& scene, float scene_radius,
                          const PinholeCamera& camera, const VisiblePointSettings& cfg,
                          VisiblePoint* points, Vec3f* light) {
  const PixelBlocks blocks(camera.width, camera.height);
  parallel_for(backend, "visible_points", blocks.thread_count(), [=] CAUSTICA_HD(size_t thread) {
    size_t pixel;
    if (!blocks.pixel_of(thread, pixel)) return;
    Chain c = start_chain(camera, cfg, pixel);
    VisiblePoint point{Vec3f(0.0f), Vec3f(0.0f), Vec3f(0.0f)};
    const auto direct = [&](const SurfaceHit& sh, const auto& reflection, Sampler& s) {
      return direct_light_traced(scene, structure, sh.position, sh.geometric_normal, reflection,
                                 cfg.area_light_samples, scene_radius, s);
    };
    while (chain_step(scene, closest_surface_hit(structure, scene, c.ray), cfg, c, point, direct)) {
    }
    points[pixel] = point;
    light[pixel] += c.light;
  });
}

// The same chains as ray queues, for structures that answer batches only: each wave one batch of
// closest hits for every live chain, then one of the shadow rays their diffuse hits ask for. A
// wave's step runs twice, first to collect the shadow rays on a copy of each chain, then for real
// with their answers, so every chain draws the samples the per-thread walk draws and meets the
// same points.
template <typename Structure>
void trace_chain_queues(const Structure& structure, Backend& backend,
                        const ResidentSceneView& scene, float scene_radius,
                        const PinholeCamera& camera, const VisiblePointSettings& cfg,
                        VisiblePoint* points, Vec3f* light) {
  const size_t pixels = size_t(camera.width) * camera.height;
  Buffer<Chain> chains(backend, pixels);
  Buffer<uint8_t> alive(backend, pixels);
  Buffer<uint32_t> live(backend, pixels);
  Buffer<Ray> rays(backend, pixels);
  Buffer<Hit> hits(backend, pixels);
  const uint32_t slots = direct_light_slots(scene, cfg.area_light_samples);
  Buffer<Ray> shadow(backend, 0);
  Buffer<uint8_t> blocked(backend, 0);
  Chain* chain = chains.data();
  uint8_t* on = alive.data();
  parallel_for(backend, "visible_point_chains", pixels, [=] CAUSTICA_HD(size_t pixel) {
    chain[pixel] = start_chain(camera, cfg, pixel);
    points[pixel] = {Vec3f(0.0f), Vec3f(0.0f), Vec3f(0.0f)};
    on[pixel] = 1;
  });
  size_t count = backend.select_flagged(nullptr, on, pixels, live.data());
  while (count > 0) {
    const uint32_t* index = live.data();
    Ray* ray = rays.data();
    parallel_for(backend, "visible_point_rays", count,
                 [=] CAUSTICA_HD(size_t i) { ray[i] = chain[index[i]].ray; });
    trace_closest_surfaces(backend, structure, scene, rays.data(), count, hits.data());
    shadow.resize_discard(count * slots);
    blocked.resize_discard(count * slots);
    const Hit* hit = hits.data();
    Ray* shadow_ray = shadow.data();
    parallel_for(backend, "visible_point_shadow_rays", count, [=] CAUSTICA_HD(size_t i) {
      Ray* mine = shadow_ray + i * slots;
      for (uint32_t k = 0; k < slots; ++k) mine[k] = Ray{Vec3f(0.0f), Vec3f(0, 0, 1), 0.0f, 0.0f};
      Chain copy = chain[index[i]];
      VisiblePoint unused;
      (void)chain_step(scene, hit[i], cfg, copy, unused,
                       [&](const SurfaceHit& sh, const auto& reflection, Sampler& s) {
                         return direct_light_by(scene, sh.position, sh.geometric_normal, reflection,
                                                cfg.area_light_samples, scene_radius, s,
                                                [&](uint32_t slot, const Ray& r) {
                                                  mine[slot] = r;
                                                  return false;
                                                });
                       });
    });
    trace_any_surfaces(backend, structure, scene, shadow.data(), count * slots, blocked.data());
    const uint8_t* is_blocked = blocked.data();
    parallel_for(backend, "visible_point_step", count, [=] CAUSTICA_HD(size_t i) {
      const uint32_t pixel = index[i];
      const uint8_t* mine = is_blocked + i * slots;
      Chain c = chain[pixel];
      on[pixel] = chain_step(scene, hit[i], cfg, c, points[pixel],
                             [&](const SurfaceHit& sh, const auto& reflection, Sampler& s) {
                               return direct_light_by(
                                   scene, sh.position, sh.geometric_normal, reflection,
                                   cfg.area_light_samples, scene_radius, s,
                                   [&](uint32_t slot, const Ray&) { return mine[slot] == 0; });
                             })
                      ? 1
                      : 0;
      chain[pixel] = c;
      if (!on[pixel]) light[pixel] += c.light;
    });
    count = backend.select_flagged(nullptr, on, pixels, live.data());
  }
}

}  // namespace

std::invalid_argument batch_only_refusal(const char* who, StructureKind structure) {
  return std::invalid_argument(std::string(who) + " traces one ray at a time, and the structure " +
                               structure_kind_name(structure) +
                               " answers batches only: choose another structure for it");
}

void trace_visible_points(Backend& backend, const ResidentScene& resident,
                          const PinholeCamera& camera, const VisiblePointSettings& settings,
                          VisiblePoint* points, Vec3f* light) {
  const ResidentSceneView scene = resident.view();
  const float scene_radius = resident.radius();
  resident.structure().visit([&](const auto& structure) {
    if constexpr (StructureView<std::decay_t<decltype(structure)>>) {
      if (!settings.ray_queues) {
        trace_chains_through(structure, backend, scene, scene_radius, camera, settings, points,
                             light);
        return;
      }
    }
    trace_chain_queues(structure, backend, scene, scene_radius, camera, settings, points, light);
  });
}

}  // namespace caustica
