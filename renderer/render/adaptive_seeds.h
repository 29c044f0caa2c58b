// Adaptive seeding of final-gather points in a screen-space quadtree (Wang et al. 2009, as Zeidan
// 2011 sec. 6.2.3.1 builds it): the gather requests' pixels' Morton codes sort them into the
// leaves of a linkless quadtree over the image; sums of position and normal go up the tree a
// level at a time; the seed budget comes down it, every node splitting its seeds among its four
// children by their geometric variation; and each leaf picks its seeds among its requests by
// jittered strides. Flat regions get few seeds, edges and corners many.
//
// The variation of a node is Wang's eta = alpha |x_i - x_k| + sqrt(2 - 2 n_i . n_k) summed over its
// requests, squared term by term here, alpha^2 |x_i - x_k|^2 + (2 - 2 n_i . n_k): squared, the
// sums follow from each node's moments (sum x, sum |x|^2, sum n), so one bottom-up pass finds
// every node's variation with no per-request, per-level work. Half of each split follows the
// variation and half the requests, so that flat regions keep some seeds.
#pragma once

#include <cstdint>

#include "renderer/parallel/buffer.h"
#include "renderer/render/whitted.h"

namespace caustica {

struct GatherSeed {
  Vec3f position;
  Vec3f normal;  // towards the viewer, as the request's
};

struct SeedingSettings {
  uint32_t width = 0, height = 0;  // of the image whose pixels the requests name
  uint32_t count = 0;              // seeds wanted; fewer when there are fewer requests
  Vec3f center{0.0f};              // positions are measured from here in units of `radius`
  float radius = 1.0f;
  // alpha in units of `radius`: a position spread of radius / alpha counts like a radian between
  // normals. Larger, position outweighs bends in all but the smallest nodes and corners get no
  // more seeds than flat walls (docs/convergence.md, "Final gathering").
  float alpha = 4.0f;
  uint32_t seed = 1, pass = 0;
};

// Levels below the root, at most: leaves of 2^(levels - 10) pixels square above 1024x1024 keep
// the tree's 1.4M nodes.
constexpr uint32_t kMaxSeedLevels = 10;

Buffer<GatherSeed> adaptive_seeds(Backend& backend, const GatherRequests& requests,
                                  const SeedingSettings& settings);

}  // namespace caustica
