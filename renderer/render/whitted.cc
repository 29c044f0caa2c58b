#include "renderer/render/whitted.h"

#include "renderer/accel/camera_tiles.h"
#include "renderer/base/pixel_blocks.h"
#include "renderer/base/rng.h"
#include "renderer/parallel/parallel_for.h"
#include "renderer/photon/density.h"
#include "renderer/photon/scattering.h"

namespace caustica {
namespace {

struct PendingRay {
  Ray ray;
  Vec3f throughput;
  uint32_t depth;
};

}  // namespace

void render_pass(Backend& backend, const ResidentScene& resident, const PhotonMap& caustic_map,
                 const PhotonMap& global_map, const PinholeCamera& camera,
                 const ShadingSettings& settings, Film& film) {
  const ResidentSceneView scene = resident.view();
  const PhotonMapView caustics = caustic_map.view();
  const PhotonMapView global = global_map.view();
  const ShadingSettings cfg = settings;
  const float scene_radius = resident.radius();
  const uint32_t k = cfg.k_nearest < kMaxNearest ? cfg.k_nearest : kMaxNearest;
  const uint32_t max_depth = cfg.max_depth < kMaxSpecularDepth ? cfg.max_depth : kMaxSpecularDepth;
  Vec3f* accum = film.accumulator();
  const int width = camera.width, height = camera.height;
  const uint32_t seed = cfg.seed, pass = cfg.pass;
  // The jittered camera ray of a pixel: the first two dimensions of its sample stream.
  auto camera_ray = [=] CAUSTICA_HD(size_t pixel, Sampler& s) {
    float x = float(pixel % width) + s.next_float();
    float y = float(pixel / width) + s.next_float();
    return camera.ray_through(x, y);
  };

  // Stage 1: primary hits, traced as packets of kPacketTile^2 camera rays sharing the eye.
  Buffer<Hit> primary_hits(backend, size_t(width) * height);
  Hit* primary = primary_hits.data();
  trace_camera_tiles(backend, scene.bvh, camera.origin, width, height,
                     [=] CAUSTICA_HD(size_t pixel) {
                       Sampler s(seed, uint32_t(pixel), pass);
                       return camera_ray(pixel, s).direction;
                     },
                     primary);

  // Stage 2: shading, one pixel per thread, a warp per 8x4 pixels so that its gathers query
  // neighbouring points.
  const PixelBlocks blocks(width, height);
  parallel_for(backend, blocks.thread_count(), [=] CAUSTICA_HD(size_t thread) {
    size_t pixel;
    if (!blocks.pixel_of(thread, pixel)) return;
    Sampler s(seed, uint32_t(pixel), pass);
    // Depth-first over the specular tree: each dielectric hit adds at most one pending branch.
    PendingRay stack[kMaxSpecularDepth + 2];
    int top = 0;
    stack[top++] = {camera_ray(pixel, s), Vec3f(1.0f), 0};
    bool camera_ray_pending = true;
    Neighbour heap[kMaxNearest];
    Vec3f radiance(0.0f);
    while (top > 0) {
      PendingRay pr = stack[--top];
      Hit hit = camera_ray_pending ? primary[pixel] : closest_hit(scene.bvh, pr.ray);
      camera_ray_pending = false;
      if (!hit.valid()) continue;  // black background
      SurfaceHit sh = surface_at(scene, hit);
      const DeviceMaterial& m = scene.materials[sh.material];
      Vec3f d = pr.ray.direction;
      auto spawn = [&](Vec3f dir, Vec3f throughput) {
        if (pr.depth >= max_depth || max_component(throughput) <= 0.0f) return;
        Ray r;
        r.origin = offset_origin(sh.position, sh.geometric_normal, dir);
        r.direction = dir;
        stack[top++] = {r, throughput, pr.depth + 1};
      };
      switch (m.type) {
        case MaterialType::kEmissive:
          if (dot(d, sh.geometric_normal) < 0.0f) radiance += pr.throughput * m.radiance;
          break;
        case MaterialType::kDiffuse: {
          Vec3f n = dot(d, sh.shading_normal) < 0.0f ? sh.shading_normal : -sh.shading_normal;
          Vec3f l = direct_light(scene, sh.position, n, sh.geometric_normal, m.color,
                                 cfg.area_light_samples, scene_radius, s);
          l += estimate_radiance(caustics, sh.position, n, m.color, k, cfg.max_radius, cfg.kernel, heap);
          l += estimate_radiance(global, sh.position, n, m.color, k, cfg.max_radius, cfg.kernel, heap);
          radiance += pr.throughput * l;
          break;
        }
        case MaterialType::kMirror:
          spawn(reflect(d, sh.shading_normal), pr.throughput * m.color);
          break;
        case MaterialType::kDielectric: {
          DielectricSide side = dielectric_side(d, sh.shading_normal, m.ior);
          float fr = fresnel_dielectric(side.cos_i, side.eta);
          Vec3f refracted;
          if (fr < 1.0f && refract(d, side.normal, side.eta, refracted))
            spawn(refracted, pr.throughput * (1.0f - fr));
          spawn(reflect(d, side.normal), pr.throughput * fr);
          break;
        }
      }
    }
    accum[pixel] += radiance;
  });
  film.add_pass();
}

}  // namespace caustica
