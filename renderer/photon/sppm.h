// Stochastic progressive photon mapping (Hachisuka and Jensen 2009): each pixel keeps a radius,
// a photon count and a flux sum across passes. Every pass its new visible point collects the
// photons within its radius by a range query on the photon map (range_query.h), and the radius
// shrinks so that a fraction alpha of the new photons is kept: N' = N + alpha M,
// r'^2 = r^2 N' / (N + M), tau' = (tau + Phi) r'^2 / r^2. The estimate tau / (n pi r^2) after n
// passes converges to the radiance as the radius goes to zero. With Knaus and Zwicker's (2011)
// rule every pixel's radius follows one sequence instead, r_i^2 = r_1^2 prod_{j<i} (j + alpha) /
// (j + 1), and each pass's estimate is independent of the others.
//
// A pixel's first radius follows the photons' density at its first visible point, dense caustics
// small and dim corners wide: the disk that would hold its k nearest photons, estimated from the
// distance d to its kSppmInitialSearch-th nearest as r^2 = d^2 k / kSppmInitialSearch (the
// expected squared distance grows with the count), capped at the maximum gather radius. The small
// search keeps the first pass's cost near the others'.
#pragma once

#include <cstdint>

#include "renderer/base/pixel_blocks.h"
#include "renderer/parallel/backend.h"
#include "renderer/photon/photon_map.h"
#include "renderer/scene/setting_kinds.h"

namespace caustica {

constexpr uint32_t kSppmInitialSearch = 16;

// A pixel's first diffuse hit in one pass; a zero weight when its path met none.
struct VisiblePoint {
  Vec3f position;
  Vec3f normal;  // facing the viewer
  Vec3f weight;  // the path's throughput times the albedo
};

// A pixel's statistics, zero until its first visible point and after every reset.
struct SppmPixel {
  float radius_squared;  // kPixel: the current radius; kGlobal: the first radius
  float photons;         // kPixel: N; kGlobal: unused
  Vec3f flux;            // kPixel: tau; kGlobal: the sum of each pass's Phi / r_i^2
};

struct SppmGather {
  float alpha = 0.7f;
  SppmRadius rule = SppmRadius::kPixel;
  uint32_t initial_nearest = 64;  // k for the first radius
  float max_radius = 1.0f;
  // kGlobal: r_i^2 / r_1^2 for this pass, sppm_global_shrink(i).
  float global_shrink = 1.0f;
};

// prod_{j=1}^{i-1} (j + alpha) / (j + 1): pass i's squared radius over the first's (i from 1).
double sppm_global_shrink(uint32_t pass_number, float alpha);

// One pass: every pixel's visible point (all `blocks` of the image) gathers from `map`, its
// statistics are updated, and the film's sum becomes its light sum plus passes x its photon
// estimate (so that the film's mean is the SPPM image). `light` is each pixel's emitted and direct
// light summed over the passes.
void sppm_gather(Backend& backend, const PhotonMapView& map, const VisiblePoint* points,
                 const Vec3f* light, SppmPixel* pixels, Vec3f* film_sum, const PixelBlocks& blocks,
                 const SppmGather& settings);

}  // namespace caustica
