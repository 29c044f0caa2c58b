#include "renderer/render/visible_points.h"

#include <stdexcept>
#include <string>
#include <type_traits>

#include "renderer/accel/ray_queries.h"
#include "renderer/base/pixel_blocks.h"
#include "renderer/base/rng.h"
#include "renderer/parallel/parallel_for.h"
#include "renderer/photon/scattering.h"
#include "renderer/render/path_tracer.h"
#include "renderer/render/whitted.h"

namespace caustica {
namespace {

// The chain of one camera ray through `structure` to its visible point; returns the emitted and
// direct light it sees. Samples: the camera jitter's two, then the chain's.
template <typename Structure>
CAUSTICA_HDI Vec3f chain_to_visible_point(const ResidentSceneView& scene,
                                          const Structure& structure, Ray ray, float scene_radius,
                                          const VisiblePointSettings& cfg, Sampler& s,
                                          VisiblePoint& point) {
  Vec3f light(0.0f), throughput(1.0f);
  point = {Vec3f(0.0f), Vec3f(0.0f), Vec3f(0.0f)};
  for (uint32_t depth = 0;; ++depth) {
    const Hit hit = closest_hit(structure, ray);
    if (!hit.valid()) return light;  // black background
    const SurfaceHit sh = surface_at(scene, hit);
    const DeviceMaterial& m = scene.materials[sh.material];
    const Vec3f d = ray.direction;
    Vec3f next;
    switch (m.type) {
      case MaterialType::kEmissive:
        if (dot(d, sh.geometric_normal) < 0.0f) light += throughput * m.radiance;
        return light;
      case MaterialType::kDiffuse: {
        const Vec3f n = dot(d, sh.shading_normal) < 0.0f ? sh.shading_normal : -sh.shading_normal;
        light += throughput * direct_light(scene, structure, sh.position, n, sh.geometric_normal,
                                           m.color, cfg.area_light_samples, scene_radius, s);
        point = {sh.position, n, throughput * m.color};
        return light;
      }
      case MaterialType::kMirror:
        next = reflect(d, sh.shading_normal);
        throughput *= m.color;
        break;
      case MaterialType::kDielectric: {
        const DielectricSide side = dielectric_side(d, sh.shading_normal, m.ior);
        const float fr = fresnel_dielectric(side.cos_i, side.eta);
        next = reflect(d, side.normal);
        Vec3f refracted;
        if (s.next_float() >= fr && refract(d, side.normal, side.eta, refracted)) next = refracted;
        break;
      }
    }
    if (depth >= cfg.max_depth) return light;
    // From the depth where the photon integrator's trees start their roulette (whitted.h), with
    // the path tracer's cap: one chain a pixel costs little, and a lower cap multiplies a lossless
    // chain's weight into fireflies that SPPM's statistics keep for many passes.
    if (depth >= kBranchRouletteFrom) {
      const float survive = min_f(max_component(throughput), kPathSurvivalCap);
      if (!(s.next_float() < survive)) return light;
      throughput = throughput / survive;
    }
    ray = Ray{};
    ray.origin = offset_origin(sh.position, sh.geometric_normal, next);
    ray.direction = next;
  }
}

// The pass's chains through `structure`, a view that answers single rays. (A named function: nvcc
// admits no extended lambda inside the generic one that visits the views.)
template <typename Structure>
void trace_chains_through(const Structure& structure, Backend& backend,
                          const ResidentSceneView& scene, float scene_radius,
                          const PinholeCamera& camera, const VisiblePointSettings& cfg,
                          VisiblePoint* points, Vec3f* light) {
  const PixelBlocks blocks(camera.width, camera.height);
  parallel_for(backend, "visible_points", blocks.thread_count(), [=] CAUSTICA_HD(size_t thread) {
    size_t pixel;
    if (!blocks.pixel_of(thread, pixel)) return;
    Sampler s(cfg.seed, uint32_t(pixel), cfg.pass);
    const float x = float(pixel % camera.width) + s.next_float();
    const float y = float(pixel / camera.width) + s.next_float();
    light[pixel] += chain_to_visible_point(scene, structure, camera.ray_through(x, y), scene_radius,
                                           cfg, s, points[pixel]);
  });
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
      trace_chains_through(structure, backend, scene, scene_radius, camera, settings, points,
                           light);
    } else {
      throw batch_only_refusal("SPPM's camera pass", resident.structure().kind());
    }
  });
}

}  // namespace caustica
