#include "renderer/render/whitted.h"

#include <algorithm>
#include <stdexcept>
#include <type_traits>
#include <utility>
#include <vector>

#include "renderer/accel/camera_tiles.h"
#include "renderer/accel/curve_order.h"
#include "renderer/accel/ray_queries.h"
#include "renderer/base/atomic.h"
#include "renderer/base/morton.h"
#include "renderer/base/pixel_blocks.h"
#include "renderer/base/rng.h"
#include "renderer/base/uninitialized.h"
#include "renderer/material/fresnel.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {
namespace {

struct PendingRay {
  Ray ray;
  Vec3f throughput;
  uint32_t depth;
  uint64_t branch;  // PathRay::branch
  uint32_t medium;  // the one the ray travels in (medium/medium.h)
  float travelled;  // from the camera to the ray's origin: its ray cone's width over the spread
  float glossy_pdf;  // the density it was drawn with off a glossy surface, else 0
};

// Room for the pending branches of a specular walk, left unconstructed (a walk uses a handful).
using PendingStack = Uninitialized<PendingRay, kMaxSpecularDepth + 2>;

// The branch key of the child `choice` (0 reflection, 1 refraction) of a branch at `depth`: the
// tree's choices from the top bit, one per depth, so that as integers the leaves of a tree order
// as the depth-first walks meet them.
CAUSTICA_HDI uint64_t child_branch(uint64_t branch, uint32_t depth, uint64_t choice) {
  return branch | (choice << (63u - depth));
}

// Russian roulette on the deep branches of a pixel's specular tree (kBranchRouletteFrom). Each
// draw is a hash of the pixel, the pass and the branch's key, so the walks and the ray queues,
// which meet the branches in different orders, draw the same numbers.
class BranchRoulette {
 public:
  CAUSTICA_HD BranchRoulette(const ShadingSettings& cfg, uint32_t pixel)
      : key_(stream_key(cfg.seed ^ 0x2545f491u, pixel, cfg.pass)), survival_(cfg.branch_survival) {}

  // Whether the child `branch` spawned at `depth` with `throughput` is followed, its throughput
  // rescaled when roulette spares it.
  CAUSTICA_HDI bool spares(uint64_t branch, uint32_t depth, uint32_t max_depth,
                           Vec3f& throughput) const {
    const float carried = max_component(throughput);
    if (depth >= max_depth || !(carried > 0.0f)) return false;
    if (depth < kBranchRouletteFrom) return true;
    const float survive = min_f(carried, survival_);
    // A reflection's key is its parent's, so the depth tells a chain of reflections apart: with
    // one number for the whole chain, a lucky draw kept every branch of it.
    const uint32_t h = pcg_hash(
        key_ ^ pcg_hash(uint32_t(branch) ^ pcg_hash(uint32_t(branch >> 32) ^ pcg_hash(depth))));
    if (unit_float(h) >= survive) return false;
    throughput = throughput / survive;
    return true;
  }

  // Uniform number `dim` (0 to 2) of the branch `branch` at `depth` where it scatters off a glossy
  // surface: a hash of the branch's key apart from the roulette's, the same in walks and queues.
  CAUSTICA_HDI float uniform(uint64_t branch, uint32_t depth, uint32_t dim) const {
    return unit_float(pcg_hash((key_ ^ 0x68e31da4u) ^
                               pcg_hash(uint32_t(branch) ^ pcg_hash(uint32_t(branch >> 32) ^
                                                                    pcg_hash(4u * depth + dim)))));
  }

