// The camera side of progressive photon mapping: one visible point per pixel and pass (Hachisuka
// and Jensen 2009). A jittered camera ray follows one branch through mirrors and glass (drawn by
// the Fresnel reflectance, as the path tracer does) to its first diffuse hit, where direct light
// comes from shadow rays and the photons will supply the rest. Russian roulette ends deep chains
// by their throughput, the depth cap being a safety net, as in the photon integrator's trees.
#pragma once

#include <cstdint>
#include <stdexcept>

#include "renderer/parallel/backend.h"
#include "renderer/photon/sppm.h"
#include "renderer/render/camera.h"
#include "renderer/resident/resident_scene.h"
#include "renderer/resident/surface_bsdf.h"

namespace caustica {

struct VisiblePointSettings {
  uint32_t max_depth = 64;  // specular bounces
  uint32_t area_light_samples = 4;
  uint32_t seed = 1;
  uint32_t pass = 0;
  // Trace the chains as ray queues (batches of closest and any hits) even where the structure
  // answers single rays; structures that answer batches only always do. The points are the same.
  bool ray_queues = false;
  // ShadingSettings::near_specular_alpha.
  float near_specular_alpha = kNearSpecularAlpha;
};

// Each pixel's visible point (photon/sppm.h) of pass `settings.pass` into `points`, and the emitted
// and direct light its chain sees added to `light` (both camera.width x camera.height, row-major):
// one chain per thread where the structure answers single rays, else (and when asked) as ray
// queues.
void trace_visible_points(Backend& backend, const ResidentScene& scene, const PinholeCamera& camera,
                          const VisiblePointSettings& settings, VisiblePoint* points, Vec3f* light);

// Refuses `structure` for `who`, which traces one ray at a time: the error to throw when a
// structure answers batches only (the path integrator's).
std::invalid_argument batch_only_refusal(const char* who, StructureKind structure);

}  // namespace caustica
