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

namespace {

// The photons of one map, or of two read as one run: the second's photon i is photon
// first_count + i. Kernels pick a set by comparing indices, not from arrays, which a GPU would
// index in local memory.
struct PhotonSets {
  const Photon* first;
  uint32_t first_count;
  const Photon* second;  // null for one set
  uint32_t second_count;

  CAUSTICA_HDI const Photon& operator[](uint32_t i) const {
    return i < first_count ? first[i] : second[i - first_count];
  }
};

// Launches the hierarchy's build over `map`'s photons, in curve order, from the codes of its
// `leaves` leaves and the photons' bounds in `summary`; finish_map_hierarchy ends it.
void launch_map_hierarchy(Backend& backend, PhotonMap& map, const uint32_t* leaf_code,
                          uint32_t leaves, BvhSummary* summary) {
  const Vec3f* position = map.positions.data();
  const uint32_t per_leaf = map.photons_per_leaf, count = uint32_t(map.positions.size());
  map.bvh = launch_bvh_from_sorted_codes(
      backend, leaf_code, leaves, summary, [=] CAUSTICA_HD(uint32_t leaf) {
        const uint32_t end = photon_leaf_end(leaf, per_leaf, count);
        Aabb box;
        for (uint32_t i = leaf * per_leaf; i < end; ++i) box.extend(position[i]);
        return box;
      });
}

// The hierarchy's bounds and root from its summary, copied to the host, and its nodes stored as
// `nodes` says.
void finish_map_hierarchy(Backend& backend, PhotonMap& map, const BvhSummary& summary,
                          PhotonMapNodes nodes) {
  finish_bvh(map.bvh, summary);
  if (nodes == PhotonMapNodes::kSiblingPairs) {
    map.pair_nodes = encode_sibling_pairs(backend, map.bvh, map.bvh.bounds);
    map.bvh.nodes = Buffer<BvhNode>(backend, 0);
  }
}

// A map for each set of `sets` into `first_map` and, with two sets, `second_map`, each as
// build_photon_map makes it alone: every set has its own bounds, and its codes carry the set's
// index above kCurveCodeBits, so one stable sort orders each set's photons as a sort of its own
// would.
void build_maps(Backend& backend, const PhotonSets& sets, uint32_t per_leaf, Curve curve,
                PhotonMapNodes nodes, PhotonMap& first_map, PhotonMap* second_map,
                Buffer<uint32_t>* leaf_codes_out, Buffer<uint32_t>* order_out) {
  const bool two = second_map != nullptr;
  const uint32_t n0 = sets.first_count, n = n0 + (two ? sets.second_count : 0);
  Buffer<Aabb> points(backend, n);
  Aabb* point = points.data();
  parallel_for(backend, "photon_points", n, [=] CAUSTICA_HD(size_t i) {
    const Vec3f p = sets[uint32_t(i)].position;
    point[i] = Aabb{p, p};
  });
  Buffer<BvhSummary> summary(backend, two ? 2 : 1);
  BvhSummary* summaries = summary.data();
  backend.reduce_bounds_to(point, n0, &summaries[0].bounds);
  if (two) backend.reduce_bounds_to(point + n0, n - n0, &summaries[1].bounds);
  constexpr uint32_t kSecondSet = 1u << kCurveCodeBits;
  static_assert(kCurveCodeBits < 32, "a bit above the curve codes tells the sets apart");
  CurveOrder sorted_order = sort_by_code(
      backend, n, two ? kCurveCodeBits + 1 : kCurveCodeBits, [=] CAUSTICA_HD(uint32_t i) {
        return i < n0 ? curve_code(curve, point[i], summaries[0].bounds)
                      : kSecondSet | curve_code(curve, point[i], summaries[1].bounds);
      });

  // Each map's photons in curve order, split into positions and flux, and the code of each leaf's
  // first photon: ascending, so the radix tree over leaves is built like the one over photons.
  const uint32_t n1 = n - n0;
  const uint32_t leaves0 = (n0 + per_leaf - 1) / per_leaf, leaves1 = (n1 + per_leaf - 1) / per_leaf;
  Buffer<uint32_t> leaf_codes0(backend, leaves0), leaf_codes1(backend, leaves1);
  first_map.positions.resize_discard(n0);
  first_map.flux.resize_discard(n0);
  if (two) {
    second_map->positions.resize_discard(n1);
    second_map->flux.resize_discard(n1);
  }
  Vec3f* position0 = first_map.positions.data();
  PhotonFlux* flux0 = first_map.flux.data();
  Vec3f* position1 = two ? second_map->positions.data() : nullptr;
  PhotonFlux* flux1 = two ? second_map->flux.data() : nullptr;
  uint32_t* leaf_code0 = leaf_codes0.data();
  uint32_t* leaf_code1 = leaf_codes1.data();
  const uint32_t* id = sorted_order.order.data();
  const uint32_t* code = sorted_order.codes.data();
  parallel_for(backend, "photon_map_leaves", n, [=] CAUSTICA_HD(size_t sorted) {
    const Photon& ph = sets[id[sorted]];
    const bool in_first = sorted < n0;
    const size_t i = in_first ? sorted : sorted - n0;
    (in_first ? position0 : position1)[i] = ph.position;
    (in_first ? flux0 : flux1)[i] = {ph.power, encode_octahedral(ph.incoming)};
    if (i % per_leaf == 0)
      (in_first ? leaf_code0 : leaf_code1)[i / per_leaf] = code[sorted] & (kSecondSet - 1);
  });
  // Both hierarchies launched, then one wait for both summaries.
  launch_map_hierarchy(backend, first_map, leaf_code0, leaves0, &summaries[0]);
  if (two) launch_map_hierarchy(backend, *second_map, leaf_code1, leaves1, &summaries[1]);
  const std::vector<BvhSummary> done = summary.download();
  finish_map_hierarchy(backend, first_map, done[0], nodes);
  if (two) finish_map_hierarchy(backend, *second_map, done[1], nodes);
  if (leaf_codes_out != nullptr) *leaf_codes_out = std::move(leaf_codes0);
  if (order_out != nullptr) *order_out = std::move(sorted_order.order);
}

// A map with nothing in it yet, its buffers bound to `backend`.
PhotonMap empty_map(Backend& backend, uint32_t per_leaf, PhotonMapNodes nodes) {
  PhotonMap map;
  map.node_layout = nodes;
  map.photons_per_leaf = per_leaf;
  map.pair_nodes.bind(backend);
  map.positions.bind(backend);
  map.flux.bind(backend);
  map.bvh.nodes.bind(backend);
  return map;
}

}  // namespace

