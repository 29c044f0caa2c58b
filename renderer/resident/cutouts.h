// Surfaces that let rays through: glTF's MASK cut-outs and BLEND stochastic transparency (MTL's
// map_d), applied where a ray meets a triangle as OptiX's any-hit programs and Embree's filter
// functions do, but outside the structures: a ray that meets a surface it passes is traced again
// from just beyond that hit, so that every structure and both ray shapes (one per thread, batches)
// see the same surfaces (docs/materials.md, "Cut-outs and transparency"). A scene without cut-outs
// pays one uniform branch per trace.
#pragma once

#include <cstddef>
#include <cstdint>
#include <cstring>

#include "renderer/accel/structure.h"
#include "renderer/base/rng.h"
#include "renderer/resident/resident_scene.h"

namespace caustica {

// The most surfaces a ray passes before the next one stops it, whatever that one's opacity.
inline constexpr uint32_t kMaxCutoutCrossings = 64;

// Material `m`'s opacity at `hit`: its factor times its map's channel there, at the finest level.
CAUSTICA_HDI float opacity_at(const ResidentSceneView& scene, const DeviceMaterial& m,
                              const Hit& hit) {
  float alpha = m.opacity;
  if (m.opacity_map != kNoTexture && scene.corner_uvs != nullptr) {
    const DeviceTextureMap& map = scene.texture_maps[m.opacity_map];
    const Texel t =
        map.view.trilinear(map.transform.apply(uv_at(scene, hit.triangle, hit.u, hit.v)), 0.0f);
    alpha *= m.opacity_channel == 3 ? t.a : t.r;
  }
  return alpha;
}

// Whether `ray` passes the surface at its hit `hit`. A blend's choice is a hash of the ray and the
// triangle, not a sampler's draw, so that a ray traced again from beyond the hit chooses alike
// (as pbrt-v4's HashFloat of the ray does). The hash leaves out the low 8 bits of each number's
// mantissa, in which the backends' arithmetic may differ, so that they mostly choose alike too.
CAUSTICA_HDI bool passes_through(const ResidentSceneView& scene, const Ray& ray, const Hit& hit) {
  const DeviceMaterial& m = scene.materials[scene.material_ids[hit.triangle]];
  if (m.alpha_mode == AlphaMode::kOpaque) return false;
  const float alpha = opacity_at(scene, m, hit);
  if (m.alpha_mode == AlphaMode::kMask) return alpha < m.alpha_cutoff;
  if (alpha >= 1.0f) return false;
  const auto bits = [](float f) {
    uint32_t u;
    memcpy(&u, &f, sizeof(u));
    return u & ~0xffu;
  };
  uint32_t h = pcg_hash(hit.triangle ^ 0x6a09e667u);
  h = pcg_hash(h ^ bits(ray.origin.x));
  h = pcg_hash(h ^ bits(ray.origin.y));
  h = pcg_hash(h ^ bits(ray.origin.z));
  h = pcg_hash(h ^ bits(ray.direction.x));
  h = pcg_hash(h ^ bits(ray.direction.y));
  h = pcg_hash(h ^ bits(ray.direction.z));
  return unit_float(h) >= alpha;
}

// The closest hit of `ray` whose surface stops it. kCutouts false compiles the cut-outs out, for
// launches whose registers are bounded and that are chosen only for scenes without them. One
// call of the traversal in a loop, not a second one after the first: kernels inline it.
template <bool kCutouts = true, typename Structure>
CAUSTICA_HDI Hit closest_surface_hit(const Structure& structure, const ResidentSceneView& scene,
                                     Ray ray) {
  for (uint32_t crossed = 0;; ++crossed) {
    const Hit hit = closest_hit(structure, ray);
    if (!kCutouts || !scene.has_cutouts || crossed == kMaxCutoutCrossings || !hit.valid() ||
        !passes_through(scene, ray, hit))
      return hit;
    // The intersection tests keep t > t_min: the surface passed is not met again.
    ray.t_min = hit.t;
  }
}

// Whether a surface between ray.t_min and ray.t_max stops `ray` (a shadow ray's test).
// kCutouts: closest_surface_hit's.
template <bool kCutouts = true, typename Structure>
CAUSTICA_HDI bool surface_blocks(const Structure& structure, const ResidentSceneView& scene,
                                 const Ray& ray) {
  if (!kCutouts || !scene.has_cutouts) return any_hit(structure, ray);
  return closest_surface_hit(structure, scene, ray).valid();
}

// The batches' counterpart: rays whose hit they pass are gathered, traced again from beyond it
// and their hits written back, until none passes. Its kernels know nothing of the structure, so
// that they are compiled once (structure.h says why a batch's lambdas must be).
class CutoutRetrace {
 public:
  CutoutRetrace(Backend& backend, size_t n);
  // Selects the rays of `rays` (n of them, with their hits) that pass their hit; returns how many,
  // whose rays from beyond the hit are rays().
  size_t select(const ResidentSceneView& scene, const Ray* rays, const Hit* hits, size_t n);
  // After hits() were traced for the selected rays: writes them to their rays' places in `hits`
  // and selects those of them that pass their new hit; returns how many.
  size_t write_back(const ResidentSceneView& scene, Hit* hits, size_t selected);
  const Ray* rays() const { return rays_.data(); }
  Hit* hits() { return hits_.data(); }
  // Keeps the selected rays that pass their hit in hits(), with their places; returns how many.
  // Public only because nvcc refuses device lambdas in private member functions.
  size_t compact(const ResidentSceneView& scene, size_t selected);

 private:
  Backend& backend_;
  Buffer<Ray> rays_, next_rays_;
  Buffer<Hit> hits_;
  // Each selected ray's index in the caller's batch; the indices among the selected that pass.
  Buffer<uint32_t> places_, next_places_, kept_;
  Buffer<uint8_t> flags_;
};

// Whether each hit of a batch is blocked (the flags of trace_any) from closest hits.
void blocked_from_hits(Backend& backend, const Hit* hits, size_t n, uint8_t* blocked);

// Moves each of `hits`, the closest hits of `rays`, on to the first surface from there that stops
// its ray.
template <typename Structure>
void continue_through_cutouts(Backend& backend, const Structure& structure,
                              const ResidentSceneView& scene, const Ray* rays, size_t n,
                              Hit* hits) {
  if (!scene.has_cutouts || n == 0) return;
  CutoutRetrace retrace(backend, n);
  size_t selected = retrace.select(scene, rays, hits, n);
  for (uint32_t i = 0; i < kMaxCutoutCrossings && selected > 0; ++i) {
    trace_closest(backend, structure, retrace.rays(), selected, retrace.hits());
    selected = retrace.write_back(scene, hits, selected);
  }
}

// trace_closest through the surfaces that let rays through.
template <typename Structure>
void trace_closest_surfaces(Backend& backend, const Structure& structure,
                            const ResidentSceneView& scene, const Ray* rays, size_t n, Hit* hits) {
  trace_closest(backend, structure, rays, n, hits);
  continue_through_cutouts(backend, structure, scene, rays, n, hits);
}

// trace_any through the surfaces that let rays through.
template <typename Structure>
void trace_any_surfaces(Backend& backend, const Structure& structure,
                        const ResidentSceneView& scene, const Ray* rays, size_t n,
                        uint8_t* blocked) {
  if (!scene.has_cutouts) {
    trace_any(backend, structure, rays, n, blocked);
    return;
  }
  Buffer<Hit> hits(backend, n);
  trace_closest_surfaces(backend, structure, scene, rays, n, hits.data());
  blocked_from_hits(backend, hits.data(), n, blocked);
}

}  // namespace caustica
