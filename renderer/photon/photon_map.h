// The photon map: photons sorted along a space-filling curve under the same Karras LBVH as the
// triangles (Fabianowski 2011 ch. 6 builds his photon map with this machinery), queried by exact
// k-nearest neighbours (range_query.h, knn_estimate.h).
//
// The hierarchy's leaves are runs of `photons_per_leaf` consecutive photons, not single photons:
// a gather then fetches one node per run instead of two per photon, and the nodes cost a few bytes
// per photon instead of 56. Positions are stored apart from power and direction, because the
// search reads every candidate's position but the estimate reads only the k winners' flux.
#pragma once

#include <vector>

#include "renderer/accel/bvh.h"
#include "renderer/accel/curve_order.h"
#include "renderer/accel/sibling_pair.h"
#include "renderer/base/octahedral.h"
#include "renderer/photon/photon.h"

namespace caustica {

constexpr uint32_t kDefaultPhotonsPerLeaf = 8;

// How the hierarchy stores its nodes, chosen when the map is built. Both hold the same tree and
// give a search the same boxes bit for bit, so the same photons in the same order; they differ in
// bytes per node and in the work to read one (docs/structures.md, "sibling-pair").
enum class PhotonMapNodes : uint32_t {
  // BvhNode (accel/bvh.h): both children's boxes in full, 64 bytes.
  kBoxPairs,
  // SiblingPairNode (accel/sibling_pair.h): the planes a child does not inherit, 32 bytes; a
  // search decodes the children's boxes from the node's own.
  kSiblingPairs,
};
constexpr PhotonMapNodes kDefaultPhotonMapNodes = PhotonMapNodes::kBoxPairs;

// One past the last photon of leaf `leaf`: leaves are runs of `per_leaf`, the last one shorter.
CAUSTICA_HDI uint32_t photon_leaf_end(uint32_t leaf, uint32_t per_leaf, uint32_t count) {
  const uint32_t end = (leaf + 1) * per_leaf;
  return end < count ? end : count;
}

// What the estimate needs of a photon besides its position, read with one 16-byte load.
struct alignas(16) PhotonFlux {  // 16 bytes: flux_of reads it as one float4
  Vec3f power;
  uint32_t incoming;  // octahedral (base/octahedral.h)
};

struct PhotonMapView {
  const BvhNode* nodes = nullptr;    // kBoxPairs; null with sibling pairs
  const Vec3f* positions = nullptr;  // curve order
  const PhotonFlux* flux = nullptr;  // same order
  uint32_t count = 0;                // photons
  uint32_t photons_per_leaf = 1;
  uint32_t leaf_count = 0;
  uint32_t root = 0;
  Aabb bounds;  // with sibling pairs, the box the root's children decode from
  const SiblingPairNode* pair_nodes = nullptr;  // kSiblingPairs, node k for the tree's node k
  PhotonMapNodes node_layout = kDefaultPhotonMapNodes;

  CAUSTICA_HDI uint32_t leaf_begin(uint32_t leaf) const { return leaf * photons_per_leaf; }
  // Photon i's flux record in one 16-byte load: read field by field, the side test waited for
  // the direction and then the power for a second round trip.
  CAUSTICA_HDI PhotonFlux flux_of(uint32_t i) const {
#if defined(__CUDA_ARCH__)
    const float4 f = __ldg(reinterpret_cast<const float4*>(flux) + i);
    return {Vec3f(f.x, f.y, f.z), __float_as_uint(f.w)};
#else
    return flux[i];
#endif
  }
  CAUSTICA_HDI uint32_t leaf_end(uint32_t leaf) const {
    return photon_leaf_end(leaf, photons_per_leaf, count);
  }
};

struct PhotonMap {
  Bvh bvh;  // over leaves of photons_per_leaf photons; no nodes with sibling pairs
  Buffer<SiblingPairNode> pair_nodes;  // the nodes with sibling pairs, else none
  Buffer<Vec3f> positions;
  Buffer<PhotonFlux> flux;
  uint32_t photons_per_leaf = kDefaultPhotonsPerLeaf;
  PhotonMapNodes node_layout = kDefaultPhotonMapNodes;

  PhotonMapView view() const {
    const bool pairs = node_layout == PhotonMapNodes::kSiblingPairs;
    return {pairs ? nullptr : bvh.nodes.data(),
            positions.data(),
            flux.data(),
            uint32_t(positions.size()),
            photons_per_leaf,
            bvh.leaf_count,
            bvh.root,
            bvh.bounds,
            pairs ? pair_nodes.data() : nullptr,
            node_layout};
  }
  size_t size() const { return positions.size(); }
  size_t bytes() const {
    return bvh.nodes.bytes() + pair_nodes.bytes() + positions.bytes() + flux.bytes();
  }
  // The photons in map order, with directions as decoded: for tests and tools.
  std::vector<Photon> download() const;
};

// Sorts `photons` along `curve` (by default the backend's, backend_curve) and builds the hierarchy
// over runs of `photons_per_leaf` (>= 1) of them, its nodes stored as `nodes` says (by default
// kDefaultPhotonMapNodes).
// `leaf_codes`, when given, gets each leaf's curve code, ascending: what a tree over the same
// leaves with other boxes is built from (volume_map.h); `order`, when given, the index in
// `photons` of each photon of the map, for what travels beside them.
PhotonMap build_photon_map(Backend& backend, const Buffer<Photon>& photons,
                           uint32_t photons_per_leaf, Curve curve, PhotonMapNodes nodes,
                           Buffer<uint32_t>* leaf_codes = nullptr,
                           Buffer<uint32_t>* order = nullptr);
PhotonMap build_photon_map(Backend& backend, const Buffer<Photon>& photons,
                           uint32_t photons_per_leaf, PhotonMapNodes nodes);
PhotonMap build_photon_map(Backend& backend, const Buffer<Photon>& photons,
                           uint32_t photons_per_leaf, Curve curve);
PhotonMap build_photon_map(Backend& backend, const Buffer<Photon>& photons,
                           uint32_t photons_per_leaf = kDefaultPhotonsPerLeaf);

// Two maps, each the one build_photon_map makes of its photons with the backend's curve and the
// default nodes, built together: one sort and one launch of each step serve both.
struct PhotonMapPair {
  PhotonMap first, second;
};
PhotonMapPair build_photon_maps(Backend& backend, const Buffer<Photon>& first,
                                const Buffer<Photon>& second,
                                uint32_t photons_per_leaf = kDefaultPhotonsPerLeaf);

}  // namespace caustica