 private:
  uint32_t key_;
  float survival_;
};

// The branches a mirror or dielectric hit (material `m`, `sh`, ray direction `d`) spawns with the
// path's `throughput`: spawn(direction, throughput, choice, 0), choice 1 for the refraction and 0
// for a reflection; a dielectric's both Fresnel branches, the refraction first. `color` is the
// mirror's reflectance there (surface_color).
template <typename Spawn>
CAUSTICA_HDI void specular_branches(const DeviceMaterial& m, Vec3f color, const SurfaceHit& sh,
                                    Vec3f d, Vec3f throughput, Spawn spawn) {
  if (m.type == MaterialType::kMirror) {
    spawn(reflect(d, sh.shading_normal), throughput * color, uint64_t(0), 0.0f);
    return;
  }
  DielectricSide side = dielectric_side(d, sh.shading_normal, m.ior);
  float fr = fresnel_dielectric(side.cos_i, side.eta);
  Vec3f refracted;
  if (fr < 1.0f && refract(d, side.normal, side.eta, refracted))
    spawn(refracted, throughput * (1.0f - fr), uint64_t(1), 0.0f);
  spawn(reflect(d, side.normal), throughput * fr, uint64_t(0), 0.0f);
}

// The branch a hit on a sampled model (surface_bsdf.h) spawns: one direction from its glossy lobes,
// drawn by the branch's own numbers, spawn(direction, throughput, choice, density) with choice 1
// for a transmission and the density continuation_pdf's. A direction on the wrong side of the
// triangle itself (a shading normal tilted from the geometric one) would leak through it and is
// dropped.
template <typename Spawn>
CAUSTICA_HDI void glossy_branch(const SurfaceBsdf& bsdf, const SurfaceHit& sh, Vec3f d,
                                Vec3f throughput, const BranchRoulette& roulette, uint64_t branch,
                                uint32_t depth, float near_specular_alpha, Spawn spawn) {
  const SurfaceSample g =
      bsdf.sample_glossy(-d, roulette.uniform(branch, depth, 0), roulette.uniform(branch, depth, 1),
                         roulette.uniform(branch, depth, 2));
  if (!g.valid()) return;
  const bool transmits = (g.flags & kBsdfTransmission) != 0;
  if ((dot(g.wi, sh.geometric_normal) * dot(d, sh.geometric_normal) < 0.0f) == transmits) return;
  spawn(g.wi, throughput * g.weight, transmits ? uint64_t(1) : uint64_t(0),
        continuation_pdf(bsdf, g.pdf, near_specular_alpha));
}

// Follows the specular tree of one camera ray depth-first (each dielectric hit adds at most one
// pending branch) from its first hit. `on_diffuse(hit, normal, colour, throughput, medium, bsdf)`
// is called at every diffuse hit (bsdf null, the normal facing the viewer) and every hit on a
// sampled model (its SurfaceBsdf, whose frame's normal is given), with wo, in a fixed order, a
// sampled model's glossy branch following, the colour read through a ray cone `pixel_spread` wide
// per unit of distance from the camera; emitted light seen along the tree is returned. With kMedia,
// `on_beam(ray, span, medium, throughput)` is called in the same order for every stretch through a
// medium, whose beam estimate the caller owes the path, and each branch is attenuated by the media
// it crosses. `light_samples`: the shadow rays each diffuse or glossy hit sends to area lights
// (SurfaceReflection's). Without kMedia the scene has none, and the walk compiles to what it was
// before media, registers and all; without kEnvironment, likewise for a scene without an
// environment, and without kSurfaceMaps for a scene without normal maps and cut-outs.
template <bool kMedia, bool kEnvironment, bool kSurfaceMaps, typename Structure, typename OnDiffuse,
          typename OnBeam>
CAUSTICA_HDI Vec3f walk_specular_tree(const ResidentSceneView& scene, const Structure& structure,
                                      const Ray& camera_ray, const Hit& first_hit,
                                      uint32_t max_depth, float pixel_spread, float light_samples,
                                      float near_specular_alpha, const BranchRoulette& roulette,
                                      OnDiffuse on_diffuse, OnBeam on_beam) {
  PendingStack pending;
  PendingRay* stack = pending.item;
  int top = 0;
  // The camera stands outside every shape: in the scene-wide medium, where there is one.
  stack[top++] = {camera_ray, Vec3f(1.0f), 0, 0, kMedia ? scene.media.scene_medium : kVacuum,
                  0.0f,       0.0f};
  bool first = true;
  Vec3f emitted(0.0f);
  while (top > 0) {
    PendingRay pr = stack[--top];
    Hit hit = first ? first_hit : closest_surface_hit<kSurfaceMaps>(structure, scene, pr.ray);
    if (kMedia && pr.medium != kVacuum) {
      const MediumSpan span =
          medium_span(scene.media, pr.medium, pr.ray.origin, pr.ray.direction, hit.t);
      if (span.length() > 0.0f) {
        on_beam(pr.ray, span, pr.medium, pr.throughput);
        pr.throughput *=
            span_transmittance(scene.media.media[pr.medium], pr.ray.origin, pr.ray.direction, span);
      }
    }
    first = false;
    if (!hit.valid()) {
      if constexpr (kEnvironment)
        emitted +=
            pr.throughput * environment_seen(scene, pr.ray.direction, pr.glossy_pdf, light_samples);
      continue;
    }
    SurfaceHit sh = surface_at<kSurfaceMaps>(scene, hit);
    const DeviceMaterial& m = scene.materials[sh.material];
    Vec3f d = pr.ray.direction;
    auto spawn = [&](Vec3f dir, Vec3f throughput, uint64_t choice, float glossy_pdf) {
      const uint64_t branch = child_branch(pr.branch, pr.depth, choice);
      if (!roulette.spares(branch, pr.depth, max_depth, throughput)) return;
      Ray r;
      r.origin = offset_origin(sh.position, sh.geometric_normal, dir);
      r.direction = dir;
      const uint32_t medium =
          kMedia && choice == 1
              ? medium_after_crossing(scene.media, hit.triangle, d, sh.geometric_normal)
              : pr.medium;
      stack[top++] = {r,      throughput,           pr.depth + 1, branch,
                      medium, pr.travelled + hit.t, glossy_pdf};
    };
    const float cone = pixel_spread * (pr.travelled + hit.t);
    // Any surface may emit from its front face; an emissive one does nothing else.
    const float cos_light = -dot(d, sh.geometric_normal);
    if (!is_black(m.radiance) && cos_light > 0.0f)
      emitted += pr.throughput * surface_emission(scene, m, hit, d, cone) *
                 glossy_emission_weight(scene, pr.glossy_pdf, light_samples, hit, cos_light);
    if (is_sampled_model(m)) {
      const SurfaceBsdf bsdf =
          SurfaceBsdf::at_hit(scene, m, hit, sh, d, cone, Transport::kRadiance);
      on_diffuse(sh, bsdf.normal(), bsdf.color, pr.throughput, kMedia ? pr.medium : kVacuum, &bsdf,
                 -d);
      glossy_branch(bsdf, sh, d, pr.throughput, roulette, pr.branch, pr.depth, near_specular_alpha,
                    spawn);
      continue;
    }
    switch (m.type) {
      case MaterialType::kDiffuse: {
        Vec3f n = dot(d, sh.shading_normal) < 0.0f ? sh.shading_normal : -sh.shading_normal;
        on_diffuse(sh, n, surface_color(scene, m, hit, d, cone), pr.throughput,
                   kMedia ? pr.medium : kVacuum, static_cast<const SurfaceBsdf*>(nullptr), -d);
        break;
      }
      case MaterialType::kMirror:
      case MaterialType::kDielectric:
        specular_branches(m, surface_color(scene, m, hit, d, cone), sh, d, pr.throughput, spawn);
        break;
      default:  // emissive: nothing else
        break;
    }
  }
  return emitted;
}

// What every stage of one pass reads, copied by value into its kernels.
struct PassInputs {
  ResidentSceneView scene;
  PinholeCamera camera;
  ShadingSettings cfg;
  PixelBlocks blocks;
  size_t pixels;
  float scene_radius;
  Aabb scene_bounds;
  uint32_t max_depth;
  float pixel_spread;  // the camera's ray cones: width per unit of distance (surface_color)

