#include "renderer/photon/volume_map.h"

#include <stdexcept>
#include <utility>

#include "renderer/accel/bvh_build.h"
#include "renderer/accel/curve_order.h"
#include "renderer/parallel/parallel_for.h"
#include "renderer/photon/neighbour_heap.h"
#include "renderer/photon/range_query.h"

namespace caustica {

namespace {

// The beams' tree: the points' leaves and codes, each leaf's box its spheres' bounds.
void build_beams(Backend& backend, VolumeMap& map, const Buffer<uint32_t>& leaf_codes) {
  const uint32_t n = uint32_t(map.points.size());
  const uint32_t per_leaf = map.points.photons_per_leaf;
  const uint32_t leaves = uint32_t(leaf_codes.size());
  Buffer<Aabb> leaf_boxes(backend, leaves);
  Aabb* leaf_box = leaf_boxes.data();
  const Vec3f* position = map.points.positions.data();
  const float* bandwidth = map.bandwidth.data();
  parallel_for(backend, "volume_beam_boxes", leaves, [=] CAUSTICA_HD(size_t leaf) {
    const uint32_t end = photon_leaf_end(uint32_t(leaf), per_leaf, n);
    Aabb box;
    for (uint32_t i = uint32_t(leaf) * per_leaf; i < end; ++i) {
      const Vec3f h(bandwidth[i]);
      box.extend(Aabb{position[i] - h, position[i] + h});
    }
    leaf_box[leaf] = box;
  });
  Buffer<BvhSummary> summary(backend, 1);
  backend.reduce_bounds_to(leaf_box, leaves, &summary.data()->bounds);
  map.beams =
      build_bvh_from_sorted_codes(backend, leaf_codes.data(), leaves, summary.data(),
                                  [=] CAUSTICA_HD(uint32_t leaf) { return leaf_box[leaf]; });
}

// The map's points over `collisions`, its bandwidths room for one each; the leaves' codes and
// (when asked) each point's index in `collisions` for what the builders add.
VolumeMap volume_map_points(Backend& backend, const Buffer<Photon>& collisions,
                            uint32_t photons_per_leaf, Buffer<uint32_t>& leaf_codes,
                            Buffer<uint32_t>* order = nullptr) {
  VolumeMap map;
  map.points = build_photon_map(backend, collisions, photons_per_leaf, backend_curve(backend),
                                PhotonMapNodes::kBoxPairs, &leaf_codes, order);
  map.bandwidth.bind(backend);
  map.beams.nodes.bind(backend);
  map.bandwidth.resize_discard(map.points.size());
  return map;
}

}  // namespace

VolumeMap build_volume_map(Backend& backend, const Buffer<Photon>& collisions,
                           uint32_t photons_per_leaf, uint32_t k, float max_bandwidth) {
  Buffer<uint32_t> leaf_codes(backend, 0);
  VolumeMap map = volume_map_points(backend, collisions, photons_per_leaf, leaf_codes);
  const uint32_t n = uint32_t(map.points.size());
  if (n == 0) return map;

  // Each collision's bandwidth: the distance to its k-th nearest, found in the points' tree.
  float* bandwidth = map.bandwidth.data();
  const PhotonMapView points = map.points.view();
  const uint32_t nearest = k < 1 ? 1 : (k > kMaxNearest ? kMaxNearest : k);
  const float max_d2 = max_bandwidth * max_bandwidth;
  // The collisions are in curve order, so a warp's lanes search neighbouring points and walk the
  // tree as one search group.
  parallel_for(backend, "volume_bandwidths", n, [=] CAUSTICA_HD(size_t i) {
    NeighbourPair pairs[NeighbourHeap<NeighbourPair*>::pairs_for(kVolumeNearest)];
    NeighbourHeap<NeighbourPair*> heap{pairs};
    const uint32_t wanted = nearest < kVolumeNearest ? nearest : kVolumeNearest;
    float limit = max_d2;
    for_each_photon_within(points, points.positions[i], limit, launch_warp(i, n),
                           [&](float d2, uint32_t index) {
                             limit = min_f(limit, heap.offer({d2, index}, wanted));
                           });
    bandwidth[i] = heap.size == wanted ? sqrtf(limit) : max_bandwidth;
  });
  build_beams(backend, map, leaf_codes);
  return map;
}

VolumeMap build_volume_map(Backend& backend, const Buffer<Photon>& collisions,
                           const Buffer<float>& footprint_volumes, uint32_t photons_per_leaf,
                           const VolumeKernelSettings& settings) {
  if (footprint_volumes.size() != collisions.size())
    throw std::invalid_argument("build_volume_map: collisions traced without differentials");
  Buffer<uint32_t> leaf_codes(backend, 0), order(backend, 0);
  VolumeMap map = volume_map_points(backend, collisions, photons_per_leaf, leaf_codes, &order);
  const uint32_t n = uint32_t(map.points.size());
  if (n == 0) return map;
  float* bandwidth = map.bandwidth.data();
  const float* volume = footprint_volumes.data();
  const uint32_t* from = order.data();
  const VolumeKernelSettings s = settings;
  parallel_for(backend, "volume_differential_bandwidths", n, [=] CAUSTICA_HD(size_t i) {
    bandwidth[i] = differential_bandwidth(volume[from[i]], s);
  });
  build_beams(backend, map, leaf_codes);
  return map;
}

}  // namespace caustica
