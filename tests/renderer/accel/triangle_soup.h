// Random triangle soups for the structure tests (the accel suite and the GPU parity suite).
#pragma once

#include <cstdint>
#include <random>
#include <vector>

#include "renderer/accel/triangle.h"

namespace caustica {

// `n` small triangles scattered over [-10, 10]^3, every 97th one repeated: duplicates and
// identical centroids stress the Morton tie-breaking.
inline std::vector<TriangleVertices> random_soup(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> pos(-10.0f, 10.0f), small(-0.6f, 0.6f);
  std::vector<TriangleVertices> tris(n);
  for (auto& t : tris) {
    Vec3f c(pos(rng), pos(rng), pos(rng));
    t = {c + Vec3f(small(rng), small(rng), small(rng)),
         c + Vec3f(small(rng), small(rng), small(rng)),
         c + Vec3f(small(rng), small(rng), small(rng))};
  }
  for (size_t i = 0; i + 1 < n; i += 97) tris[i + 1] = tris[i];
  return tris;
}

}  // namespace caustica
