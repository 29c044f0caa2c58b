#include "renderer/photon/photon_map.h"

#include <utility>

#include "renderer/accel/bvh_build.h"
#include "renderer/accel/curve_order.h"
#include "renderer/parallel/parallel_for.h"

namespace caustica {

std::vector<Photon> PhotonMap::download() const {
  std::vector<Vec3f> p = positions.download();
  std::vector<PhotonFlux> f = flux.download();
  std::vector<Photon> out(p.size());
  for (size_t i = 0; i < p.size(); ++i)
    out[i] = {p[i], f[i].power, decode_octahedral(f[i].incoming)};
  return out;
}

PhotonMap build_photon_map(Backend& backend, const Buffer<Photon>& photons,
                           uint32_t photons_per_leaf) {
  return build_photon_map(backend, photons, photons_per_leaf, backend_curve(backend));
}

PhotonMap build_photon_map(Backend& backend, const Buffer<Photon>& photons,
                           uint32_t photons_per_leaf, Curve curve) {
  return build_photon_map(backend, photons, photons_per_leaf, curve, kDefaultPhotonMapNodes);
}

PhotonMap build_photon_map(Backend& backend, const Buffer<Photon>& photons,
                           uint32_t photons_per_leaf, PhotonMapNodes nodes) {
  return build_photon_map(backend, photons, photons_per_leaf, backend_curve(backend), nodes);
}

PhotonMap build_photon_map(Backend& backend, const Buffer<Photon>& photons,
                           uint32_t photons_per_leaf, Curve curve, PhotonMapNodes nodes,
                           Buffer<uint32_t>* leaf_codes_out, Buffer<uint32_t>* order_out) {
  PhotonMap map;
  map.node_layout = nodes;
  map.pair_nodes.bind(backend);
  const uint32_t n = uint32_t(photons.size());
  const uint32_t per_leaf = photons_per_leaf > 0 ? photons_per_leaf : 1;
  map.photons_per_leaf = per_leaf;
  map.positions.bind(backend);
  map.flux.bind(backend);
  map.bvh.nodes.bind(backend);
  if (n == 0) return map;

  Buffer<Aabb> points(backend, n);
  Aabb* point = points.data();
  const Photon* in = photons.data();
  parallel_for(backend, "photon_points", n, [=] CAUSTICA_HD(size_t i) {
    point[i] = Aabb{in[i].position, in[i].position};
  });
  Buffer<BvhSummary> summary(backend, 1);
  backend.reduce_bounds_to(point, n, &summary.data()->bounds);
  CurveOrder sorted_order = sort_by_curve(backend, point, n, &summary.data()->bounds, curve);

  // The photons in curve order, split into positions and flux, and the code of each leaf's
  // first photon: ascending, so the radix tree over leaves is built like the one over photons.
  const uint32_t leaves = (n + per_leaf - 1) / per_leaf;
  map.positions.resize_discard(n);
  map.flux.resize_discard(n);
  Buffer<uint32_t> leaf_codes(backend, leaves);
  Vec3f* position = map.positions.data();
  PhotonFlux* flux = map.flux.data();
  uint32_t* leaf_code = leaf_codes.data();
  const uint32_t* id = sorted_order.order.data();
  const uint32_t* code = sorted_order.codes.data();
  parallel_for(backend, "photon_map_leaves", n, [=] CAUSTICA_HD(size_t i) {
    const Photon& ph = in[id[i]];
    position[i] = ph.position;
    flux[i] = {ph.power, encode_octahedral(ph.incoming)};
    if (i % per_leaf == 0) leaf_code[i / per_leaf] = code[i];
  });
  map.bvh = build_bvh_from_sorted_codes(backend, leaf_code, leaves, summary.data(),
                                        [=] CAUSTICA_HD(uint32_t leaf) {
                                          const uint32_t end = photon_leaf_end(leaf, per_leaf, n);
                                          Aabb box;
                                          for (uint32_t i = leaf * per_leaf; i < end; ++i)
                                            box.extend(position[i]);
                                          return box;
                                        });
  if (nodes == PhotonMapNodes::kSiblingPairs) {
    map.pair_nodes = encode_sibling_pairs(backend, map.bvh, map.bvh.bounds);
    map.bvh.nodes = Buffer<BvhNode>(backend, 0);
  }
  if (leaf_codes_out != nullptr) *leaf_codes_out = std::move(leaf_codes);
  if (order_out != nullptr) *order_out = std::move(sorted_order.order);
  return map;
}

}  // namespace caustica
