// Unbiased path tracing (Kajiya 1986), the reference the photon mapper is checked against
// (settings.integrator "path"): camera paths bounce off diffuse surfaces by cosine-weighted
// sampling and follow mirrors and dielectrics (one Fresnel branch drawn by its reflectance);
// point, spot and directional lights are reached by shadow rays alone (next-event estimation),
// area lights both by a shadow ray to a point drawn on one of them and by the paths that hit
// them, the two weighed by the power heuristic (Veach 1997, multiple importance sampling).
// In participating media a free flight before each surface hit may scatter the path by the phase
// function instead, with shadow rays to the lights from there; every shadow ray is attenuated by
// the transmittance of its way (docs/media.md). Russian roulette ends paths by their throughput;
// a bounce cap only stops the rare path that roulette keeps alive between lossless mirrors. One
// source for both backends.
#pragma once

#include "renderer/parallel/backend.h"
#include "renderer/render/camera.h"
#include "renderer/render/film.h"
#include "renderer/resident/resident_scene.h"

namespace caustica {

// The bounces at most, a safety net: Russian roulette ends paths long before.
constexpr uint32_t kPathSafetyBounces = 1024;
// Bounces after which Russian roulette may end a path, with survival probability its throughput's
// largest channel (at most kPathSurvivalCap).
constexpr uint32_t kPathRouletteFrom = 3;
constexpr float kPathSurvivalCap = 0.95f;

struct PathSettings {
  uint32_t seed = 1;
  uint32_t pass = 0;
};

// Adds one pass of path tracing, one jittered path per pixel, to the film. The scene's structure
// must answer single rays (StructureView): throws std::invalid_argument naming it when it answers
// batches only (dacrt).
void render_path_pass(Backend& backend, const ResidentScene& scene, const PinholeCamera& camera,
                      const PathSettings& settings, Film& film);

}  // namespace caustica