  PassInputs(const ResidentScene& resident, const PinholeCamera& camera_in,
             const ShadingSettings& settings)
      : scene(resident.view()),
        camera(camera_in),
        cfg(settings),
        blocks(camera_in.width, camera_in.height),
        pixels(size_t(camera_in.width) * camera_in.height),
        scene_radius(resident.radius()),
        scene_bounds(resident.bounds()),
        max_depth(settings.max_depth < kMaxSpecularDepth ? settings.max_depth : kMaxSpecularDepth),
        pixel_spread(camera_in.pixel_spread()) {}

  // The jittered camera ray of a pixel: the first two dimensions of its sample stream.
  CAUSTICA_HDI Ray camera_ray(size_t pixel, Sampler& s) const {
    const float jx = s.next_float();
    return camera.pixel_ray(pixel, jx, s.next_float());
  }
};

// What the specular walks leave for the gathers: per pixel its emitted and direct light and how
// many requests it made (offsets: where they start in pixel and path order), and the requests.
struct SpecularPaths {
  Buffer<Vec3f> direct;
  Buffer<uint32_t> counts, offsets;
  Buffer<GatherRequest> requests;
  uint32_t request_total = 0;

  // Per-pixel arrays for `pixels` pixels and no requests yet.
  static SpecularPaths for_pixels(Backend& backend, size_t pixels) {
    return {Buffer<Vec3f>(backend, pixels), Buffer<uint32_t>(backend, pixels),
            Buffer<uint32_t>(backend, pixels), Buffer<GatherRequest>(backend, 0)};
  }
};

// Stage 1: primary hits (packets on the CPU, a warp per 8x4 pixels on a GPU).
template <typename Structure>
Buffer<Hit> trace_camera_rays(Backend& backend, const Structure& structure, const PassInputs& in) {
  Buffer<Hit> hits(backend, in.pixels);
  const uint32_t seed = in.cfg.seed, pass = in.cfg.pass;
  trace_camera_tiles(
      backend, structure, in.camera.origin, in.camera.width, in.camera.height,
      [=] CAUSTICA_HD(size_t pixel) {
        Sampler s(seed, in.camera.stream(pixel), pass);
        return in.camera_ray(pixel, s).direction;
      },
      hits.data());
  if (in.scene.has_cutouts) {
    // The tiles' packets see every triangle; the rays that met a cut-out go on from there.
    Buffer<Ray> rays(backend, in.pixels);
    Ray* ray = rays.data();
    parallel_for(backend, "cutout_camera_rays", in.pixels, [=] CAUSTICA_HD(size_t pixel) {
      Sampler s(seed, in.camera.stream(pixel), pass);
      ray[pixel] = in.camera_ray(pixel, s);
    });
    continue_through_cutouts(backend, structure, in.scene, rays.data(), in.pixels, hits.data());
  }
  return hits;
}

// A stretch of a camera path through a medium, waiting for its beam estimate: `order` is its
// place among its pixel's stretches in the order the walk met them, `thread` the walk's thread
// (pixels in 8 x 4 blocks).
struct BeamRequest {
  Vec3f origin;
  float t0;
  Vec3f direction;
  float t1;
  Vec3f throughput;
  uint32_t medium;
  uint32_t pixel, thread, order;
};

// The beam estimate of every request, in the order `index` sorts them, each written to its
// pixel's `offset` plus its order. kGrids: some medium is a grid (media.grids).
template <bool kGrids>
void gather_beam_queue(Backend& backend, const VolumeMapView& volume, const MediaView& media,
                       const BeamRequest* requests, const uint32_t* index, uint32_t total,
                       const uint32_t* offset, Vec3f* value) {
  parallel_for(backend, "beam_gather", total, [=] CAUSTICA_HD(size_t rank) {
    const BeamRequest r = requests[index[rank]];
    const MediumSpan span{r.t0, r.t1};
    const Vec3f beam = beam_radiance<kGrids>(volume, media.media[r.medium], r.origin, r.direction,
                                             span, launch_warp(rank, total));
    value[offset[r.pixel] + r.order] = r.throughput * beam;
  });
}

// The pass's beam estimates, from the stretches the walks left (`count` per pixel starting at
// `offset`, `total` in `requests`), added to each pixel's light in its walk's order. The stretches
// go to the gather sorted by their place in their pixel's walk and then by the walk's thread: the
// camera rays' first stretches together, then the second ones, each in blocks of 8 x 4 pixels, so
// that the 32 lanes of a warp gather neighbouring stretches and walk the volume map as one search
// group, reading each node and collision once for all of them (Fabianowski 2011 sec. 7.4 found
// packets of rays the fastest way to gather beams). In a walk's own thread, the stretches behind
// the glass sphere made its warp wait for its slowest lane (docs/media.md, "Speed").
void gather_beams(Backend& backend, const PassInputs& in, const BeamRequest* requests,
                  uint32_t total, const uint32_t* count, const uint32_t* offset,
                  Vec3f* pixel_light) {
  if (total == 0) return;
  Buffer<uint64_t> keys(backend, total);
  Buffer<uint32_t> order(backend, total);
  uint64_t* key = keys.data();
  uint32_t* index = order.data();
  parallel_for(backend, "beam_keys", total, [=] CAUSTICA_HD(size_t i) {
    key[i] = uint64_t(requests[i].order) << 32 | requests[i].thread;
    index[i] = uint32_t(i);
  });
  backend.sort_pairs(key, index, total, 48);  // orders below 2^16
  Buffer<Vec3f> values(backend, total);
  Vec3f* value = values.data();
  const VolumeMapView volume = in.cfg.volume;
  const MediaView media = in.scene.media;
  if (media.grids)
    gather_beam_queue<true>(backend, volume, media, requests, index, total, offset, value);
  else
    gather_beam_queue<false>(backend, volume, media, requests, index, total, offset, value);
  parallel_for(backend, "beam_accumulate", in.pixels, [=] CAUSTICA_HD(size_t pixel) {
    Vec3f sum(0.0f);
    for (uint32_t b = offset[pixel]; b < offset[pixel] + count[pixel]; ++b) sum += value[b];
    pixel_light[pixel] += sum;
  });
}

// Stage 2, with the shadow rays of direct light. The gathers run apart from the paths that need
// them (a wavefront, as in pbrt-v4): inside one per-pixel kernel, a pixel on the glass sphere
// made its warp wait through half a dozen gathers while the other lanes idled, and the lanes of a
// warp searched far-apart photons. Each pixel's specular tree is walked once: emitted and direct
// light per pixel, and one gather request per diffuse hit, appended wherever there is room; each
// request knows its pixel and its place in the pixel's path order. A pixel makes about one
// request (1.1 in cornell-caustics); when a pass needs more room than it was given, the walks run
// again with exactly enough (nothing they compute depends on what they wrote before). kMedia: the
// scene has participating media, kEnvironment: an environment, kSurfaceMaps: normal maps or
// cut-outs (launches of their own, so that scenes without keep their registers).
template <bool kMedia, bool kEnvironment, bool kSurfaceMaps, typename Structure>
SpecularPaths walk_specular_paths(Backend& backend, const Structure& structure,
                                  const PassInputs& in, const Hit* primary) {
  SpecularPaths out = SpecularPaths::for_pixels(backend, in.pixels);
  // Counters of gather requests and (with media) beam requests appended.
  Buffer<uint32_t> appended(backend, 2);
  Vec3f* direct_out = out.direct.data();
  uint32_t* count = out.counts.data();
  uint32_t* next_request = appended.data();
  uint32_t* next_beam = appended.data() + 1;
  size_t capacity = size_t(in.cfg.gather_requests_per_pixel) * in.pixels;
  // With media, the stretches through them: a camera ray's first, and a few behind glass.
  Buffer<BeamRequest> beams(backend, 0);
  Buffer<uint32_t> beam_counts(backend, kMedia ? in.pixels : 0);
  Buffer<uint32_t> beam_offsets(backend, kMedia ? in.pixels : 0);
  uint32_t* beam_count = beam_counts.data();
  size_t beam_capacity = kMedia ? 2 * in.pixels : 0;
  while (true) {
    out.requests.resize_discard(capacity);
    beams.resize_discard(beam_capacity);
    GatherRequest* request = out.requests.data();
    BeamRequest* beam = beams.data();
    const uint32_t room = uint32_t(capacity), beam_room = uint32_t(beam_capacity);
    backend.fill_bytes(next_request, 0, 2 * sizeof(uint32_t));
    parallel_for(
        backend, kMedia ? "specular_walk_media" : "specular_walk", in.blocks.thread_count(),
        [=] CAUSTICA_HD(size_t thread) {
          size_t pixel;
          if (!in.blocks.pixel_of(thread, pixel)) return;
          Sampler s(in.cfg.seed, in.camera.stream(pixel), in.cfg.pass);
          Vec3f direct(0.0f);
          uint32_t made = 0, beams_made = 0;
          Vec3f emitted = walk_specular_tree<kMedia, kEnvironment, kSurfaceMaps>(
              in.scene, structure, in.camera_ray(pixel, s), primary[pixel], in.max_depth,
              in.pixel_spread, float(in.cfg.area_light_samples), in.cfg.near_specular_alpha,
              BranchRoulette(in.cfg, in.camera.stream(pixel)),
              [&](const SurfaceHit& sh, Vec3f n, Vec3f color, Vec3f throughput, uint32_t medium,
                  const SurfaceBsdf* bsdf, Vec3f wo) {
                Vec3f weight = color;
                if (bsdf == nullptr) {
                  direct += throughput * direct_light<kEnvironment, kSurfaceMaps>(
                                             in.scene, structure, sh.position, n,
                                             sh.geometric_normal, color, in.cfg.area_light_samples,
                                             in.scene_radius, s, medium);
                } else {
                  const SurfaceReflection r = reflection_on_path(
                      *bsdf, wo, float(in.cfg.area_light_samples), in.cfg.near_specular_alpha);
                  direct +=
                      throughput * direct_light_traced<kEnvironment, kSurfaceMaps>(
                                       in.scene, structure, sh.position, sh.geometric_normal, r,
                                       in.cfg.area_light_samples, in.scene_radius, s, medium);
                  weight = bsdf->base_albedo(wo);
                }
                const uint32_t slot = atomic_fetch_add(next_request, 1u);
                if (slot < room)
                  request[slot] = {sh.position, n, throughput * weight, uint32_t(pixel), made};
                ++made;
              },
              [&](const Ray& ray, const MediumSpan& span, uint32_t medium, Vec3f throughput) {
                const uint32_t slot = atomic_fetch_add(next_beam, 1u);
                if (slot < beam_room)
                  beam[slot] = {ray.origin,      span.t0,          ray.direction,
                                span.t1,         throughput,       medium,
                                uint32_t(pixel), uint32_t(thread), beams_made};
                ++beams_made;
              });
          direct_out[pixel] = emitted + direct;
          count[pixel] = made;
          if (kMedia) beam_count[pixel] = beams_made;
        });
    out.request_total = backend.exclusive_scan(count, out.offsets.data(), in.pixels);
    const uint32_t beam_total =
        kMedia ? backend.exclusive_scan(beam_count, beam_offsets.data(), in.pixels) : 0;
    if (out.request_total <= capacity && beam_total <= beam_capacity) {
      if constexpr (kMedia) {
        gather_beams(backend, in, beam, beam_total, beam_count, beam_offsets.data(), direct_out);
      }
      return out;
    }
    capacity = std::max<size_t>(capacity, out.request_total);
    beam_capacity = std::max<size_t>(beam_capacity, beam_total);
  }
}

// Stage 2 as ray queues, in pbrt-v4's wavefront shape, for structures that answer batches only
// (BatchStructureView): the walks above trace one ray at a time inside one thread. Each wave is
// one batch of closest hits for the branches of every pixel's specular tree at one depth; its
// shading sends mirror and glass branches on to the next wave and leaves each tree's emissive
// and diffuse hits as leaves. The leaves then go in pixel and depth-first order (the order the
// walks meet them), where a diffuse hit's place says where its pixel's samples stand, so that
// its shadow rays are the walk's; those go out as one queue of any hits, and each pixel sums its
// leaves in that order, as the walk did. The image is the walks' to the bit.
struct PathRay {
  Ray ray;
  Vec3f throughput;
  uint32_t pixel;
  uint32_t depth;
  // The tree's choices down to this ray (child_branch): 0 for a mirror's or a dielectric's
  // reflection, which the walks follow first, 1 for a refraction.
  uint64_t branch;
  float travelled;   // PendingRay::travelled
  float glossy_pdf;  // PendingRay::glossy_pdf
};

struct PathLeaf {
  uint64_t branch;
  uint32_t pixel;
  uint32_t diffuse;  // 1: a diffuse hit or one on a sampled model; 0: emitted light seen
  Vec3f throughput;
  Vec3f value;  // emitted radiance, or a diffuse hit's emission and then its direct light added
  Vec3f position, normal, geometric_normal, albedo;
  // A hit on a sampled model: its material (else kLambertHit), `normal` its frame's and `albedo`
  // its colour there, the direction towards the viewer, and its metalness and roughness there.
  uint32_t sampled;
  Vec3f wo;
  Vec2f metal_rough;

