// The radiance estimate by brute force, for the photon tests: the k nearest by sorting every
// distance, their flux summed with the kernel's weights, those arriving from behind left out.
#pragma once

#include <algorithm>
#include <random>
#include <utility>
#include <vector>

#include "renderer/photon/knn_estimate.h"

namespace caustica {

struct ReferenceEstimate {
  RadianceEstimate estimate;
  // The largest channel's estimate with every weight 1: the scale of the terms that a sum split
  // by the kernel's weights (binned_estimate.h, FluxSum) rounds apart by a few ulp of.
  float unweighted;
};

inline ReferenceEstimate reference_estimate(const std::vector<Photon>& stored, Vec3f x,
                                            Vec3f normal, Vec3f albedo, uint32_t k,
                                            float max_radius, DensityKernel kernel) {
  std::vector<std::pair<float, size_t>> by_distance;
  for (size_t i = 0; i < stored.size(); ++i) {
    const float d2 = length_squared(stored[i].position - x);
    if (d2 < max_radius * max_radius) by_distance.push_back({d2, i});
  }
  std::sort(by_distance.begin(), by_distance.end());
  const size_t used = std::min<size_t>(k, by_distance.size());
  const float r2 = used == k ? by_distance[k - 1].first : max_radius * max_radius;
  if (used == 0 || r2 <= 0.0f) return {{Vec3f(0.0f), r2}, 0.0f};
  double sum[3] = {0, 0, 0}, unweighted = 0;
  for (size_t j = 0; j < used; ++j) {
    const Photon& ph = stored[by_distance[j].second];
    if (dot(ph.incoming, normal) <= 0.0f) continue;
    // d2 times 1/r2 as the renderer computes it: at the k-th photon it may fall an ulp short of
    // 1, where the Epanechnikov and cone weights are not yet 0.
    const float w = kernel_weight(kernel, by_distance[j].first * (1.0f / r2));
    for (int c = 0; c < 3; ++c) {
      sum[c] += double(ph.power[c]) * w;
      unweighted = std::max(unweighted, albedo[c] * double(ph.power[c]));
    }
  }
  Vec3f l;
  for (int c = 0; c < 3; ++c) l[c] = float(albedo[c] * sum[c] / (kPi * kPi * r2));
  return {{l, r2}, float(unweighted * double(used) / (kPi * kPi * r2))};
}

// Photons of distinct powers and directions in the slab [0, 1]^2 x [0, 0.2], so that summing a
// wrong photon shows.
inline std::vector<Photon> photons_in_slab(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::normal_distribution<float> g;
  std::vector<Photon> photons(n);
  for (auto& ph : photons) {
    ph = {Vec3f(u(rng), u(rng), 0.2f * u(rng)), Vec3f(u(rng), u(rng), u(rng)),
          normalize(Vec3f(g(rng), g(rng), g(rng)))};
  }
  return photons;
}

// `points` random points on the plane z = 0 in [0, 1]^2, `copies` unit photons on each: many
// photons at exactly the k-th distance of most queries.
inline std::vector<Photon> stacked_photons(int points, int copies, std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  std::vector<Photon> photons;
  for (int point = 0; point < points; ++point) {
    const Vec3f at(u(rng), u(rng), 0.0f);
    for (int copy = 0; copy < copies; ++copy) photons.push_back({at, Vec3f(1.0f), Vec3f(0, 0, 1)});
  }
  return photons;
}

}  // namespace caustica
