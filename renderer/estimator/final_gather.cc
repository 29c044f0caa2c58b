#include "renderer/estimator/final_gather.h"

#include <algorithm>
#include <cfloat>
#include <cmath>

#include "renderer/accel/curve_order.h"
#include "renderer/accel/ray_queries.h"
#include "renderer/base/morton.h"
#include "renderer/base/octahedral.h"
#include "renderer/base/rng.h"
#include "renderer/base/sampling.h"
#include "renderer/estimator/irradiance_gradients.h"
#include "renderer/estimator/knn_gather.h"
#include "renderer/material/fresnel.h"
#include "renderer/parallel/parallel_for.h"
#include "renderer/photon/knn_estimate.h"
#include "renderer/render/adaptive_seeds.h"
#include "renderer/resident/cutouts.h"

namespace caustica {
namespace {

// Keeps the gather rays' sample streams apart from the camera paths' under the same seed.
constexpr uint32_t kFinalGatherDomain = 0x6a7e4e55u;
// Mirror and glass bounces a gather ray follows to a diffuse hit; rarer longer chains are dropped.
constexpr uint32_t kMaxGatherBounces = 8;
// The most seeds an irradiance may be interpolated from.
constexpr uint32_t kMaxInterpolated = 32;
// Ward's accuracy a: a seed's irradiance is carried to points where its error estimate
// d / R + sqrt(1 - n . n_seed) stays below a.
constexpr float kWardAccuracy = 0.5f;
// Bounds on a seed's harmonic mean distance R, in scene radii: a seed in a corner would otherwise
// be trusted nowhere, and one facing open space everywhere.
constexpr float kMinHarmonicRadius = 0.01f;
constexpr float kMaxHarmonicRadius = 0.5f;

struct GatherRay {
  Ray ray;
  Vec3f throughput;
};

// Where a gather ray ended on a diffuse surface, and what it carried there.
struct GatherHit {
  Vec3f position;
  Vec3f normal;  // shading, towards where the ray came from
  Vec3f geometric_normal;
  Vec3f albedo;
  Vec3f throughput;
  uint32_t diffuse;  // 0 where the ray found no diffuse surface
  float distance;    // to the ray's first hit, infinite where it found none
  // A hit on a sampled model (reflected_at): its material, else kLambertHit, `albedo` its colour
  // and `normal` its frame's, and the direction back along the ray.
  uint32_t sampled;
  Vec3f wo;
  Vec2f metal_rough;  // its metalness and roughness there
};

CAUSTICA_HDI Sampler gather_sampler(uint32_t seed, uint32_t ray, uint32_t pass) {
  return Sampler(seed ^ kFinalGatherDomain, ray, pass);
}

// Gather ray r of a seed's `per_seed`, in the seed's frame (+z its normal): cosine-distributed,
// stratified over a grid of `side` x `side` cells when per_seed is a square (256: 16 x 16), cell
// (j, k) = (r % side, r / side) spanning sin^2(theta) in [j, j + 1] / side and phi in
// 2 pi [k, k + 1] / side, the layout irradiance gradients read (irradiance_gradients.h).
CAUSTICA_HDI Vec3f gather_direction(Sampler& s, uint32_t r, uint32_t side) {
  float u1 = s.next_float(), u2 = s.next_float();
  if (side != 0) {
    u1 = (float(r % side) + u1) / float(side);
    u2 = (float(r / side) + u2) / float(side);
  }
  return sample_cosine_hemisphere(u1, u2);
}

CAUSTICA_HDI uint32_t stratified_side(uint32_t per_seed) {
  const uint32_t side = uint32_t(sqrtf(float(per_seed)) + 0.5f);
  return side * side == per_seed ? side : 0u;
}

// The gather rays of every seed, traced through mirrors and glass to their diffuse hits.
template <typename Structure>
Buffer<GatherHit> trace_gather_rays(const Structure& structure, Backend& backend,
                                    const ResidentSceneView& scene, const Buffer<GatherSeed>& seeds,
                                    uint32_t per_seed, const ShadingSettings& cfg) {
  const size_t m = seeds.size() * size_t(per_seed);
  Buffer<GatherRay> state(backend, m);
  Buffer<GatherHit> found(backend, m);
  Buffer<uint32_t> alive_flags(backend, m);
  Buffer<Ray> rays(backend, m);
  Buffer<Hit> hits(backend, m);
  GatherRay* path = state.data();
  GatherHit* hit_out = found.data();
  uint32_t* alive = alive_flags.data();
  const GatherSeed* seed = seeds.data();
  const uint32_t rng_seed = cfg.seed, pass = cfg.pass;
  const uint32_t side = stratified_side(per_seed);
  parallel_for(backend, "gather_rays", m, [=] CAUSTICA_HD(size_t i) {
    const GatherSeed& g = seed[i / per_seed];
    const uint32_t r = uint32_t(i % per_seed);
    Sampler s = gather_sampler(rng_seed, uint32_t(i), pass);
    const Vec3f d = Frame::from_normal(g.normal).to_world(gather_direction(s, r, side));
    path[i] = {Ray{offset_origin(g.position, g.normal, d), d, 0.0f, FLT_MAX}, Vec3f(1.0f)};
    hit_out[i].diffuse = 0;
    hit_out[i].distance = INFINITY;
    alive[i] = 1;
  });
  Ray* ray = rays.data();
  Hit* hit = hits.data();
  for (uint32_t bounce = 0; bounce < kMaxGatherBounces; ++bounce) {
    parallel_for(backend, "gather_ray_queue", m, [=] CAUSTICA_HD(size_t i) {
      // A finished ray's segment is empty, so the structure answers it at once.
      ray[i] = alive[i] ? path[i].ray : Ray{path[i].ray.origin, path[i].ray.direction, 1.0f, 0.0f};
    });
    trace_closest_surfaces(backend, structure, scene, ray, m, hit);
    parallel_for(backend, "gather_ray_hits", m, [=] CAUSTICA_HD(size_t i) {
      if (!alive[i]) return;
      alive[i] = 0;
      if (!hit[i].valid()) return;
      if (bounce == 0) hit_out[i].distance = hit[i].t;
      const SurfaceHit sh = surface_at(scene, hit[i]);
      const DeviceMaterial& mat = scene.materials[sh.material];
      GatherRay& p = path[i];
      const Vec3f d = p.ray.direction;
      Vec3f next;
      if (mat.type == MaterialType::kEmissive) return;  // direct light or a caustic: not ours
      const bool front = dot(d, sh.shading_normal) < 0.0f;
      const Vec3f ng = front ? sh.geometric_normal : -sh.geometric_normal;
      if (mat.type == MaterialType::kDiffuse) {
        const Vec3f n = front ? sh.shading_normal : -sh.shading_normal;
        // A gather ray lands on one point, like a photon: the map's finest level.
        hit_out[i] = {sh.position,
                      n,
                      ng,
                      surface_color(scene, mat, hit[i], d, 0.0f),
                      p.throughput,
                      1u,
                      hit_out[i].distance,
                      kLambertHit,
                      -d,
                      Vec2f{0.0f, 0.0f}};
        return;
      }
      // A sampled model ends the gather ray too: its direct light and its base's photons; the
      // light its glossy lobes reflect there is left out (docs/materials.md, "In the
      // integrators").
      if (is_sampled_model(mat)) {
        const SurfaceBsdf bsdf =
            SurfaceBsdf::at_hit(scene, mat, hit[i], sh, d, 0.0f, Transport::kRadiance);
        hit_out[i] = {sh.position,
                      bsdf.normal(),
                      ng,
                      bsdf.color,
                      p.throughput,
                      1u,
                      hit_out[i].distance,
                      sh.material,
                      -d,
                      Vec2f{bsdf.metallic, bsdf.roughness}};
        return;
      }
      if (mat.type == MaterialType::kMirror) {
        p.throughput = p.throughput * surface_color(scene, mat, hit[i], d, 0.0f);
        next = reflect(d, sh.shading_normal);
      } else {  // dielectric: one branch, drawn by the Fresnel reflectance
        Sampler s = gather_sampler(rng_seed, uint32_t(i), pass);
        s.skip(2 + bounce);
        const DielectricSide side_of = dielectric_side(d, sh.shading_normal, mat.ior);
        const float fr = fresnel_dielectric(side_of.cos_i, side_of.eta);
        if (s.next_float() < fr || !refract(d, side_of.normal, side_of.eta, next))
          next = reflect(d, side_of.normal);
      }
      p.ray = Ray{offset_origin(sh.position, sh.geometric_normal, next), next, 0.0f, FLT_MAX};
      alive[i] = 1;
    });
    if (backend.reduce_sum(alive, m) == 0) break;
  }
  return found;
}

// Each gather ray's radiance from its diffuse hit towards the seed: the hit's direct light (one
// shadow ray a light, one to the area lights) plus the photon maps' estimate there, times what
// the mirrors and glass on the way let through.
template <typename Structure>
Buffer<Vec3f> gather_ray_radiance(const Structure& structure, Backend& backend,
                                  const ResidentScene& resident, const Buffer<GatherHit>& found,
                                  uint32_t per_seed, const ShadingSettings& cfg,
                                  const RadianceGather& photons) {
  const ResidentSceneView scene = resident.view();
  const size_t m = found.size();
  const GatherHit* hit = found.data();
  const uint32_t slots = direct_light_slots(scene, 1);
  Buffer<Ray> shadow_rays(backend, m * slots);
  Buffer<uint8_t> blocked(backend, m * slots);
  Ray* shadow = shadow_rays.data();
  const uint32_t rng_seed = cfg.seed, pass = cfg.pass;
  const float scene_radius = resident.radius();
  // The direct light's samples follow the gather ray's own dimensions.
  auto direct_sampler = [=] CAUSTICA_HD(size_t i) {
    Sampler s = gather_sampler(rng_seed, uint32_t(i), pass);
    s.skip(2 + kMaxGatherBounces);
    return s;
  };
  parallel_for(backend, "gather_shadow_rays", m, [=] CAUSTICA_HD(size_t i) {
    Ray* mine = shadow + i * slots;
    const GatherHit& h = hit[i];
    for (uint32_t k = 0; k < slots; ++k) mine[k] = Ray{h.position, Vec3f(0, 0, 1), 1.0f, 0.0f};
    if (!h.diffuse) return;
    Sampler s = direct_sampler(i);
    Vec3f weight;
    (void)reflected_at(
        scene, h.sampled, h.albedo, h.metal_rough, h.normal, h.wo, 0.0f, 0.0f, weight,
        [&](const auto& reflection) {
          return direct_light_by(scene, h.position, h.geometric_normal, reflection, 1, scene_radius,
                                 s, [&](uint32_t slot, const Ray& r) {
                                   mine[slot] = r;
                                   return false;
                                 });
        });
  });
  trace_any_surfaces(backend, structure, scene, shadow, m * slots, blocked.data());
  Buffer<Vec3f> radiance(backend, m);
  Vec3f* out = radiance.data();
  const uint8_t* is_blocked = blocked.data();
  parallel_for(backend, "gather_direct_light", m, [=] CAUSTICA_HD(size_t i) {
    const GatherHit& h = hit[i];
    if (!h.diffuse) {
      out[i] = Vec3f(0.0f);
      return;
    }
    Sampler s = direct_sampler(i);
    const uint8_t* mine = is_blocked + i * slots;
    Vec3f weight;
    out[i] = h.throughput *
             reflected_at(scene, h.sampled, h.albedo, h.metal_rough, h.normal, h.wo, 0.0f, 0.0f,
                          weight, [&](const auto& reflection) {
                            return direct_light_by(
                                scene, h.position, h.geometric_normal, reflection, 1, scene_radius,
                                s, [&](uint32_t slot, const Ray&) { return mine[slot] == 0; });
                          });
  });

  // The photon maps' estimates at the diffuse hits, in Hilbert order, added per ray.
  Buffer<uint8_t> diffuse_flags(backend, m);
  uint8_t* is_diffuse = diffuse_flags.data();
  parallel_for(backend, "gather_hit_flags", m,
               [=] CAUSTICA_HD(size_t i) { is_diffuse[i] = hit[i].diffuse ? 1 : 0; });
  Buffer<uint32_t> hit_index(backend, m);
  const uint32_t hits = uint32_t(backend.select_flagged(nullptr, is_diffuse, m, hit_index.data()));
  Buffer<GatherRequest> requests(backend, hits);
  GatherRequest* request = requests.data();
  const uint32_t* index = hit_index.data();
  parallel_for(backend, "gather_hit_requests", hits, [=] CAUSTICA_HD(size_t j) {
    const uint32_t i = index[j];
    const GatherHit& h = hit[i];
    Vec3f weight;
    (void)reflected_at(scene, h.sampled, h.albedo, h.metal_rough, h.normal, h.wo, 0.0f, 0.0f,
                       weight, [](const auto&) { return Vec3f(0.0f); });
    request[j] = {h.position, h.normal, h.throughput * weight, i / per_seed, i % per_seed};
  });
  const size_t seeds = m / per_seed;
  Buffer<uint32_t> seed_offsets(backend, seeds);
  uint32_t* offset = seed_offsets.data();
  parallel_for(backend, "gather_seed_offsets", seeds,
               [=] CAUSTICA_HD(size_t s) { offset[s] = uint32_t(s * per_seed); });
  const Aabb bounds = resident.bounds();
  const CurveOrder order = sort_by_code(backend, hits, 30, [=] CAUSTICA_HD(uint32_t j) {
    return hilbert_code(request[j].position, bounds);
  });
  Buffer<Vec3f> estimates(backend, m);
  estimates.fill_zero();
  photons.gather(backend, {request, order.order.data(), offset, hits}, cfg, estimates.data());
  const Vec3f* estimate = estimates.data();
  parallel_for(backend, "gather_ray_radiance", m,
               [=] CAUSTICA_HD(size_t i) { out[i] += estimate[i]; });
  return radiance;
}

}  // namespace

void FinalGather::gather(Backend& backend, const GatherRequests& requests,
                         const ShadingSettings& cfg, Vec3f* gathered) const {
  // Caustics straight from the caustic map; the global map is read only at the gather rays' hits.
  const PhotonMap none = build_photon_map(backend, Buffer<Photon>(backend, 0), 1);
  KnnGather(caustic_, none).gather(backend, requests, cfg, gathered);
  if (requests.count == 0) return;

  const uint32_t pixels = camera_.width * camera_.height;
  SeedingSettings seeding;
  seeding.width = camera_.width;
  seeding.height = camera_.height;
  seeding.count = settings_.seeds != 0 ? settings_.seeds : std::min(kDefaultSeeds, pixels);
  seeding.center = scene_.bounds().center();
  seeding.radius = scene_.radius();
  seeding.seed = cfg.seed ^ kFinalGatherDomain;
  seeding.pass = cfg.pass;
  const Buffer<GatherSeed> seeds = adaptive_seeds(backend, requests, seeding);
  const uint32_t per_seed = std::max(settings_.rays, 1u);
  const size_t count = seeds.size();

  // Each seed's record from its gather rays (irradiance_gradients.h): a thread a column of its
  // rays, then a thread a seed to sum them.
  Buffer<GatherHit> hits(backend, 0);
  const Buffer<Vec3f> radiance = scene_.structure().visit([&](const auto& structure) {
    hits = trace_gather_rays(structure, backend, scene_.view(), seeds, per_seed, cfg);
    return gather_ray_radiance(structure, backend, scene_, hits, per_seed, cfg,
                               KnnGather(caustic_, global_));
  });
  const uint32_t side = stratified_side(per_seed);
  const uint32_t columns = side == 0 ? 1u : side;
  Buffer<SeedColumn> seed_columns(backend, count * columns);
  Buffer<SeedRecord> records(backend, count);
  Buffer<Photon> seed_points(backend, count);
  SeedColumn* column = seed_columns.data();
  SeedRecord* record = records.data();
  Photon* point = seed_points.data();
  const GatherSeed* seed = seeds.data();
  const Vec3f* ray_radiance = radiance.data();
  const GatherHit* hit = hits.data();
  parallel_for(backend, "gather_seed_columns", count * columns, [=] CAUSTICA_HD(size_t i) {
    const size_t s = i / columns;
    const Vec3f* mine = ray_radiance + s * per_seed;
    const GatherHit* hits_of = hit + s * per_seed;
    column[i] = seed_column(
        uint32_t(i % columns), per_seed, side, seed[s].normal, [&](uint32_t r) { return mine[r]; },
        [&](uint32_t r) { return hits_of[r].distance; });
  });
  const float nearest = kMinHarmonicRadius * scene_.radius();
  const float farthest = kMaxHarmonicRadius * scene_.radius();
  parallel_for(backend, "gather_seed_records", count, [=] CAUSTICA_HD(size_t s) {
    record[s] = seed_record_of(column + s * columns, columns, per_seed, nearest, farthest);
    // The map indexes the seeds by position; its record carries the seed's index.
    point[s] = {seed[s].position, Vec3f(float(s), 0.0f, 0.0f), seed[s].normal};
  });
  const PhotonMap seed_map = build_photon_map(backend, seed_points, 8);
  const PhotonMapView map = seed_map.view();
  const uint32_t k = std::min(std::max(settings_.interpolated, 1u), kMaxInterpolated);

  // Each request's irradiance from its nearest seeds, each carried to it by its gradients and
  // weighed by Ward's 1 / (d / R + sqrt(1 - n . n_seed)): those above 1 / kWardAccuracy when any
  // are, else all that face its way.
  const GatherRequests r = requests;
  parallel_for(backend, "final_gather_interpolate", r.count, [=] CAUSTICA_HD(size_t t) {
    const GatherRequest q = r.requests[r.by_code[t]];
    NeighbourPair pairs[NeighbourHeap<NeighbourPair*>::pairs_for(kMaxInterpolated)];
    NeighbourHeap<NeighbourPair*> heap{pairs};
    const uint32_t found = find_nearest(map, q.position, k, FLT_MAX, heap);
    Vec3f near_sum(0.0f), all_sum(0.0f);
    float near_weights = 0.0f, all_weights = 0.0f;
    for (uint32_t i = 0; i < found; ++i) {
      const Neighbour n = heap[i];
      const PhotonFlux f = map.flux_of(n.index);
      const float facing = dot(decode_octahedral(f.incoming), q.normal);
      if (facing <= 0.0f) continue;
      const uint32_t index = uint32_t(f.power.x);
      const SeedRecord& from = record[index];
      const float w = 1.0f / (sqrtf(n.distance_squared) / from.radius +
                              sqrtf(fmaxf(0.0f, 1.0f - facing)) + 1e-6f);
      const Vec3f e =
          extrapolated(from, seed[index].position, seed[index].normal, q.position, q.normal);
      all_sum += e * w;
      all_weights += w;
      if (w > 1.0f / kWardAccuracy) {
        near_sum += e * w;
        near_weights += w;
      }
    }
    const Vec3f sum = near_weights > 0.0f ? near_sum : all_sum;
    const float weights = near_weights > 0.0f ? near_weights : all_weights;
    if (weights > 0.0f)
      gathered[r.pixel_offsets[q.pixel] + q.order] += q.weight * sum * (kInvPi / weights);
  });
}

}  // namespace caustica