  // The leaf's direct light by reflected_at, and the weight of its gather request.
  template <typename Direct>
  CAUSTICA_HDI Vec3f reflected(const ShadingSettings& cfg, const ResidentSceneView& scene,
                               Vec3f& weight, Direct direct) const {
    const Vec3f light =
        reflected_at(scene, sampled, albedo, metal_rough, normal, wo, float(cfg.area_light_samples),
                     cfg.near_specular_alpha, weight, direct);
    weight = throughput * weight;
    return light;
  }
};

// One wave's shading: leaves where the branch ends on a light or a diffuse surface, new branches
// appended to `next` for mirrors and dielectrics. kEnvironment: as walk_specular_paths'.
template <bool kEnvironment>
void shade_wave(Backend& backend, const PassInputs& in, const PathRay* wave, const Hit* hits,
                size_t count, PathLeaf* leaves, uint8_t* is_leaf, PathRay* next,
                uint32_t* next_count) {
  parallel_for(backend, "specular_wave_shade", count, [=] CAUSTICA_HD(size_t i) {
    is_leaf[i] = 0;
    const Hit hit = hits[i];
    const PathRay pr = wave[i];
    if (!hit.valid()) {
      // The environment seen, a leaf of its own as an emitter's.
      if (!kEnvironment || !in.scene.has_environment) return;
      leaves[i] = {pr.branch,
                   pr.pixel,
                   0u,
                   pr.throughput,
                   environment_seen(in.scene, pr.ray.direction, pr.glossy_pdf,
                                    float(in.cfg.area_light_samples)),
                   Vec3f(0.0f),
                   Vec3f(0.0f),
                   Vec3f(0.0f),
                   Vec3f(0.0f),
                   kLambertHit,
                   Vec3f(0.0f),
                   Vec2f{0.0f, 0.0f}};
      is_leaf[i] = 1;
      return;
    }
    const SurfaceHit sh = surface_at(in.scene, hit);
    const DeviceMaterial& m = in.scene.materials[sh.material];
    const Vec3f d = pr.ray.direction;
    const BranchRoulette roulette(in.cfg, in.camera.stream(pr.pixel));
    auto spawn = [&](Vec3f dir, Vec3f throughput, uint64_t choice, float glossy_pdf) {
      const uint64_t branch = child_branch(pr.branch, pr.depth, choice);
      if (!roulette.spares(branch, pr.depth, in.max_depth, throughput)) return;
      Ray r;
      r.origin = offset_origin(sh.position, sh.geometric_normal, dir);
      r.direction = dir;
      const uint32_t slot = atomic_fetch_add(next_count, 1u);
      next[slot] = {r,      throughput,           pr.pixel,  pr.depth + 1,
                    branch, pr.travelled + hit.t, glossy_pdf};
    };
    const float cone = in.pixel_spread * (pr.travelled + hit.t);
    // Any surface may emit from its front face: a leaf of its own, or a diffuse leaf's start.
    const float cos_light = -dot(d, sh.geometric_normal);
    const Vec3f emission =
        !is_black(m.radiance) && cos_light > 0.0f
            ? surface_emission(in.scene, m, hit, d, cone) *
                  glossy_emission_weight(in.scene, pr.glossy_pdf, float(in.cfg.area_light_samples),
                                         hit, cos_light)
            : Vec3f(0.0f);
    const bool sampled = is_sampled_model(m);
    if (!is_black(emission) && m.type != MaterialType::kDiffuse && !sampled) {
      leaves[i] = {pr.branch,   pr.pixel,    0u,          pr.throughput,
                   emission,    Vec3f(0.0f), Vec3f(0.0f), Vec3f(0.0f),
                   Vec3f(0.0f), kLambertHit, Vec3f(0.0f), Vec2f{0.0f, 0.0f}};
      is_leaf[i] = 1;
    }
    if (sampled || m.type == MaterialType::kDiffuse) {
      Vec3f n, color;
      Vec2f metal_rough{0.0f, 0.0f};
      uint32_t material = kLambertHit;
      if (sampled) {
        const SurfaceBsdf bsdf =
            SurfaceBsdf::at_hit(in.scene, m, hit, sh, d, cone, Transport::kRadiance);
        n = bsdf.normal();
        color = bsdf.color;
        material = sh.material;
        metal_rough = Vec2f{bsdf.metallic, bsdf.roughness};
        glossy_branch(bsdf, sh, d, pr.throughput, roulette, pr.branch, pr.depth,
                      in.cfg.near_specular_alpha, spawn);
      } else {
        n = dot(d, sh.shading_normal) < 0.0f ? sh.shading_normal : -sh.shading_normal;
        color = surface_color(in.scene, m, hit, d, cone);
      }
      leaves[i] = {pr.branch, pr.pixel,    1u, pr.throughput,
                   emission,  sh.position, n,  sh.geometric_normal,
                   color,     material,    -d, metal_rough};
      is_leaf[i] = 1;
      return;
    }
    if (m.type == MaterialType::kMirror || m.type == MaterialType::kDielectric)
      specular_branches(m, surface_color(in.scene, m, hit, d, cone), sh, d, pr.throughput, spawn);
  });
}

// Every wave's closest hits and shading; returns the leaves of all waves.
template <typename Structure>
Buffer<PathLeaf> trace_specular_waves(Backend& backend, const Structure& structure,
                                      const PassInputs& in, const Hit* primary) {
  Buffer<PathRay> wave(backend, in.pixels), next(backend, 0);
  Buffer<Ray> rays(backend, 0);
  Buffer<Hit> hits(backend, 0);
  Buffer<uint32_t> next_counter(backend, 1);
  {
    PathRay* first = wave.data();
    const PassInputs inputs = in;
    parallel_for(backend, "specular_wave_camera", in.pixels, [=] CAUSTICA_HD(size_t pixel) {
      Sampler s(inputs.cfg.seed, inputs.camera.stream(pixel), inputs.cfg.pass);
      first[pixel] = {
          inputs.camera_ray(pixel, s), Vec3f(1.0f), uint32_t(pixel), 0u, 0u, 0.0f, 0.0f};
    });
  }
  std::vector<Buffer<PathLeaf>> wave_leaves;
  size_t total_leaves = 0, count = in.pixels;
  const Hit* wave_hits = primary;
  Buffer<PathLeaf> leaves(backend, 0);
  Buffer<uint8_t> is_leaf(backend, 0);
  Buffer<uint32_t> leaf_index(backend, 0);
  while (count > 0) {
    leaves.resize_discard(count);
    is_leaf.resize_discard(count);
    next.resize_discard(2 * count);
    backend.fill_bytes(next_counter.data(), 0, sizeof(uint32_t));
    (in.scene.has_environment ? shade_wave<true>
                              : shade_wave<false>)(backend, in, wave.data(), wave_hits, count,
                                                   leaves.data(), is_leaf.data(), next.data(),
                                                   next_counter.data());
    leaf_index.resize_discard(count);
    const size_t made = backend.select_flagged(nullptr, is_leaf.data(), count, leaf_index.data());
    Buffer<PathLeaf> kept(backend, made);
    PathLeaf* kept_leaf = kept.data();
    const PathLeaf* leaf = leaves.data();
    const uint32_t* index = leaf_index.data();
    parallel_for(backend, "specular_wave_leaves", made,
                 [=] CAUSTICA_HD(size_t i) { kept_leaf[i] = leaf[index[i]]; });
    total_leaves += made;
    wave_leaves.push_back(std::move(kept));
    count = next_counter.download()[0];
    if (count == 0) break;
    std::swap(wave, next);
    rays.resize_discard(count);
    hits.resize_discard(count);
    Ray* ray = rays.data();
    const PathRay* queued = wave.data();
    parallel_for(backend, "specular_wave_rays", count,
                 [=] CAUSTICA_HD(size_t i) { ray[i] = queued[i].ray; });
    trace_closest_surfaces(backend, structure, in.scene, rays.data(), count, hits.data());
    wave_hits = hits.data();
  }
  Buffer<PathLeaf> all(backend, total_leaves);
  size_t at = 0;
  for (const Buffer<PathLeaf>& part : wave_leaves) {
    if (!part.empty())
      backend.copy_on_device(all.data() + at, part.data(), part.size() * sizeof(PathLeaf));
    at += part.size();
  }
  return all;
}

// The leaves in pixel order and, within a pixel, in the walks' order: a stable sort by branch,
// then one by pixel.
Buffer<uint32_t> order_leaves(Backend& backend, const Buffer<PathLeaf>& leaves) {
  const size_t n = leaves.size();
  Buffer<uint64_t> branch_keys(backend, n);
  Buffer<uint32_t> pixel_keys(backend, n), order(backend, n);
  uint64_t* branch = branch_keys.data();
  uint32_t* index = order.data();
  const PathLeaf* leaf = leaves.data();
  parallel_for(backend, "leaf_branch_keys", n, [=] CAUSTICA_HD(size_t i) {
    branch[i] = leaf[i].branch;
    index[i] = uint32_t(i);
  });
  backend.sort_pairs(branch, index, n);
  uint32_t* pixel = pixel_keys.data();
  parallel_for(backend, "leaf_pixel_keys", n,
               [=] CAUSTICA_HD(size_t j) { pixel[j] = leaf[index[j]].pixel; });
  backend.sort_pairs(pixel, index, n);
  return order;
}

// The sampler of a pixel's diffuse hit `rank` (in its walk's order) as the walk holds it there:
// past the camera ray's two dimensions and the earlier hits' direct light. `stream`: the pixel's
// (PinholeCamera::stream).
CAUSTICA_HDI Sampler diffuse_hit_sampler(const ShadingSettings& cfg, uint32_t stream, uint32_t rank,
                                         uint32_t dimensions) {
  Sampler s(cfg.seed, stream, cfg.pass);
  s.skip(2 + rank * dimensions);
  return s;
}

// A wave's diffuse leaves as their shadow rays read them: request r is leaf[diffuse_at[r]], its
// pixel's requests start at pixel_offset[pixel], and each has `slots` shadow rays
// (direct_light_slots) and draws `dimensions` sample dimensions (direct_light_dimensions).
struct DiffuseLeaves {
  PathLeaf* leaf;
  const uint32_t* diffuse_at;
  const uint32_t* pixel_offset;
  uint32_t slots, dimensions;

