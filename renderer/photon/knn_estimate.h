// The k-nearest-neighbour radiance estimate: the k nearest photons within a maximum radius (the
// range query of range_query.h shrunk to the current k-th distance, kept in neighbour_heap.h's
// heap), and L = f_r / (pi r^2) * sum w(d/r) dPhi with a density kernel (density_kernel.h)
// (Jensen 2001 sec. 7.2).
//
// A carried bound makes many searches cheaper without changing what they find: the k-th distance
// at a nearby point q bounds it at p by r_k(q) + |p - q| (the k photons within r_k(q) of q lie
// within that of p), so a search can start from that radius instead of the maximum and offer its
// heap only photons that may belong to it.
#pragma once

#include <cmath>

#include "renderer/photon/density_kernel.h"
#include "renderer/photon/neighbour_heap.h"
#include "renderer/photon/range_query.h"

namespace caustica {

// Finds the (up to) k photons nearest to `p` with squared distance < max_distance_squared and
// leaves them in `heap` (heap.size of them). Every member of `group` must make this call with the
// same map and k.
template <typename Pairs>
CAUSTICA_HDI uint32_t find_nearest(const PhotonMapView& map, Vec3f p, uint32_t k,
                                   float max_distance_squared, NeighbourHeap<Pairs>& heap,
                                   SearchGroup group = {}) {
  heap.size = 0;
  if (k == 0) return 0;
  float limit = max_distance_squared;  // shrinks to the k-th distance once the heap is full
  for_each_photon_within(map, p, limit, group, [&](float d2, uint32_t index) {
    limit = min_f(limit, heap.offer({d2, index}, k));
  });
  return heap.size;
}

// An estimate and the squared radius its photons were gathered from.
struct RadianceEstimate {
  Vec3f radiance;
  float radius_squared;
};

// A squared radius within which the k nearest photons of `p` surely lie, given the squared
// radius `near_radius_squared` that held them at the nearby point `near`: (r + |p - near|)^2,
// widened by 1e-4 for rounding.
CAUSTICA_HDI float carried_radius_squared(float near_radius_squared, Vec3f near, Vec3f p) {
  const float r = (sqrtf(near_radius_squared) + length(p - near)) * 1.0001f;
  return r * r;
}

// Reflected radiance at a diffuse point from the photons of `map` arriving on the side of
// `normal`: (albedo / pi) * sum w dPhi / (pi r^2), with r the k-th distance, or the maximum
// radius when fewer than k photons lie within it. `bound_squared`, when below the maximum, is a
// squared radius known to hold the k nearest (carried_radius_squared); should it prove too small
// the search is repeated from the maximum, so a bound changes speed, never the estimate's photons.
// `pairs` is a NeighbourHeap's storage for k.
template <typename Pairs>
CAUSTICA_HDI RadianceEstimate estimate_radiance_within(const PhotonMapView& map, Vec3f p,
                                                       Vec3f normal, Vec3f albedo, uint32_t k,
                                                       float max_radius, DensityKernel kernel,
                                                       Pairs pairs, float bound_squared,
                                                       SearchGroup group) {
  NeighbourHeap<Pairs> heap{pairs};
  const float max_d2 = max_radius * max_radius;
  // One call site for both searches, since each inlines the whole search.
  float limit = bound_squared < max_d2 ? bound_squared : max_d2;
  SearchGroup searching = group;
  bool searches = true;
  uint32_t found = 0;
  while (true) {
    if (searches) found = find_nearest(map, p, k, limit, heap, searching);
    // Rare: the members whose bound held fewer than k search again from the maximum.
    const bool missed = searches && limit < max_d2 && found < k;
    if (!group.any(missed)) break;
    searching = group.among(missed);
    searches = missed;
    limit = max_d2;
  }
  if (found == 0) return {Vec3f(0.0f), max_d2};
  const float r2 = found == k ? heap.top.distance_squared : max_d2;
  if (r2 <= 0.0f) return {Vec3f(0.0f), r2};
  Vec3f flux(0.0f);
  const float inv_r2 = 1.0f / r2;
  // Unrolled so that several photons' flux loads are in flight at once.
  CAUSTICA_UNROLL_BY(4)
  for (uint32_t i = 0; i < found; ++i) {
    const Neighbour n = heap[i];
    const PhotonFlux ph = map.flux_of(n.index);
    if (!octahedral_along(ph.incoming, normal)) continue;
    flux += ph.power * kernel_weight(kernel, n.distance_squared * inv_r2);
  }
  return {albedo * flux * (kInvPi * kInvPi * inv_r2), r2};
}

// The same for a lone search with no bound.
template <typename Pairs>
CAUSTICA_HDI Vec3f estimate_radiance(const PhotonMapView& map, Vec3f p, Vec3f normal, Vec3f albedo,
                                     uint32_t k, float max_radius, DensityKernel kernel,
                                     Pairs pairs) {
  return estimate_radiance_within(map, p, normal, albedo, k, max_radius, kernel, pairs, INFINITY,
                                  {})
      .radiance;
}

}  // namespace caustica