PhotonMap build_photon_map(Backend& backend, const Buffer<Photon>& photons,
                           uint32_t photons_per_leaf, Curve curve, PhotonMapNodes nodes,
                           Buffer<uint32_t>* leaf_codes_out, Buffer<uint32_t>* order_out) {
  const uint32_t per_leaf = photons_per_leaf > 0 ? photons_per_leaf : 1;
  PhotonMap map = empty_map(backend, per_leaf, nodes);
  if (photons.size() == 0) return map;
  build_maps(backend, PhotonSets{photons.data(), uint32_t(photons.size()), nullptr, 0}, per_leaf,
             curve, nodes, map, nullptr, leaf_codes_out, order_out);
  return map;
}

PhotonMapPair build_photon_maps(Backend& backend, const Buffer<Photon>& first,
                                const Buffer<Photon>& second, uint32_t photons_per_leaf) {
  if (first.size() == 0 || second.size() == 0) {
    return {build_photon_map(backend, first, photons_per_leaf),
            build_photon_map(backend, second, photons_per_leaf)};
  }
  const uint32_t per_leaf = photons_per_leaf > 0 ? photons_per_leaf : 1;
  PhotonMapPair pair{empty_map(backend, per_leaf, kDefaultPhotonMapNodes),
                     empty_map(backend, per_leaf, kDefaultPhotonMapNodes)};
  build_maps(
      backend,
      PhotonSets{first.data(), uint32_t(first.size()), second.data(), uint32_t(second.size())},
      per_leaf, backend_curve(backend), kDefaultPhotonMapNodes, pair.first, &pair.second, nullptr,
      nullptr);
  return pair;
}

}  // namespace caustica