  CAUSTICA_HDI Sampler sampler(const PassInputs& in, uint32_t r, const PathLeaf& l) const {
    return diffuse_hit_sampler(in.cfg, in.camera.stream(l.pixel), r - pixel_offset[l.pixel],
                               dimensions);
  }
};

// Every slot of each request's shadow rays: the ray direct_light_by asks for, or an empty one.
template <bool kEnvironment>
void queue_shadow_rays(Backend& backend, const PassInputs& in, const DiffuseLeaves& diffuse,
                       uint32_t requests, Ray* shadow) {
  parallel_for(backend, "shadow_ray_queue", requests, [=] CAUSTICA_HD(size_t r) {
    const PathLeaf l = diffuse.leaf[diffuse.diffuse_at[r]];
    Ray* mine = shadow + r * diffuse.slots;
    for (uint32_t k = 0; k < diffuse.slots; ++k)
      mine[k] = Ray{l.position, Vec3f(0, 0, 1), 0.0f, 0.0f};
    Sampler s = diffuse.sampler(in, uint32_t(r), l);
    Vec3f weight;
    (void)l.reflected(
        in.cfg, in.scene, weight, [&](const auto& reflection) {
          return direct_light_by<kEnvironment>(in.scene, l.position, l.geometric_normal, reflection,
                                               in.cfg.area_light_samples, in.scene_radius, s,
                                               [&](uint32_t slot, const Ray& ray) {
                                                 mine[slot] = ray;
                                                 return false;
                                               });
        });
  });
}

// Each request's direct light from its shadow rays' answers, added to its leaf's value, and its
// gather request.
template <bool kEnvironment>
void shade_shadow_rays(Backend& backend, const PassInputs& in, const DiffuseLeaves& diffuse,
                       uint32_t requests, const uint8_t* is_blocked, GatherRequest* request) {
  parallel_for(backend, "shadow_ray_shade", requests, [=] CAUSTICA_HD(size_t r) {
    PathLeaf& l = diffuse.leaf[diffuse.diffuse_at[r]];
    const uint8_t* mine = is_blocked + r * diffuse.slots;
    Sampler s = diffuse.sampler(in, uint32_t(r), l);
    Vec3f weight;
    l.value +=
        l.reflected(in.cfg, in.scene, weight, [&](const auto& reflection) {
          return direct_light_by<kEnvironment>(
              in.scene, l.position, l.geometric_normal, reflection, in.cfg.area_light_samples,
              in.scene_radius, s, [&](uint32_t slot, const Ray&) { return mine[slot] == 0; });
        });
    request[r] = {l.position, l.normal, weight, l.pixel,
                  uint32_t(r) - diffuse.pixel_offset[l.pixel]};
  });
}

// Stage 2 through ray queues: what walk_specular_paths computes, for any BatchStructureView.
template <typename Structure>
SpecularPaths walk_specular_queues(Backend& backend, const Structure& structure,
                                   const PassInputs& in, const Hit* primary) {
  SpecularPaths out = SpecularPaths::for_pixels(backend, in.pixels);
  Buffer<PathLeaf> leaves = trace_specular_waves(backend, structure, in, primary);
  const size_t n = leaves.size();
  const Buffer<uint32_t> order = order_leaves(backend, leaves);
  // Per pixel: its leaves and its diffuse hits, counted, then their offsets.
  Buffer<uint32_t> leaf_counts(backend, in.pixels), leaf_offsets(backend, in.pixels);
  leaf_counts.fill_zero();
  out.counts.fill_zero();
  uint32_t* leaf_count = leaf_counts.data();
  uint32_t* diffuse_count = out.counts.data();
  PathLeaf* leaf = leaves.data();
  parallel_for(backend, "leaf_counts", n, [=] CAUSTICA_HD(size_t i) {
    atomic_fetch_add(leaf_count + leaf[i].pixel, 1u);
    if (leaf[i].diffuse) atomic_fetch_add(diffuse_count + leaf[i].pixel, 1u);
  });
  backend.exclusive_scan(leaf_count, leaf_offsets.data(), in.pixels);
  out.request_total = backend.exclusive_scan(diffuse_count, out.offsets.data(), in.pixels);
  // The diffuse leaves in pixel and path order: request r is the r-th.
  const uint32_t requests = out.request_total;
  Buffer<uint32_t> diffuse_rank(backend, n + 1), diffuse_leaf(backend, requests);
  uint32_t* rank = diffuse_rank.data();
  const uint32_t* ordered = order.data();
  parallel_for(backend, "leaf_diffuse_flags", n + 1, [=] CAUSTICA_HD(size_t j) {
    rank[j] = j < n && leaf[ordered[j]].diffuse ? 1u : 0u;
  });
  backend.exclusive_scan(rank, rank, n + 1);
  uint32_t* diffuse_at = diffuse_leaf.data();
  parallel_for(backend, "leaf_diffuse_list", n, [=] CAUSTICA_HD(size_t j) {
    if (rank[j + 1] != rank[j]) diffuse_at[rank[j]] = ordered[j];
  });

  // Shadow rays: every slot direct_light_with may use, empty where it asks for none.
  const uint32_t slots = direct_light_slots(in.scene, in.cfg.area_light_samples);
  const uint32_t dimensions = direct_light_dimensions(in.scene, in.cfg.area_light_samples);
  const size_t shadow_count = size_t(requests) * slots;
  Buffer<Ray> shadow_rays(backend, shadow_count);
  Buffer<uint8_t> blocked(backend, shadow_count);
  Ray* shadow = shadow_rays.data();
  const DiffuseLeaves diffuse{leaf, diffuse_at, out.offsets.data(), slots, dimensions};
  (in.scene.has_environment ? queue_shadow_rays<true>
                            : queue_shadow_rays<false>)(backend, in, diffuse, requests, shadow);
  trace_any_surfaces(backend, structure, in.scene, shadow_rays.data(), shadow_count,
                     blocked.data());
  out.requests.resize_discard(requests);
  (in.scene.has_environment ? shade_shadow_rays<true>
                            : shade_shadow_rays<false>)(backend, in, diffuse, requests,
                                                        blocked.data(), out.requests.data());
  // Each pixel's emitted and direct light summed in its walk's order.
  Vec3f* direct_out = out.direct.data();
  const uint32_t* first_leaf = leaf_offsets.data();
  parallel_for(backend, "specular_leaves_sum", in.pixels, [=] CAUSTICA_HD(size_t pixel) {
    Vec3f emitted(0.0f), direct(0.0f);
    const uint32_t begin = first_leaf[pixel], end = begin + leaf_count[pixel];
    for (uint32_t j = begin; j < end; ++j) {
      const PathLeaf& l = leaf[ordered[j]];
      if (l.diffuse) {
        direct += l.throughput * l.value;
      } else {
        emitted += l.throughput * l.value;
      }
    }
    direct_out[pixel] = emitted + direct;
  });
  return out;
}

// Stage 3: the requests in Hilbert order of their positions, so that the threads of a warp
// search the same nodes and photons. Morton order jumps where Hilbert order does not, which puts
// a warp's requests farther apart and slows the render pass (docs/performance.md).
// The sort keeps equal codes in the order it is given them, and stage 2 appended the requests
// in whatever order the walks ended. So they go to the sort in pixel and path order: taken in
// append order, requests on one grid cell (pixels that a curved mirror shrinks onto one spot)
// met their neighbours in an order that changed from run to run, and with it the order each
// estimate summed its photons, the last bit of a few pixels.
CurveOrder order_gather_requests(Backend& backend, const PassInputs& in,
                                 const SpecularPaths& paths) {
  Buffer<uint32_t> requests_in_pixel_order(backend, paths.request_total);
  uint32_t* in_pixel_order = requests_in_pixel_order.data();
  const GatherRequest* request = paths.requests.data();
  const uint32_t* offset = paths.offsets.data();
  const Aabb scene_bounds = in.scene_bounds;
  parallel_for(backend, "gather_pixel_order", paths.request_total, [=] CAUSTICA_HD(size_t slot) {
    in_pixel_order[offset[request[slot].pixel] + request[slot].order] = uint32_t(slot);
  });
  return sort_by_code(
      backend, paths.request_total, 30,
      [=] CAUSTICA_HD(uint32_t i) { return hilbert_code(request[i].position, scene_bounds); },
      [=] CAUSTICA_HD(uint32_t rank) { return in_pixel_order[rank]; });
}

// Stage 5: each pixel adds its direct light and its requests' estimates in path order, so the
// sum is the same on every backend and every run, whatever order the requests were appended in.
void accumulate_film(Backend& backend, const SpecularPaths& paths, const Buffer<Vec3f>& gathered,
                     Film& film) {
  const Vec3f* gathered_at = gathered.data();
  const Vec3f* direct = paths.direct.data();
  const uint32_t* offset = paths.offsets.data();
  const uint32_t* count = paths.counts.data();
  Vec3f* accum = film.accumulator();
  parallel_for(backend, "film_accumulate", paths.direct.size(), [=] CAUSTICA_HD(size_t pixel) {
    const uint32_t begin = offset[pixel], end = begin + count[pixel];
    Vec3f sum = direct[pixel];
    for (uint32_t r = begin; r < end; ++r) sum += gathered_at[r];
    accum[pixel] += sum;
  });
  film.add_pass();
}

// The render pass with rays traced through `structure`, the view of the scene's structure.
template <typename Structure>
void render_pass_through(const Structure& structure, Backend& backend,
                         const ResidentScene& resident, const PinholeCamera& camera,
                         const ShadingSettings& settings, const RadianceGather& gather, Film& film,
                         uint32_t* requests) {
  const PassInputs in(resident, camera, settings);
  if (resident.has_media() && (settings.ray_queues || !StructureView<Structure>)) {
    throw std::invalid_argument(
        "participating media: the ray queues do not trace through media yet; render the scene "
        "with a structure that answers single rays (every one but dacrt)");
  }
  SpecularPaths paths;
  {
    const Buffer<Hit> primary = trace_camera_rays(backend, structure, in);
    if constexpr (StructureView<Structure>) {
      if (settings.ray_queues) {
        paths = walk_specular_queues(backend, structure, in, primary.data());
      } else {
        // Media bring the environment's and the surface maps' code along, and surface maps the
        // environment's: few scenes have them, fewer lack a sky then.
        const bool surface_maps = in.scene.has_normal_maps || in.scene.has_cutouts;
        paths = resident.has_media()
                    ? walk_specular_paths<true, true, true>(backend, structure, in, primary.data())
                : surface_maps
                    ? walk_specular_paths<false, true, true>(backend, structure, in, primary.data())
                : in.scene.has_environment
                    ? walk_specular_paths<false, true, false>(backend, structure, in, primary.data())
                    : walk_specular_paths<false, false, false>(backend, structure, in,
                                                               primary.data());
      }
    } else {
      paths = walk_specular_queues(backend, structure, in, primary.data());
    }
  }
  const CurveOrder request_order = order_gather_requests(backend, in, paths);
  Buffer<Vec3f> gathered(backend, paths.request_total);
  gather.gather(backend,
                {paths.requests.data(), request_order.order.data(), paths.offsets.data(),
                 paths.request_total},
                settings, gathered.data());
  accumulate_film(backend, paths, gathered, film);
  if (requests != nullptr) *requests = paths.request_total;
}

}  // namespace

void render_pass(Backend& backend, const ResidentScene& resident, const PinholeCamera& camera,
                 const ShadingSettings& settings, const RadianceGather& gather, Film& film,
                 uint32_t* requests) {
  resident.structure().visit([&](const auto& structure) {
    render_pass_through(structure, backend, resident, camera, settings, gather, film, requests);
  });
}

}  // namespace caustica
